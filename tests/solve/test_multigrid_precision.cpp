// The float V-cycle (MultigridSettings::floatCycle), the value-free products of unit rows and the
// zero 4th column of the position solve (docs/solvers.md, "The production solver").
#include <catch2/catch.hpp>

#include "solve/multigrid.hpp"
#include "solve/solve_fixtures.hpp"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace dgv;
using namespace dgv::test;

namespace {

/// The graph Laplacian of a ball's free points (centre pinned), rows in point order, and the
/// lattice coordinates of the rows.
SparseRows ballLaplacian(Real radius, std::vector<Vec3i>& coords) {
    const Lattice lat = sphereLattice(radius);
    std::vector<int> row(static_cast<std::size_t>(lat.size()), -1);
    const Index pinned = lat.size() / 2;
    int rows = 0;
    for (Index p = 0; p < lat.size(); ++p)
        if (p != pinned) row[static_cast<std::size_t>(p)] = rows++;
    SparseRows A;
    A.rows = rows;
    A.start.push_back(0);
    coords.clear();
    for (Index p = 0; p < lat.size(); ++p) {
        if (p == pinned) continue;
        std::vector<std::pair<int, Real>> entries;
        int count = 0;
        for (Index q : lat.neighbours[static_cast<std::size_t>(p)]) {
            if (q == kNoPoint) continue;
            ++count;
            if (row[static_cast<std::size_t>(q)] >= 0) entries.emplace_back(row[static_cast<std::size_t>(q)], -1.0);
        }
        entries.emplace_back(row[static_cast<std::size_t>(p)], Real(count));
        std::sort(entries.begin(), entries.end());
        for (const auto& [c, v] : entries) {
            A.column.push_back(c);
            A.value.push_back(v);
        }
        A.start.push_back(int(A.column.size()));
        coords.push_back(lat.coords[static_cast<std::size_t>(p)]);
    }
    return A;
}

/// A smooth-plus-oscillating right-hand side with `cols` interleaved columns; columns >= used
/// are zero.
std::vector<Real> rhs(Index rows, int cols, int used) {
    std::vector<Real> b(static_cast<std::size_t>(rows) * std::size_t(cols), 0.0);
    for (Index i = 0; i < rows; ++i)
        for (int c = 0; c < used; ++c)
            b[static_cast<std::size_t>(i) * std::size_t(cols) + std::size_t(c)] =
                std::sin(0.37 * Real(i) + c) + 0.1 * (c + 1);
    return b;
}

}  // namespace

TEST_CASE(
    "multigrid: the float V-cycle keeps CG's iterations and accuracy, unit rows and a zero "
    "4th column change no bit, threads change no bit",
    "[solve]") {
    std::vector<Vec3i> coords;
    const SparseRows A = ballLaplacian(14, coords);  // ~11k rows: many parallel blocks
    REQUIRE(A.rows > 10000);
    const AggregationMultigrid mgD(A, coords);
    MultigridSettings fs;
    fs.floatCycle = true;
    const AggregationMultigrid mgF(A, coords, fs);
    REQUIRE(mgF.levels() == mgD.levels());
    const std::vector<Real> b3 = rhs(A.rows, 3, 3);

    // unit rows (CG handed the multigrid's own matrix) = valued rows (a copy), bit for bit
    std::vector<Real> xCopy(b3.size(), 0.0), xOwn(b3.size(), 0.0);
    const SolveReport rCopy = conjugateGradients(A, &mgD, b3, xCopy, 3, 1e-10, 0, 200);
    const SolveReport rOwn = conjugateGradients(mgD.matrix(), &mgD, b3, xOwn, 3, 1e-10, 0, 200);
    REQUIRE(rCopy.converged);
    CHECK(rOwn.iterations == rCopy.iterations);
    CHECK(xOwn == xCopy);

    // the float cycle: the same iterations (at most one more), the same solution within the
    // tolerance's reach, and down to 1e-12 (far below float precision) as fast as double
    std::vector<Real> xF(b3.size(), 0.0);
    const SolveReport rF = conjugateGradients(mgF.matrix(), &mgF, b3, xF, 3, 1e-10, 0, 200);
    REQUIRE(rF.converged);
    CHECK(rF.residual <= 1e-10);
    CHECK(rF.iterations <= rCopy.iterations + 1);
    Real diff = 0, size = 0;
    for (std::size_t i = 0; i < xF.size(); ++i) {
        diff = std::max(diff, std::abs(xF[i] - xCopy[i]));
        size = std::max(size, std::abs(xCopy[i]));
    }
    CHECK(diff < 1e-10 * size);  // measured 7e-15 relative (11.5k rows)
    std::vector<Real> xD12(b3.size(), 0.0), xF12(b3.size(), 0.0);
    const SolveReport rD12 = conjugateGradients(A, &mgD, b3, xD12, 3, 1e-12, 0, 200);
    const SolveReport rF12 = conjugateGradients(mgF.matrix(), &mgF, b3, xF12, 3, 1e-12, 0, 200);
    REQUIRE(rD12.converged);
    REQUIRE(rF12.converged);
    CHECK(rF12.iterations <= rD12.iterations + 1);
    if (verbose())
        std::printf(
            "%lld rows: double cycle %d / %d iterations (1e-10 / 1e-12), float %d / %d; "
            "max |x_float - x_double| %.2e of %.2e\n",
            (long long)A.rows, rCopy.iterations, rD12.iterations, rF.iterations, rF12.iterations, diff, size);

    // a zero 4th column (the position solve's layout) leaves the other three bit for bit
    const std::vector<Real> b4 = rhs(A.rows, 4, 3);
    std::vector<Real> x4(b4.size(), 0.0);
    const SolveReport r4 = conjugateGradients(mgF.matrix(), &mgF, b4, x4, 4, 1e-10, 0, 200);
    CHECK(r4.iterations == rF.iterations);
    CHECK(r4.residual == rF.residual);
    bool same = true, zero = true;
    for (Index i = 0; i < A.rows; ++i) {
        for (std::size_t c = 0; c < 3; ++c)
            same = same && x4[static_cast<std::size_t>(i) * 4 + c] == xF[static_cast<std::size_t>(i) * 3 + c];
        zero = zero && x4[static_cast<std::size_t>(i) * 4 + 3] == 0.0;
    }
    CHECK(same);
    CHECK(zero);

    // one thread gives the same bytes as all of them
    std::vector<Real> x1(b3.size(), 0.0);
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        (void)conjugateGradients(mgF.matrix(), &mgF, b3, x1, 3, 1e-10, 0, 200);
    }
    CHECK(x1 == xF);
}
