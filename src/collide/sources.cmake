list(APPEND DGV_COLLIDE_SOURCES collide/gln_exact.cpp collide/bvh.cpp collide/box_tree.cpp collide/gln_farfield.cpp collide/gln_seed.cpp collide/curve_distance.cpp collide/gln_network.cpp collide/mesh_distance.cpp collide/sampled_distance.cpp)
# The AVX2 and scalar kernels must give bit-identical sums (tests/collide): no fused multiply-add
# contraction in either, whatever the compiler's default or -march.
set_source_files_properties(collide/gln_exact.cpp PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
