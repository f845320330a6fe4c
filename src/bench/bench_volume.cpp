// `dgv bench volume`: the per-cell volume projection (deform/volume.hpp), as the dynamics calls
// it after each reconstruction. Balls of radius 8, 16 and 32 voxels (2.1k, 17k and 137k points;
// radius 8 and 16 with --quick), deformed by a smooth non-uniform dilation (cell volume errors
// from about -5e-3 to 3e-2) and a twist, plus uniform noise of 1e-3 voxel on every point; no
// pins. For each ball, three settings:
//  - step: the dynamics' settings (tolerance 1e-5 on max_c |V_c/V0_c - 1|, else the defaults:
//    inexact Gauss-Newton, parity multigrid built on the first iteration);
//  - step_cached: the same with a VolumeProjectionCache filled by an earlier call (another
//    deformation), as the dynamics calls it every step: no multigrid setup;
//  - exact: the defaults (tolerance 1e-12).
// Printed: Gauss-Newton and conjugate-gradient iterations, seconds (min and median over the
// repeats), max cell error before and after, max point move; and the fitted growth of the
// seconds with the number of cells. Table: docs/benchmarks.md.
#include "bench/bench.hpp"

#include "deform/volume.hpp"
#include "geom/lattice.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace dgv::bench {

namespace {

/// Dilation by 1 + s(u), s = 0.005 (1 + u_x) with u = x / radius (relative volume change
/// about 3 s + 0.005 u_x), then a twist of 0.1 u_z rad about z, then noise of +-1e-3 voxel.
std::vector<Vec3> deform(const Lattice& lat, Real radius) {
    std::vector<Vec3> x = restPositions(lat);
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<Real> noise(-1e-3, 1e-3);
    for (Vec3& p : x) {
        const Vec3 u = p / radius;
        Vec3 q = p * (1 + Real(0.005) * (1 + u.x()));
        const Real t = Real(0.1) * u.z(), c = std::cos(t), s = std::sin(t);
        q = Vec3(c * q.x() - s * q.y(), s * q.x() + c * q.y(), q.z());
        p = q + Vec3(noise(rng), noise(rng), noise(rng));
    }
    return x;
}

}  // namespace

void volume(std::ostream& out, const BenchOptions& options) {
    const int repeats = std::max(1, options.repeats);
    std::vector<Real> radii = {8, 16, 32};
    if (options.quick) radii = {8, 16};
    struct Config {
        const char* name;
        VolumeProjectionSettings settings;
    };
    constexpr int kConfigs = 3;
    Config configs[kConfigs] = {{"step", {}}, {"step_cached", {}}, {"exact", {}}};
    configs[0].settings.tolerance = 1e-5;
    configs[1].settings.tolerance = 1e-5;
    std::vector<Real> logCells, logSeconds[kConfigs];
    for (Real radius : radii) {
        const Lattice lat = ballLattice(radius);
        const LatticeCells cells = buildCells(lat);
        const std::vector<Real> v0 = cellVolumes(cells, restPositions(lat));
        const std::vector<Vec3> start = deform(lat, radius);
        const std::string tag = "volume.r" + std::to_string(static_cast<int>(radius));
        out << tag << ".points: " << lat.size() << " points, " << cells.size() << " cells\n";
        logCells.push_back(std::log(Real(cells.size())));
        VolumeProjectionCache cache;
        {  // fill the cache once (a previous dynamics step), from another deformation
            std::vector<Vec3> x = deform(lat, radius * 1.5);
            VolumeProjectionSettings s = configs[1].settings;
            s.cache = &cache;
            (void)projectVolumes(cells, v0, {}, x, s);
        }
        configs[1].settings.cache = &cache;
        for (int k = 0; k < kConfigs; ++k) {
            std::vector<double> seconds;
            VolumeProjectionReport r;
            for (int rep = 0; rep < repeats; ++rep) {
                std::vector<Vec3> x = start;
                const auto t0 = std::chrono::steady_clock::now();
                r = projectVolumes(cells, v0, {}, x, configs[k].settings);
                seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            }
            const std::string key = tag + "." + configs[k].name;
            out << key << ".iterations: " << r.iterations << " Gauss-Newton, " << r.linearIterations << " CG"
                << (r.converged ? "" : " (not converged)") << "\n";
            out << key << ".seconds: " << *std::min_element(seconds.begin(), seconds.end()) << " s min, "
                << median(seconds) << " s median\n";
            out << key << ".max_error: " << r.maxErrorBefore << " before, " << r.maxErrorAfter << " after\n";
            out << key << ".max_move: " << r.maxMove << " voxels\n";
            logSeconds[k].push_back(std::log(median(seconds)));
        }
    }
    // Growth: least squares of log(seconds) on log(cells).
    for (int k = 0; k < kConfigs; ++k) {
        const std::size_t m = logCells.size();
        Real sx = 0, sy = 0, sxx = 0, sxy = 0;
        for (std::size_t i = 0; i < m; ++i) {
            sx += logCells[i];
            sy += logSeconds[k][i];
            sxx += logCells[i] * logCells[i];
            sxy += logCells[i] * logSeconds[k][i];
        }
        const Real slope = (Real(m) * sxy - sx * sy) / (Real(m) * sxx - sx * sx);
        out << "volume.growth." << configs[k].name << ": seconds ~ cells^" << slope << "\n";
    }
    out << "volume.peak_rss: " << peakRssMiB() << " MiB\n";
}

}  // namespace dgv::bench
