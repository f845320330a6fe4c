list(APPEND DGV_DEFORM_SOURCES
  deform/displacement.cpp
  deform/connection_delta.cpp
  deform/sl3.cpp
  deform/volume.cpp
  deform/resample.cpp
)
