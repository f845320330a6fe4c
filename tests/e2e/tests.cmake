# End-to-end tests: the dgv executable run as a user would (docs/robustness.md).
list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_bad_input.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_runs.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_checkpoints.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_write_faults.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_vdb_stats.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_shipped_scenes.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_pin_group.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_reparametrise.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_contact_probe.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_farm.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_exr_frames.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_materials_render.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_motion_blur.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_depth_of_field.cpp)
