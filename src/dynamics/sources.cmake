# src/dynamics: force fields and the motion they drive (seed eqs 64-82).
list(APPEND DGV_DYNAMICS_SOURCES
  dynamics/forces.cpp
  dynamics/body.cpp
  dynamics/collider.cpp
  dynamics/stepper.cpp
  dynamics/cell_solve.cpp
  dynamics/stepper_one.cpp
  dynamics/body_state.cpp
  dynamics/load_modes.cpp
  dynamics/reparametrise.cpp
)
