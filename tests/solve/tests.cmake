list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_holonomy.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_reconstruct.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_gather.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_multigrid_precision.cpp
)
