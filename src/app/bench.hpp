#pragma once
// Benchmarks of `dgv bench <name>`: each prints "name: value unit" lines to `out`.
// One file per benchmark: app/bench_<name>.cpp.

#include <ostream>

namespace dgv::bench {

struct BenchOptions {
    int repeats = 3;     ///< timed repetitions; the figures printed are the minimum and median
    bool quick = false;  ///< smaller problem sizes (used by the test that runs every benchmark)
};

void geometry(std::ostream& out, const BenchOptions& options);  // bench_geometry.cpp
void voxelise(std::ostream& out, const BenchOptions& options);  // bench_voxelise.cpp
void render(std::ostream& out, const BenchOptions& options);    // bench_render.cpp
void reconstruct(std::ostream& out, const BenchOptions& options);  // bench_reconstruct.cpp
void gln(std::ostream& out, const BenchOptions& options);          // bench_gln.cpp

}  // namespace dgv::bench
