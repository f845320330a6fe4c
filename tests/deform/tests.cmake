list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_sl3.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_displacement.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_connection_delta.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_volume.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_resample.cpp
)
