// dgv bench voxelise: voxel parametrisation of a ~100k-triangle closed torus at resolution 128
// (10k triangles with --quick). Target: under 2 s on two cores (docs/benchmarks.md).

#include "bench/bench.hpp"
#include "geom/primitives.hpp"
#include "geom/voxelise.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iomanip>
#include <string>
#include <vector>

namespace dgv::bench {

void voxelise(std::ostream& out, const BenchOptions& options) {
    // 2 * major * minor triangles: 316 x 158 -> 99,856; 100 x 50 -> 10,000.
    const int major = options.quick ? 100 : 316, minor = options.quick ? 50 : 158;
    const TriangleMesh mesh = makeTorus(1.0, 0.4, major, minor);
    VoxeliseSettings settings;
    settings.resolution = 128;

    std::vector<double> seconds;
    VoxeliseReport report;
    for (int r = 0; r < std::max(1, options.repeats); ++r) {
        const auto start = std::chrono::steady_clock::now();
        const Lattice lat = dgv::voxelise(mesh, settings, &report);
        seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(seconds.begin(), seconds.end());
    out << "voxelise.triangles: " << mesh.triangleCount() << "\n";
    out << "voxelise.points: " << report.points << " points\n";
    out << std::fixed << std::setprecision(3);
    out << "voxelise.min: " << seconds.front() << " s\n";
    out << "voxelise.median: " << seconds[seconds.size() / 2] << " s\n";
    out << "voxelise.exact_queries: " << report.exactEvaluations << "\n";
    out << std::setprecision(1) << "voxelise.peak_rss: " << peakRssMiB() << " MiB" << std::endl;
    out.unsetf(std::ios::floatfield);
}

}  // namespace dgv::bench
