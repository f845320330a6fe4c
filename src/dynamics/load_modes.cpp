#include "dynamics/load_modes.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "dynamics/body.hpp"
#include "solve/sparse_solve.hpp"

#include <algorithm>
#include <cmath>

namespace dgv {

namespace {

/// Σ a_i b_i over cells (deterministic: parallelReduce's fixed blocks).
Real dot(const std::vector<Real>& a, const std::vector<Real>& b) {
    return parallelReduce(
        static_cast<Index>(a.size()), Real(0), [&](Real& acc, Index i) { acc += a[at(i)] * b[at(i)]; },
        [](Real x, Real y) { return x + y; });
}

}  // namespace

LoadModes computeLoadModes(const Lattice& lat, const std::vector<Vec3>& rest, const std::vector<unsigned char>& pinned,
                           const LatticeCells& cells, const std::vector<Real>& restVolumes,
                           const std::vector<Real>& mass, const PoissonSolver& solver) {
    const Index n = lat.size();
    DGV_CHECK_EQ(static_cast<Index>(rest.size()), n);
    DGV_CHECK_EQ(static_cast<Index>(pinned.size()), n);
    DGV_CHECK_EQ(static_cast<Index>(mass.size()), n);
    LoadModes modes;
    // Points that may move: in a component with a pin, not pinned themselves.
    std::vector<char> componentPinned(static_cast<std::size_t>(lat.components), 0);
    for (Index p = 0; p < n; ++p)
        if (pinned[at(p)]) componentPinned[static_cast<std::size_t>(lat.component[at(p)])] = 1;
    std::vector<unsigned char> moves(at(n), 0);
    Real massSum = 0;
    Index massCount = 0;
    for (Index p = 0; p < n; ++p) {
        moves[at(p)] = !pinned[at(p)] && componentPinned[static_cast<std::size_t>(lat.component[at(p)])];
        if (moves[at(p)] && mass[at(p)] > 0) {
            massSum += mass[at(p)];
            ++massCount;
        }
    }
    if (massCount == 0 || !solver.ok()) return modes;
    const Real meanMass = massSum / static_cast<Real>(massCount);

    // The cells' volume gradients at rest over their rest volumes (J's rows), zero at the corners
    // that do not move; a cell takes part when some corner moves.
    const Index nc = cells.size();
    std::vector<std::array<Vec3, 8>> grad(at(nc));
    std::vector<unsigned char> active(at(nc), 0);
    parallelFor(nc, [&](Index c) {
        std::array<Vec3, 8> x;
        for (std::size_t k = 0; k < 8; ++k) x[k] = rest[at(cells.corners[at(c)][k])];
        (void)hexVolumeGradient(x, grad[at(c)]);
        for (std::size_t k = 0; k < 8; ++k) {
            const Index p = cells.corners[at(c)][k];
            if (moves[at(p)])
                active[at(c)] = 1;
            else
                grad[at(c)][k].setZero();
            grad[at(c)][k] /= restVolumes[at(c)];
        }
    });
    // The cells of each point (corner k of cell cellsOfPoint[p][k]), for Jᵀ by point.
    std::vector<std::array<Index, 8>> cellsOfPoint(at(n));
    for (auto& a : cellsOfPoint) a.fill(-1);
    for (Index c = 0; c < nc; ++c)
        if (active[at(c)])
            for (std::size_t k = 0; k < 8; ++k) cellsOfPoint[at(cells.corners[at(c)][k])][k] = c;
    auto applyJ = [&](const std::vector<Vec3>& w, std::vector<Real>& out) {
        out.resize(at(nc));
        parallelFor(nc, [&](Index c) {
            Real s = 0;
            if (active[at(c)])
                for (std::size_t k = 0; k < 8; ++k) s += grad[at(c)][k].dot(w[at(cells.corners[at(c)][k])]);
            out[at(c)] = s;
        });
    };
    auto applyJt = [&](const std::vector<Real>& pc, std::vector<Vec3>& out) {
        out.resize(at(n));
        parallelFor(n, [&](Index p) {
            Vec3 s = Vec3::Zero();
            for (std::size_t k = 0; k < 8; ++k) {
                const Index c = cellsOfPoint[at(p)][k];
                if (c >= 0) s += pc[at(c)] * grad[at(c)][k];
            }
            out[at(p)] = s;
        });
    };
    // The Schur complement's CG only has to get the smooth part of the pressure: the polish
    // below removes what it leaves (measured on a bar and on balls of 17k and 137k points:
    // 5-20 iterations to 1e-2, against 200-300+ to 1e-4 for the horizontal loads).
    constexpr Real kInnerTolerance = 1e-7;  // the Poisson solves
    constexpr Real kOuterTolerance = 1e-2;  // |J w| / |J w0|
    constexpr int kMaxOuter = 300;
    auto poisson = [&](const std::vector<Vec3>& load, std::vector<Vec3>& x) {
        x.assign(at(n), Vec3::Zero());
        (void)solver.solveLoad(lat, load, x, kInnerTolerance, 400);
    };

    std::vector<unsigned char> held(at(n));
    for (Index p = 0; p < n; ++p) held[at(p)] = moves[at(p)] ? 0 : 1;
    VolumeProjectionCache polishCache;
    for (std::size_t i = 0; i < 3; ++i) {
        std::vector<Vec3> load(at(n), Vec3::Zero());
        for (Index p = 0; p < n; ++p)
            if (moves[at(p)]) load[at(p)][static_cast<Index>(i)] = mass[at(p)] / meanMass;
        std::vector<Vec3> w;
        poisson(load, w);
        // Conjugate gradients on S p = J w0, S = J L⁻¹ Jᵀ (symmetric positive semi-definite;
        // the right-hand side lies in its range). U accumulates L⁻¹ Jᵀ p.
        std::vector<Real> r, d, Sd;
        applyJ(w, r);
        const Real r0 = std::sqrt(dot(r, r));
        std::vector<Vec3> U(at(n), Vec3::Zero()), jt, u;
        d = r;
        Real rr = r0 * r0;
        int it = 0;
        while (r0 > 0 && it < kMaxOuter && std::sqrt(rr) > kOuterTolerance * r0) {
            ++it;
            applyJt(d, jt);
            poisson(jt, u);
            applyJ(u, Sd);
            const Real dSd = dot(d, Sd);
            if (!(dSd > 0)) break;
            const Real alpha = rr / dSd;
            parallelFor(n, [&](Index p) { U[at(p)] += alpha * u[at(p)]; });
            parallelFor(nc, [&](Index c) { r[at(c)] -= alpha * Sd[at(c)]; });
            const Real rrNew = dot(r, r);
            const Real beta = rrNew / rr;
            rr = rrNew;
            parallelFor(nc, [&](Index c) { d[at(c)] = r[at(c)] + beta * d[at(c)]; });
        }
        parallelFor(n, [&](Index p) { w[at(p)] = moves[at(p)] ? Vec3(w[at(p)] - U[at(p)]) : Vec3(Vec3::Zero()); });
        // Polish: the cells' volume change of w, left by the loose solve above (mostly its
        // checkerboard part, which the Schur complement's CG resolves slowest), removed by
        // the volume projection of the rest shape displaced by ±ε w, w ← (x₊ − x₋) / 2ε (the
        // central difference: J w = O(ε²)). The projection's correction is small and local.
        Real big = 0;
        for (const Vec3& v : w) big = std::max(big, v.norm());
        if (!(big > 0)) return LoadModes();
        const Real eps = Real(1e-2) * lat.spacing / big;
        VolumeProjectionSettings vs;
        vs.tolerance = 1e-11;
        vs.maxIterations = 20;
        vs.cache = &polishCache;  // one multigrid for the six projections (shapes within ε of rest)
        std::array<std::vector<Vec3>, 2> x;
        for (std::size_t side = 0; side < 2; ++side) {
            const Real e = side == 0 ? eps : -eps;
            x[side].resize(at(n));
            parallelFor(n, [&](Index p) { x[side][at(p)] = rest[at(p)] + e * w[at(p)]; });
            (void)projectVolumes(cells, restVolumes, held, x[side], vs);
        }
        parallelFor(n, [&](Index p) { w[at(p)] = (x[0][at(p)] - x[1][at(p)]) / (2 * eps); });
        Real largest = 0;
        for (const Vec3& v : w) largest = std::max(largest, v.norm());
        if (!(largest > 0)) return LoadModes();
        for (Vec3& v : w) v /= largest;
        modes.w[i] = std::move(w);
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            modes.mass(i, j) = parallelReduce(
                n, Real(0),
                [&](Real& acc, Index p) { acc += mass[at(p)] * modes.w[at(i)][at(p)].dot(modes.w[at(j)][at(p)]); },
                [](Real a, Real b) { return a + b; });
    // The sums that give an affine load's share on each mode (X̃ about the centre of mass).
    const Vec3 centre = centreOfMass(mass, rest);  // as the body's X̃ (stepper.cpp)
    for (std::size_t i = 0; i < 3; ++i) {
        modes.massSum[i].setZero();
        modes.firstMoment[i].setZero();
        for (Index p = 0; p < n; ++p) {
            modes.massSum[i] += mass[at(p)] * modes.w[i][at(p)];
            modes.firstMoment[i] += mass[at(p)] * modes.w[i][at(p)] * (rest[at(p)] - centre).transpose();
        }
    }
    // The largest strain per unit amplitude: the cell's displacement gradient from the mean of
    // its four edges along each lattice axis (Frobenius norm), per metre.
    const Real h = lat.spacing;
    for (std::size_t i = 0; i < 3; ++i) {
        const std::vector<Vec3>& w = modes.w[i];
        modes.strain[static_cast<Index>(i)] = parallelReduce(
            nc, Real(0),
            [&](Real& acc, Index c) {
                Mat3 D = Mat3::Zero();
                const auto& k = cells.corners[at(c)];
                for (int a = 0; a < 3; ++a)
                    for (std::size_t lo = 0; lo < 8; ++lo)
                        if (!(lo & (std::size_t(1) << a)))
                            D.col(a) += (w[at(k[lo | (std::size_t(1) << a)])] - w[at(k[lo])]) / (4 * h);
                acc = std::max(acc, D.norm());
            },
            [](Real a, Real b) { return std::max(a, b); });
    }
    return modes;
}

}  // namespace dgv
