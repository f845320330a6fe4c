// `dgv bench geometry`: the geometric state (eqs 1-8) of a 128^3 box lattice (64^3 quick).
#include "bench/bench.hpp"

#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

namespace dgv::bench {

void geometry(std::ostream& out, const BenchOptions& options) {
    const int n = options.quick ? 64 : 128;
    const Vec3i dims(n, n, n);
    const Real h = 1.0 / n;
    const auto t0 = std::chrono::steady_clock::now();
    const Lattice lat =
        buildLattice(Vec3::Zero(), h, dims, std::vector<unsigned char>(static_cast<std::size_t>(n) * n * n, 1));
    const double buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    // A twist of one radian over the height, so that the connection is not trivially zero.
    std::vector<Vec3> x = restPositions(lat);
    for (Vec3& p : x) {
        const Real t = p.z(), c = std::cos(t), s = std::sin(t);
        const Real dx = p.x() - 0.5, dy = p.y() - 0.5;
        p = Vec3(0.5 + c * dx - s * dy, 0.5 + s * dx + c * dy, p.z());
    }

    GeometricState state;
    std::vector<double> seconds;
    const int repeats = std::max(1, options.repeats);
    for (int r = 0; r < repeats; ++r) {
        const auto start = std::chrono::steady_clock::now();
        computeGeometricState(lat, x, state);
        seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(seconds.begin(), seconds.end());
    const double best = seconds.front();
    const double median = seconds[seconds.size() / 2];
    out << "geometry.points: " << lat.size() << " points\n";
    out << "geometry.lattice_build: " << buildSeconds << " s\n";
    out << "geometry.state_min: " << best << " s\n";
    out << "geometry.state_median: " << median << " s\n";
    out << "geometry.points_per_second: " << static_cast<double>(lat.size()) / best << " points/s\n";
    out << "geometry.peak_rss: " << peakRssMiB() << " MiB\n";
}

}  // namespace dgv::bench
