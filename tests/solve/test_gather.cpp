// Tests of the seed's gather iterations (src/solve/gather.hpp, eqs 20-34) and of the production
// solver (src/solve/sparse_solve.hpp, multigrid.hpp): every method converges to the same
// least-squares positions, which an independent sparse Cholesky also gives; the literal eq 26
// diverges; pins and walls; the multigrid's iteration counts; warm starts; determinism.
#include <catch2/catch.hpp>

#include "solve/multigrid.hpp"
#include "solve/reconstruct.hpp"
#include "solve/solve_fixtures.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>

using namespace dgv;
using namespace dgv::test;

namespace {

/// A twisted ball: lattice, Γ by finite differences, transports, the true positions and frames.
struct Problem {
    Lattice lat;
    std::vector<Vec3> truth;
    std::vector<Mat3> trueFrames;
    EdgeTransports e;
    std::vector<Pin> pins;
    std::vector<Mat3> frames;  ///< by Path from the pins
};

Problem twistedBall(Real radius) {
    Problem pr{sphereLattice(radius, Real(1) / (2 * radius + 2)), {}, {}, {}, {}, {}};
    pr.truth = mapped(pr.lat, twistMap(1.5));
    GeometricState st;
    computeGeometricState(pr.lat, pr.truth, st);
    pr.trueFrames = framesOf(st);
    pr.e = computeEdgeTransports(pr.lat, st.christoffel);
    pr.pins = centrePins(pr.lat, pr.truth, pr.trueFrames);
    ReconstructSettings s;
    s.method = ReconstructMethod::Path;
    REQUIRE(reconstructFrames(pr.lat, pr.e, pr.pins, s, pr.frames).converged);
    return pr;
}

/// Independent reference: min Σ_edges |x_q - x_p - D_pq|^2 with the pinned positions, by a
/// sparse Cholesky of the normal equations assembled edge by edge.
std::vector<Vec3> choleskyReference(const Problem& pr) {
    const Lattice& lat = pr.lat;
    const std::vector<unsigned char> fixed = fixedPositionMask(lat, pr.pins);
    std::vector<int> row(static_cast<std::size_t>(lat.size()), -1);
    int n = 0;
    for (Index p = 0; p < lat.size(); ++p)
        if (!fixed[p]) row[p] = n++;
    std::vector<Vec3> x(static_cast<std::size_t>(lat.size()), Vec3::Zero());
    for (const Pin& pin : pr.pins) x[pin.point] = pin.position;
    std::vector<Eigen::Triplet<Real>> t;
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, 3);
    for (Index p = 0; p < lat.size(); ++p)
        for (int slot = 1; slot < 6; slot += 2) {  // each edge once, p -> q = p + e_axis
            const Index q = lat.neighbours[p][slot];
            if (q == kNoPoint) continue;
            const Vec3 d = positionStep(lat, pr.e, pr.frames, p, slot);  // x_q - x_p ≈ d
            const int rp = row[p], rq = row[q];
            if (rp >= 0) t.emplace_back(rp, rp, 1.0);
            if (rq >= 0) t.emplace_back(rq, rq, 1.0);
            if (rp >= 0 && rq >= 0) {
                t.emplace_back(rp, rq, -1.0);
                t.emplace_back(rq, rp, -1.0);
            }
            if (rq >= 0) b.row(rq) += (d + (rp < 0 ? x[p] : Vec3::Zero())).transpose();
            if (rp >= 0) b.row(rp) += (-d + (rq < 0 ? x[q] : Vec3::Zero())).transpose();
        }
    Eigen::SparseMatrix<Real> A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<Real>> ldlt(A);
    REQUIRE(ldlt.info() == Eigen::Success);
    const Eigen::MatrixXd sol = ldlt.solve(b);
    for (Index p = 0; p < lat.size(); ++p)
        if (row[p] >= 0) x[p] = sol.row(row[p]).transpose();
    return x;
}

