list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_camera.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_renderer.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_image_compare.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_golden.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_png_queue.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_linear_planes.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_lights.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_materials.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_environment.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_contact_overlay.cpp)
