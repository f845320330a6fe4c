list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_forces.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_forces_from_scene.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_body.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_collider.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_stepper.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_cell_solve.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_stepper_long.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_contact_affine.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_body_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_plastic.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_load_modes.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_reparametrise.cpp
  ${CMAKE_CURRENT_LIST_DIR}/bench_forces.cpp
)
