#include "solve/sparse_solve.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "solve/gather.hpp"
#include "solve/multigrid.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace dgv {

struct PoissonSolver::Impl {
    Index points = 0;
    std::vector<unsigned char> fixed;
    std::vector<int> freeIndex;  ///< #P: row of a free point, -1 for fixed ones
    std::vector<Index> freePoints;
    SparseRows laplacian;
    std::unique_ptr<AggregationMultigrid> mg;
    bool ok = false;
    double seconds = 0;
    std::vector<Index> treeOrder;       ///< BFS order from the fixed points, by layer
    std::vector<Index> treeParent;      ///< #P parent in the tree (kNoPoint for roots)
    std::vector<signed char> treeSlot;  ///< #P slot of the edge parent -> point
    std::vector<Index> layerStart;      ///< offsets of the BFS layers in treeOrder
    mutable CgWorkspace work;           ///< reused by every solve (not reentrant)
    mutable std::vector<Real> b, x, scale2;
    mutable std::array<std::vector<Vec3>, 3> forward;  ///< solve()'s edge steps, reused
};

PoissonSolver::PoissonSolver(const Lattice& lat, const std::vector<unsigned char>& fixed)
    : mImpl(std::make_unique<Impl>()) {
    const auto start = std::chrono::steady_clock::now();
    DGV_CHECK_EQ(static_cast<Index>(fixed.size()), lat.size());
    Impl& m = *mImpl;
    m.points = lat.size();
    m.fixed = fixed;
    m.freeIndex.assign(at(lat.size()), -1);
    for (Index p = 0; p < lat.size(); ++p)
        if (!fixed[at(p)]) {
            m.freeIndex[at(p)] = static_cast<int>(m.freePoints.size());
            m.freePoints.push_back(p);
        }
    // Every component must hold a fixed point (else L is singular on it).
    std::vector<unsigned char> pinned(static_cast<std::size_t>(lat.components), 0);
    for (Index p = 0; p < lat.size(); ++p)
        if (fixed[at(p)]) pinned[static_cast<std::size_t>(lat.component[at(p)])] = 1;
    m.ok = true;
    for (unsigned char c : pinned) m.ok = m.ok && c;
    const Index n = static_cast<Index>(m.freePoints.size());
    SparseRows& L = m.laplacian;
    L.rows = n;
    L.start.assign(at(n) + 1, 0);
    std::vector<Vec3i> coords(at(n));
    for (Index r = 0; r < n; ++r) {
        const Index p = m.freePoints[at(r)];
        coords[at(r)] = lat.coords[at(p)];
        // row: the free neighbours below, the diagonal, the free neighbours above (increasing)
        int count = 0;
        std::vector<int> cols;
        for (Index q : lat.neighbours[at(p)]) {
            if (q == kNoPoint) continue;
            ++count;
            if (m.freeIndex[at(q)] >= 0) cols.push_back(m.freeIndex[at(q)]);
        }
        cols.push_back(static_cast<int>(r));
        std::sort(cols.begin(), cols.end());
        for (int c : cols) {
            L.column.push_back(c);
            L.value.push_back(c == r ? Real(count) : Real(-1));
        }
        L.start[at(r) + 1] = static_cast<int>(L.column.size());
        if (count == 0) m.ok = false;  // an isolated free point
    }
    if (m.ok && n > 0) {
        MultigridSettings mgs;
        mgs.floatCycle = true;  // the preconditioner in float, CG in double (docs/solvers.md)
        m.mg = std::make_unique<AggregationMultigrid>(L, coords, mgs);
    }
    // The breadth-first tree of the Path method (reconstruct.cpp, bfsOrder): FIFO from the fixed
    // points in point order, neighbours in slot order, so the order is sorted by depth.
    m.treeParent.assign(at(lat.size()), kNoPoint);
    m.treeSlot.assign(at(lat.size()), -1);
    std::vector<int> depth(at(lat.size()), -1);
    for (Index p = 0; p < lat.size(); ++p)
        if (fixed[at(p)]) {
            m.treeOrder.push_back(p);
            depth[at(p)] = 0;
        }
    for (std::size_t head = 0; head < m.treeOrder.size(); ++head) {
        const Index p = m.treeOrder[head];
        for (int slot = 0; slot < 6; ++slot) {
            const Index q = lat.neighbours[at(p)][at(slot)];
            if (q == kNoPoint || depth[at(q)] >= 0) continue;
            depth[at(q)] = depth[at(p)] + 1;
            m.treeParent[at(q)] = p;
            m.treeSlot[at(q)] = static_cast<signed char>(slot);
            m.treeOrder.push_back(q);
        }
    }
    for (std::size_t i = 0; i < m.treeOrder.size(); ++i)
        if (i == 0 || depth[at(m.treeOrder[i])] != depth[at(m.treeOrder[i - 1])])
            m.layerStart.push_back(static_cast<Index>(i));
    m.layerStart.push_back(static_cast<Index>(m.treeOrder.size()));
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

PoissonSolver::~PoissonSolver() = default;

bool PoissonSolver::ok() const { return mImpl->ok; }
double PoissonSolver::setupSeconds() const { return mImpl->seconds; }
Index PoissonSolver::freeCount() const { return static_cast<Index>(mImpl->freePoints.size()); }
int PoissonSolver::levels() const { return mImpl->mg ? mImpl->mg->levels() : 0; }

bool PoissonSolver::matches(const Lattice& lat, const std::vector<unsigned char>& fixed) const {
    if (lat.size() != mImpl->points || static_cast<Index>(fixed.size()) != lat.size()) return false;
    for (std::size_t p = 0; p < fixed.size(); ++p)
        if ((fixed[p] != 0) != (mImpl->fixed[p] != 0)) return false;
    return true;
}

namespace {

/// forward[a][p] = positionStep(p, +a) for every point with a +a neighbour: each edge's step
/// once (positionStep is antisymmetric bit for bit: the step back is the exact negation).
void forwardSteps(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                  std::array<std::vector<Vec3>, 3>& forward) {
    for (std::size_t a = 0; a < 3; ++a) forward[a].resize(at(lat.size()));
    parallelFor(lat.size(), [&](Index p) {
        for (int a = 0; a < 3; ++a) {
            const int slot = 2 * a + 1;
            if (lat.neighbours[at(p)][at(slot)] != kNoPoint)
                forward[std::size_t(a)][at(p)] = positionStep(lat, e, frames, p, slot);
        }
    });
}

/// The Path positions from the forward steps (the same values as from positionStep).
void pathFromSteps(const PoissonSolver::Impl& m, const std::array<std::vector<Vec3>, 3>& forward,
                   std::vector<Vec3>& positions) {
    for (std::size_t l = 1; l + 1 < m.layerStart.size(); ++l) {
        const Index begin = m.layerStart[l], count = m.layerStart[l + 1] - begin;
        parallelFor(
            count,
            [&](Index i) {
                const Index q = m.treeOrder[at(begin + i)];
                const Index p = m.treeParent[at(q)];
                const int slot = m.treeSlot[at(q)];
                const std::size_t axis = std::size_t(slot / 2);
                positions[at(q)] = (slot & 1) ? Vec3(positions[at(p)] + forward[axis][at(p)])
                                              : Vec3(positions[at(p)] + -forward[axis][at(q)]);
            },
            512);
    }
}

}  // namespace

void PoissonSolver::pathPositions(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                                  std::vector<Vec3>& positions) const {
    const Impl& m = *mImpl;
    DGV_CHECK_EQ(lat.size(), m.points);
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    forwardSteps(lat, e, frames, m.forward);
    pathFromSteps(m, m.forward, positions);
}

namespace {

/// The least-squares solve of PoissonSolver::solve / solveSteps with the edge step
/// x(q) - x(p) = step(p, slot) given as a function.
template <typename Step>
SolveReport solvePoisson(const PoissonSolver::Impl& m, const Lattice& lat, Step&& step, std::vector<Vec3>& positions,
                         Real tolerance, int maxIterations, const std::vector<Vec3>* load = nullptr) {
    const auto start = std::chrono::steady_clock::now();
    SolveReport report;
    const Index n = static_cast<Index>(m.freePoints.size());
    if (!m.ok || n == 0) {
        report.converged = m.ok;
        report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return report;
    }
    // b_p = Σ_{q fixed} x(q) - Σ_q D_pq (interleaved columns), x0 = the positions passed in;
    // scale^2 = Σ_p n_p Σ_q |D_pq|^2 over free points (gather.hpp's residual).
    std::vector<Real>& b = m.b;
    std::vector<Real>& x = m.x;
    std::vector<Real>& scale2 = m.scale2;
    // 4 interleaved columns, the 4th zero (and so zero throughout: every CG operation on it is
    // 0, and adds 0 to the residual): a row is 32 bytes, two SSE vectors, in every pass.
    constexpr int kCols = 4;
    b.resize(at(n) * kCols);
    x.resize(at(n) * kCols);
    scale2.resize(at(n));
    parallelFor(n, [&](Index r) {
        const Index p = m.freePoints[at(r)];
        Vec3 s = Vec3::Zero();
        Real s2 = 0;
        int count = 0;
        for (int slot = 0; slot < 6; ++slot) {
            const Index q = lat.neighbours[at(p)][at(slot)];
            if (q == kNoPoint) continue;
            const Vec3 d = step(p, slot);
            s -= d;
            s2 += d.squaredNorm();
            ++count;
            if (m.fixed[at(q)]) s += positions[at(q)];
        }
        scale2[at(r)] = Real(count) * s2;
        if (load) s += (*load)[at(p)];
        for (int c = 0; c < kCols; ++c) {
            b[at(r) * kCols + std::size_t(c)] = c < 3 ? s[c] : Real(0);
            x[at(r) * kCols + std::size_t(c)] = c < 3 ? positions[at(p)][c] : Real(0);
        }
    });
    const Real scale = std::sqrt(parallelReduce(
        n, Real(0), [&](Real& acc, Index r) { acc += scale2[at(r)]; }, [](Real a, Real c) { return a + c; }));
    // the multigrid's own copy of L: conjugateGradients then uses its row products (unit rows)
    report = conjugateGradients(m.mg->matrix(), m.mg.get(), b, x, kCols, tolerance, scale, maxIterations, &m.work);
    parallelFor(n, [&](Index r) {
        positions[at(m.freePoints[at(r)])] = Vec3(x[at(r) * kCols], x[at(r) * kCols + 1], x[at(r) * kCols + 2]);
    });
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

}  // namespace

SolveReport PoissonSolver::solve(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                                 std::vector<Vec3>& positions, Real tolerance, int maxIterations, bool fromPath) const {
    DGV_CHECK_EQ(lat.size(), mImpl->points);
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    // Each edge's step once, then the solve from the steps (the same values as from
    // positionStep, which is antisymmetric bit for bit).
    forwardSteps(lat, e, frames, mImpl->forward);
    if (fromPath) pathFromSteps(*mImpl, mImpl->forward, positions);
    return solveSteps(lat, mImpl->forward, positions, tolerance, maxIterations);
}

SolveReport PoissonSolver::solveSteps(const Lattice& lat, const std::array<std::vector<Vec3>, 3>& forward,
                                      std::vector<Vec3>& positions, Real tolerance, int maxIterations) const {
    DGV_CHECK_EQ(lat.size(), mImpl->points);
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    for (const auto& f : forward) DGV_CHECK_EQ(static_cast<Index>(f.size()), lat.size());
    return solvePoisson(
        *mImpl, lat,
        [&](Index p, int slot) -> Vec3 {
            const std::size_t axis = static_cast<std::size_t>(slot / 2);
            if (slot & 1) return forward[axis][at(p)];
            return -forward[axis][at(lat.neighbours[at(p)][at(slot)])];
        },
        positions, tolerance, maxIterations);
}

SolveReport PoissonSolver::solveLoad(const Lattice& lat, const std::vector<Vec3>& load, std::vector<Vec3>& positions,
                                     Real tolerance, int maxIterations) const {
    DGV_CHECK_EQ(lat.size(), mImpl->points);
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(load.size()), lat.size());
    return solvePoisson(
        *mImpl, lat, [](Index, int) -> Vec3 { return Vec3::Zero(); }, positions, tolerance, maxIterations, &load);
}

}  // namespace dgv
