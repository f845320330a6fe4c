# The simulation over frames (src/sim): substeps and retries, body-to-body contact, level-set and
# mesh colliders, driven through Simulation directly (no dgv executable).
list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_substeps.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_body_contact.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_levelset_collider.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_mesh_collider.cpp)