Real maxDiff(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    Real m = 0;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
    return m;
}

}  // namespace

TEST_CASE("gather: Jacobi, SOR and adaptive gain converge to the least-squares positions", "[solve]") {
    const Problem pr = twistedBall(4);
    const std::vector<Vec3> ref = choleskyReference(pr);
    // The production solver gives the same positions (and is exact on its own residual).
    {
        ReconstructSettings s;
        s.tolerance = 1e-12;
        std::vector<Vec3> x;
        const SolveReport r = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, x);
        REQUIRE(r.converged);
        REQUIRE(maxDiff(x, ref) < 1e-10);
    }
    struct Run {
        const char* name;
        ReconstructMethod method;
        SorForm form;
        int iterations;
    };
    Run runs[] = {{"jacobi", ReconstructMethod::Jacobi, SorForm::Standard, 0},
                  {"sor 1.9", ReconstructMethod::Sor, SorForm::Standard, 0},
                  {"sor 1.9 seed form", ReconstructMethod::Sor, SorForm::Seed, 0},
                  {"adaptive gain", ReconstructMethod::AdaptiveGain, SorForm::Standard, 0}};
    for (Run& run : runs) {
        ReconstructSettings s;
        s.method = run.method;
        s.sorForm = run.form;
        s.tolerance = 1e-11;
        s.checkEvery = 1;
        std::vector<Vec3> x;  // cold start: every point at the pin
        const SolveReport r = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, x);
        INFO(run.name);
        REQUIRE(r.converged);
        REQUIRE(r.residual <= 1e-11);
        // residual 1e-11 of the edge data bounds the position error by ~cond(L) 1e-11 |D|
        CHECK(maxDiff(x, ref) < 1e-6);
        for (const Pin& pin : pr.pins) CHECK(x[pin.point] == pin.position);
        run.iterations = r.iterations;
        if (verbose()) std::printf("gather %s: %d iterations\n", run.name, r.iterations);
    }
    // Over-relaxation pays even on this small ball (where w = 1.9 is far above the optimal
    // gain; the growth with N is measured by `dgv bench reconstruct`, docs/solvers.md).
    CHECK(runs[1].iterations < runs[0].iterations);
}

TEST_CASE("gather: the literal (summed) eq 26 diverges, the averaged one converges", "[solve]") {
    const Problem pr = twistedBall(3);
    ReconstructSettings s;
    s.method = ReconstructMethod::JacobiSummed;
    s.maxIterations = 10000;
    std::vector<Vec3> x;
    const SolveReport r = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, x);
    CHECK(r.diverged);
    CHECK_FALSE(r.converged);
    for (const Vec3& p : x) REQUIRE(std::isfinite(p.norm()));
    s.method = ReconstructMethod::Jacobi;
    std::vector<Vec3> y;
    CHECK(reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, y).converged);
}

TEST_CASE("gather: SOR with w = 1 is red-black Gauss-Seidel in both the standard and the seed form", "[solve]") {
    const Problem pr = twistedBall(3);
    const std::vector<unsigned char> fixed = fixedPositionMask(pr.lat, pr.pins);
    std::vector<Vec3> a(static_cast<std::size_t>(pr.lat.size()), Vec3::Zero()), b = a;
    GatherSettings g;
    g.method = GatherMethod::Sor;
    g.gain = 1;
    g.maxIterations = 7;
    g.sorForm = SorForm::Standard;
    (void)gatherPositions(pr.lat, pr.e, pr.frames, fixed, g, a);
    g.sorForm = SorForm::Seed;
    (void)gatherPositions(pr.lat, pr.e, pr.frames, fixed, g, b);
    CHECK(maxDiff(a, b) < 1e-14);
    // and w = 1.9 differs between the forms (the seed's applies w to the correction only)
    g.gain = 1.9;
    std::vector<Vec3> c(a.size(), Vec3::Zero()), d = c;
    g.sorForm = SorForm::Standard;
    (void)gatherPositions(pr.lat, pr.e, pr.frames, fixed, g, c);
    g.sorForm = SorForm::Seed;
    (void)gatherPositions(pr.lat, pr.e, pr.frames, fixed, g, d);
    CHECK(maxDiff(c, d) > 1e-6);
}

