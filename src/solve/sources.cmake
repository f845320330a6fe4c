# src/solve: holonomy and reconstruction from a connection (seed eqs 12-34, 53-59).
list(APPEND DGV_SOLVE_SOURCES
  solve/holonomy.cpp
  solve/gather.cpp
  solve/multigrid.cpp
  solve/sparse_solve.cpp
  solve/reconstruct.cpp
)
