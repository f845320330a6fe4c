# The simulation's state as a drawable frame (src/view): the frame scene FrameView builds from
# bodies, without a GL context.
list(APPEND DGV_TEST_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/test_frame_view.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_camera_path.cpp)