TEST_CASE("gather: a wall corrects points between sweeps and holds at the end", "[solve]") {
    const Problem pr = twistedBall(4);
    Real zMax = -1e30;
    for (const Vec3& p : pr.truth) zMax = std::max(zMax, p.z());
    const Real wallZ = zMax - 0.15;  // cuts the top cap off
    ReconstructSettings s;
    s.wall = [wallZ](Index, Vec3& p) {
        if (p.z() <= wallZ) return false;
        p.z() = wallZ;
        return true;
    };
    for (ReconstructMethod m : {ReconstructMethod::Sor, ReconstructMethod::LeastSquares}) {
        s.method = m;
        std::vector<Vec3> x;
        const SolveReport r = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, x);
        CHECK(r.converged);
        int held = 0;
        for (const Vec3& p : x) {
            REQUIRE(p.z() <= wallZ + 1e-15);
            held += p.z() == wallZ;
        }
        CHECK(held > 0);
        // away from the wall the shape is the unconstrained one, to the residual's accuracy
        const std::vector<Vec3> free = choleskyReference(pr);
        Real far = 0;
        for (std::size_t i = 0; i < x.size(); ++i)
            if (free[i].z() < wallZ - 0.5) far = std::max(far, (x[i] - free[i]).norm());
        CHECK(far < 0.5);
    }
}

TEST_CASE("production solver: multigrid CG matches Cholesky with several pins, warm starts, threads", "[solve]") {
    Problem pr = twistedBall(6);
    // three pinned points (positions only beyond the first): a Dirichlet problem, not a gauge
    for (Index p : {Index(0), pr.lat.size() - 1}) {
        Pin pin;
        pin.point = p;
        pin.position = pr.truth[p] + Vec3(0.01, 0, 0);
        pin.fixFrame = false;
        pr.pins.push_back(pin);
    }
    const std::vector<Vec3> ref = choleskyReference(pr);
    const std::vector<unsigned char> fixed = fixedPositionMask(pr.lat, pr.pins);
    const PoissonSolver solver(pr.lat, fixed);
    REQUIRE(solver.ok());
    REQUIRE(solver.matches(pr.lat, fixed));
    CHECK(solver.levels() >= 2);
    ReconstructSettings s;
    s.tolerance = 1e-10;
    std::vector<Vec3> x;
    const SolveReport cold = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, x, &solver);
    REQUIRE(cold.converged);
    if (verbose()) std::printf("multigrid CG from the path positions: %d iterations\n", cold.iterations);
    CHECK(cold.iterations <= 15);  // measured ~4x per V-cycle-CG iteration; path start ~1e-4
    CHECK(maxDiff(x, ref) < 1e-8);
    // the residual reported is the gather residual of the result
    const Real check = positionResidual(pr.lat, pr.e, pr.frames, fixed, x);
    CHECK(check <= 1.01e-10);
    // warm start from the answer: nothing to do; the default restarts from the path positions
    ReconstructSettings warmSettings = s;
    warmSettings.startFromPath = false;
    std::vector<Vec3> w = x;
    const SolveReport warm = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, warmSettings, w, &solver);
    CHECK(warm.iterations == 0);
    CHECK(w == x);
    const SolveReport again = reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, w, &solver);
    CHECK(again.iterations == cold.iterations);
    // one thread gives the same bytes
    std::vector<Vec3> y;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        (void)reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, y, &solver);
    }
    std::vector<Vec3> z;
    (void)reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, s, z, &solver);
    for (std::size_t i = 0; i < y.size(); ++i) REQUIRE(y[i] == z[i]);
    // the solver's cached, layer-parallel start is exactly the Path method's tree integration
    ReconstructSettings ps;
    ps.method = ReconstructMethod::Path;
    std::vector<Vec3> viaPath;
    (void)reconstructPositions(pr.lat, pr.e, pr.frames, pr.pins, ps, viaPath);
    std::vector<Vec3> viaSolver(viaPath.size(), Vec3::Zero());
    for (const Pin& pin : pr.pins) viaSolver[pin.point] = pin.position;
    solver.pathPositions(pr.lat, pr.e, pr.frames, viaSolver);
    CHECK(viaSolver == viaPath);
    // a component without a pin makes the solver refuse, not crash
    const PoissonSolver none(pr.lat, std::vector<unsigned char>(fixed.size(), 0));
    CHECK_FALSE(none.ok());
}

