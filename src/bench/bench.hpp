#pragma once
// Benchmarks of `dgv bench <name>`: each prints "name: value unit" lines to `out`.
// One file per benchmark: bench/bench_<name>.cpp.

#include "dynamics/forces.hpp"
#include "geom/lattice.hpp"

#include <ostream>
#include <vector>

namespace dgv::bench {

struct BenchOptions {
    int repeats = 3;     ///< timed repetitions; the figures printed are the minimum and median
    bool quick = false;  ///< smaller problem sizes (used by the test that runs every benchmark)
};

/// Peak resident set size of this process since the last resetPeakRss(), in MiB (VmHWM);
/// -1 where /proc is unavailable. (bench_common.cpp)
double peakRssMiB();
/// Starts a new peak-RSS measurement (writes 5 to /proc/self/clear_refs); cmd_bench calls it
/// before each benchmark so that each reports its own peak.
void resetPeakRss();

/// A ball of material points: the grid points within `radius` voxels of the centre of an
/// (ceil(2 radius) + 3)^3 grid, spacing h, centred on the world origin. (bench_common.cpp)
Lattice ballLattice(Real radius, Real h = 1);
/// The step benchmark's gentle vortex: axis y through (−0.2, 0, 0), radius 0.6 m, 0.6 m/s²
/// (bench_common.cpp).
ForceField gentleVortex();
/// The median of `v` (the mean of the middle two for an even count; v non-empty). (bench_common.cpp)
double median(std::vector<double> v);

void geometry(std::ostream& out, const BenchOptions& options);       // bench_geometry.cpp
void voxelise(std::ostream& out, const BenchOptions& options);       // bench_voxelise.cpp
void render(std::ostream& out, const BenchOptions& options);         // bench_render.cpp
void reconstruct(std::ostream& out, const BenchOptions& options);    // bench_reconstruct.cpp
void gln(std::ostream& out, const BenchOptions& options);            // bench_gln.cpp
void step(std::ostream& out, const BenchOptions& options);           // bench_step.cpp
void vdb(std::ostream& out, const BenchOptions& options);            // bench_vdb.cpp
void volume(std::ostream& out, const BenchOptions& options);         // bench_volume.cpp
void reparametrise(std::ostream& out, const BenchOptions& options);  // bench_reparametrise.cpp
void contact(std::ostream& out, const BenchOptions& options);        // bench_contact.cpp

}  // namespace dgv::bench
