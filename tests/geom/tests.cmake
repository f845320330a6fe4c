list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_lattice.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_geometric_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_embedding.cpp
)
list(APPEND DGV_TEST_SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_triangle_mesh.cpp ${CMAKE_CURRENT_LIST_DIR}/test_primitives.cpp ${CMAKE_CURRENT_LIST_DIR}/test_voxelise.cpp)
list(APPEND DGV_TEST_SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_sdf_grid.cpp ${CMAKE_CURRENT_LIST_DIR}/test_surface_check.cpp)
