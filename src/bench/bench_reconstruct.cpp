// `dgv bench reconstruct`: positions from a deformed connection (seed eqs 53-59).
//  1. The production solver (solve/reconstruct.hpp, LeastSquares) on a ball of radius 32 voxels
//     (137,065 points; radius 10 with --quick): edge transports, frames along the tree, the
//     multigrid setup (once per lattice), a solve from the path positions, and the next step (a
//     slightly different deformation) warm-started from the last positions (and, for
//     comparison, from its own path positions), each to 1e-8 relative residual.
//  2. The seed's gather iterations on the same kind of problem, cold start, to 1e-8: Jacobi
//     (eq 26), SOR w = 1.9 (eqs 27-30) and the adaptive gain (eqs 31-34), against the production
//     solver, at N = 1e3, 1e4, 1e5 points (1e3 only with --quick), each run capped at
//     `kCapSeconds`; and the fitted growth of the iteration counts with N and with the points
//     per side n = N^(1/3). Table: docs/solvers.md.
#include "bench/bench.hpp"

#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"
#include "solve/reconstruct.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <string>
#include <vector>

namespace dgv::bench {

namespace {

struct Clock {
    std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
    std::clock_t cpu = std::clock();
    double wallSeconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall).count();
    }
    double cpuSeconds() const { return double(std::clock() - cpu) / CLOCKS_PER_SEC; }
};

/// Twist about z (`twist` rad per voxel) and a bend: the deformed positions of the ball.
std::vector<Vec3> deform(const Lattice& lat, Real twist, Real bend) {
    std::vector<Vec3> x = restPositions(lat);
    for (Vec3& p : x) {
        const Real t = twist * p.z(), c = std::cos(t), s = std::sin(t);
        p = Vec3(c * p.x() - s * p.y(), s * p.x() + c * p.y(), p.z() + bend * p.x() * p.x());
    }
    return x;
}

struct Problem {
    Lattice lat;
    EdgeTransports e;
    std::vector<Pin> pins;
    std::vector<Mat3> frames;
    std::vector<Vec3> truth;
};

/// Γ̄ from the deformed ball, its transports, the centre pin, frames along the tree.
Problem makeProblem(Real radius, Real twist, Real bend) {
    Problem pr{ballLattice(radius), {}, {}, {}, {}};
    pr.truth = deform(pr.lat, twist, bend);
    GeometricState st;
    computeGeometricState(pr.lat, pr.truth, st);
    pr.e = computeEdgeTransports(pr.lat, st.christoffel);
    std::vector<Mat3> trueFrames(static_cast<std::size_t>(pr.lat.size()));
    for (Index p = 0; p < pr.lat.size(); ++p)
        for (int a = 0; a < 3; ++a)
            trueFrames[static_cast<std::size_t>(p)].col(a) =
                st.tangent[static_cast<std::size_t>(a)][static_cast<std::size_t>(p)];
    pr.pins = centrePins(pr.lat, pr.truth, trueFrames);
    ReconstructSettings s;
    s.method = ReconstructMethod::Path;
    (void)reconstructFrames(pr.lat, pr.e, pr.pins, s, pr.frames);
    return pr;
}

constexpr double kCapSeconds = 60;

}  // namespace