TEST_CASE("multigrid: preconditioned CG iterations stay flat as the lattice grows", "[solve]") {
    // Graph Laplacian of balls of growing radius with the centre pinned, random right-hand
    // side: Jacobi-CG iterations grow like the lattice's diameter, multigrid-CG's do not.
    int mgIts[2] = {0, 0}, jacIts[2] = {0, 0};
    int k = 0;
    for (Real radius : {8.0, 16.0}) {
        const Lattice lat = sphereLattice(radius);
        std::vector<unsigned char> fixed(static_cast<std::size_t>(lat.size()), 0);
        fixed[static_cast<std::size_t>(lat.size() / 2)] = 1;
        const PoissonSolver solver(lat, fixed);
        REQUIRE(solver.ok());
        // reuse the solver's matrix through a random problem
        std::vector<Index> freePts;
        for (Index p = 0; p < lat.size(); ++p)
            if (!fixed[p]) freePts.push_back(p);
        SparseRows A;
        A.rows = static_cast<Index>(freePts.size());
        std::vector<int> row(static_cast<std::size_t>(lat.size()), -1);
        for (std::size_t r = 0; r < freePts.size(); ++r) row[freePts[r]] = int(r);
        std::vector<Vec3i> coords;
        A.start.push_back(0);
        for (Index p : freePts) {
            std::vector<std::pair<int, Real>> entries;
            int count = 0;
            for (Index q : lat.neighbours[p]) {
                if (q == kNoPoint) continue;
                ++count;
                if (row[q] >= 0) entries.emplace_back(row[q], -1.0);
            }
            entries.emplace_back(row[p], Real(count));
            std::sort(entries.begin(), entries.end());
            for (auto& [c, v] : entries) {
                A.column.push_back(c);
                A.value.push_back(v);
            }
            A.start.push_back(int(A.column.size()));
            coords.push_back(lat.coords[p]);
        }
        const AggregationMultigrid mg(A, coords);
        std::vector<Real> b(static_cast<std::size_t>(A.rows));
        for (std::size_t i = 0; i < b.size(); ++i) b[i] = std::sin(0.37 * Real(i)) + 0.1;
        std::vector<Real> x(b.size(), 0.0), y(b.size(), 0.0);
        const SolveReport r1 = conjugateGradients(A, &mg, b, x, 1, 1e-10, 0, 500);
        const SolveReport r2 = conjugateGradients(A, nullptr, b, y, 1, 1e-10, 0, 5000);
        REQUIRE(r1.converged);
        REQUIRE(r2.converged);
        mgIts[k] = r1.iterations;
        jacIts[k] = r2.iterations;
        Real d = 0;
        for (std::size_t i = 0; i < x.size(); ++i) d = std::max(d, std::abs(x[i] - y[i]));
        CHECK(d < 1e-6);
        if (verbose())
            std::printf("radius %.0f (%lld points, %d levels): multigrid CG %d, Jacobi CG %d iterations\n", radius,
                        (long long)lat.size(), mg.levels(), r1.iterations, r2.iterations);
        ++k;
    }
    CHECK(mgIts[1] <= mgIts[0] + 4);
    CHECK(jacIts[1] > Real(1.6) * jacIts[0]);
    CHECK(mgIts[1] * 4 < jacIts[1]);
}