void reconstruct(std::ostream& out, const BenchOptions& options) {
    const int repeats = std::max(1, options.repeats);
    // ---- 1. production solver ------------------------------------------------------------
    {
        const Real radius = options.quick ? 10 : 32;
        const Lattice lat = ballLattice(radius);
        const std::vector<Vec3> truth = deform(lat, 0.02, 0.004);
        GeometricState st;
        computeGeometricState(lat, truth, st);
        std::vector<Mat3> trueFrames(static_cast<std::size_t>(lat.size()));
        for (Index p = 0; p < lat.size(); ++p)
            for (int a = 0; a < 3; ++a)
                trueFrames[static_cast<std::size_t>(p)].col(a) =
                    st.tangent[static_cast<std::size_t>(a)][static_cast<std::size_t>(p)];
        const std::vector<Pin> pins = centrePins(lat, truth, trueFrames);
        ReconstructSettings s;  // LeastSquares, tolerance 1e-8
        std::vector<double> tTransport, tFrames, tCold, tWarm, cpuCold, cpuWarm;
        int itCold = 0, itWarm = 0, itNextPath = 0;
        Real resCold = 0, resWarm = 0, err = 0;
        double setup = 0;
        int levels = 0;
        for (int r = 0; r < repeats; ++r) {
            Clock c0;
            const EdgeTransports e = computeEdgeTransports(lat, st.christoffel);
            tTransport.push_back(c0.wallSeconds());
            Clock c1;
            std::vector<Mat3> frames;
            (void)reconstructFrames(lat, e, pins, s, frames);
            tFrames.push_back(c1.wallSeconds());
            Clock c2;
            const PoissonSolver solver(lat, fixedPositionMask(lat, pins));
            setup = c2.wallSeconds();
            levels = solver.levels();
            std::vector<Vec3> x;
            Clock c3;
            const SolveReport cold = reconstructPositions(lat, e, frames, pins, s, x, &solver);
            tCold.push_back(c3.wallSeconds());
            cpuCold.push_back(c3.cpuSeconds());
            itCold = cold.iterations;
            resCold = cold.residual;
            err = 0;
            for (Index p = 0; p < lat.size(); ++p)
                err = std::max(err, (x[static_cast<std::size_t>(p)] - truth[static_cast<std::size_t>(p)]).norm());
            // the next step: a slightly different connection, warm start from x
            GeometricState next;
            computeGeometricState(lat, deform(lat, 0.0205, 0.0041), next);
            const EdgeTransports e2 = computeEdgeTransports(lat, next.christoffel);
            std::vector<Mat3> frames2;
            (void)reconstructFrames(lat, e2, pins, s, frames2);
            ReconstructSettings warmSettings = s;
            warmSettings.startFromPath = false;
            std::vector<Vec3> fromPath;  // the same step from the path positions, for comparison
            const SolveReport pathStart = reconstructPositions(lat, e2, frames2, pins, s, fromPath, &solver);
            itNextPath = pathStart.iterations;
            Clock c4;
            const SolveReport warm = reconstructPositions(lat, e2, frames2, pins, warmSettings, x, &solver);
            tWarm.push_back(c4.wallSeconds());
            cpuWarm.push_back(c4.cpuSeconds());
            itWarm = warm.iterations;
            resWarm = warm.residual;
        }
        out << "reconstruct.points: " << lat.size() << " points\n";
        out << "reconstruct.transports_median: " << median(tTransport) << " s\n";
        out << "reconstruct.frames_path_median: " << median(tFrames) << " s\n";
        out << "reconstruct.multigrid_setup_once: " << setup << " s (" << levels << " levels)\n";
        out << "reconstruct.solve_cold_min: " << *std::min_element(tCold.begin(), tCold.end()) << " s\n";
        out << "reconstruct.solve_cold_median: " << median(tCold) << " s\n";
        out << "reconstruct.solve_cold_cpu_median: " << median(cpuCold) << " s\n";
        out << "reconstruct.solve_cold_iterations: " << itCold << " iterations\n";
        out << "reconstruct.solve_cold_residual: " << resCold << " relative\n";
        out << "reconstruct.solve_warm_min: " << *std::min_element(tWarm.begin(), tWarm.end()) << " s\n";
        out << "reconstruct.solve_warm_median: " << median(tWarm) << " s\n";
        out << "reconstruct.solve_warm_cpu_median: " << median(cpuWarm) << " s\n";
        out << "reconstruct.solve_warm_iterations: " << itWarm << " iterations\n";
        out << "reconstruct.solve_warm_residual: " << resWarm << " relative\n";
        out << "reconstruct.next_step_from_path_iterations: " << itNextPath << " iterations\n";
        out << "reconstruct.max_position_error: " << err << " voxels\n";
    }
    // ---- 2. iterations / time against N -----------------------------------------------------
    struct Method {
        const char* name;
        ReconstructMethod method;
    };
    const Method methods[] = {{"jacobi", ReconstructMethod::Jacobi},
                              {"sor", ReconstructMethod::Sor},
                              {"adaptive_gain", ReconstructMethod::AdaptiveGain},
                              {"multigrid_cg", ReconstructMethod::LeastSquares}};
    std::vector<Real> sizes = {1e3, 1e4, 1e5};
    if (options.quick) sizes = {1e3};
    struct Point {
        Real n = 0;
        int iterations = 0;
        bool converged = false;
    };
    std::vector<Point> fits[4];
    for (Real target : sizes) {
        const Real radius = std::cbrt(3 * target / (4 * Real(M_PI)));
        const Problem pr = makeProblem(radius, 0.3 / radius, 0.05 / radius);
        const std::string tag = "reconstruct.n" + std::to_string(static_cast<long long>(target));
        out << tag << ".points: " << pr.lat.size() << " points (ball radius " << radius << ")\n";
        for (int m = 0; m < 4; ++m) {
            ReconstructSettings s;
            s.method = methods[m].method;
            s.gain = 1.9;
            s.tolerance = 1e-8;
            s.maxSeconds = options.quick ? 5 : kCapSeconds;
            s.checkEvery = 10;
            std::vector<Vec3> x;  // cold start: every point at the pin (path positions for multigrid)
            Clock c;
            const SolveReport r = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, x);
            const double wall = c.wallSeconds();
            const std::string key = tag + "." + methods[m].name;
            if (r.converged) {
                out << key << ": " << r.iterations << " iterations, " << wall << " s\n";
            } else {
                out << key << ": not converged after " << wall << " s (" << r.iterations << " iterations, residual "
                    << r.residual << ")\n";
            }
            fits[m].push_back(Point{Real(pr.lat.size()), r.iterations, r.converged});
        }
    }
    // Growth exponents: least squares of log(iterations) on log(N), converged runs only.
    for (int m = 0; m < 4; ++m) {
        Real sx = 0, sy = 0, sxx = 0, sxy = 0;
        int k = 0;
        for (const Point& p : fits[m]) {
            if (!p.converged) continue;
            const Real lx = std::log(p.n), ly = std::log(Real(p.iterations));
            sx += lx;
            sy += ly;
            sxx += lx * lx;
            sxy += lx * ly;
            ++k;
        }
        const std::string key = std::string("reconstruct.growth.") + methods[m].name;
        if (k < 2 || sxx * k - sx * sx <= 0) {
            out << key << ": n/a (fewer than two converged sizes)\n";
            continue;
        }
        const Real slope = (k * sxy - sx * sy) / (k * sxx - sx * sx);
        out << key << ": iterations ~ N^" << slope << " = n^" << 3 * slope << " (n = N^(1/3) points per side)\n";
    }
    out << "reconstruct.peak_rss: " << peakRssMiB() << " MiB\n";
}

}  // namespace dgv::bench
