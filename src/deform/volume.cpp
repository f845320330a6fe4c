#include "deform/volume.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "solve/multigrid.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <memory>

namespace dgv {

struct VolumeProjectionCache::Impl {
    std::vector<Index> cellOfRow;  ///< the active cells the hierarchy was built for
    bool parity = true;
    std::unique_ptr<AggregationMultigrid> mg;
};

namespace {

inline std::size_t at(Index p) { return static_cast<std::size_t>(p); }

inline Vec3i cornerOffset(int k) { return Vec3i(k & 1, (k >> 1) & 1, (k >> 2) & 1); }

/// dW[q][k][a] = d w_k / d s_a at Gauss point q (q's bits pick g0 or g1 per axis).
struct GaussTable {
    Real dW[8][8][3];
    GaussTable() {
        const Real g[2] = {Real(0.5) - Real(0.5) / std::sqrt(Real(3)),
                           Real(0.5) + Real(0.5) / std::sqrt(Real(3))};
        for (int q = 0; q < 8; ++q) {
            const Real s[3] = {g[q & 1], g[(q >> 1) & 1], g[(q >> 2) & 1]};
            for (int k = 0; k < 8; ++k) {
                const Vec3i o = cornerOffset(k);
                Real phi[3], dphi[3];
                for (int a = 0; a < 3; ++a) {
                    phi[a] = o[a] ? s[a] : Real(1) - s[a];
                    dphi[a] = o[a] ? Real(1) : Real(-1);
                }
                dW[q][k][0] = dphi[0] * phi[1] * phi[2];
                dW[q][k][1] = phi[0] * dphi[1] * phi[2];
                dW[q][k][2] = phi[0] * phi[1] * dphi[2];
            }
        }
    }
};

const GaussTable& gaussTable() {
    static const GaussTable table;
    return table;
}

/// Jacobian columns at Gauss point q from corners relative to corner 0.
inline void jacobianAt(const GaussTable& t, int q, const std::array<Vec3, 8>& y, Vec3 J[3]) {
    for (int a = 0; a < 3; ++a) {
        Vec3 col = Vec3::Zero();
        for (int k = 1; k < 8; ++k) col += t.dW[q][k][a] * y[static_cast<std::size_t>(k)];
        J[a] = col;
    }
}

inline std::array<Vec3, 8> relativeCorners(const std::array<Vec3, 8>& x) {
    std::array<Vec3, 8> y;
    y[0].setZero();
    for (std::size_t k = 1; k < 8; ++k) y[k] = x[k] - x[0];
    return y;
}

inline std::array<Vec3, 8> gatherCorners(const LatticeCells& cells, const std::vector<Vec3>& x,
                                         Index c) {
    std::array<Vec3, 8> v;
    const std::array<Index, 8>& ids = cells.corners[at(c)];
    for (std::size_t k = 0; k < 8; ++k) v[k] = x[at(ids[k])];
    return v;
}

constexpr int kStencil = 27;
/// Inexact Gauss-Newton: linear tolerance = kSafety max(err, tolerance / err) (measured).
constexpr Real kSafety = 1;

}  // namespace

LatticeCells buildCells(const Lattice& lat) {
    LatticeCells cells;
    cells.dims = lat.dims;
    const Index gridSize = Index(lat.dims.x()) * Index(lat.dims.y()) * Index(lat.dims.z());
    cells.cellOfGrid.assign(at(gridSize), Index(-1));
    // A point is the lowest corner of a cell when its +i, +j, +k, ... corners all exist.
    const Index n = lat.size();
    std::vector<unsigned char> isCell(at(n), 0);
    parallelFor(n, [&](Index p) {
        const Vec3i& u = lat.coords[at(p)];
        bool all = true;
        for (int k = 1; k < 8 && all; ++k) all = lat.pointAt(u + cornerOffset(k)) != kNoPoint;
        isCell[at(p)] = all ? 1 : 0;
    });
    // Points are in increasing linear index, so cells in point order are too.
    for (Index p = 0; p < n; ++p) {
        if (!isCell[at(p)]) continue;
        const Vec3i& u = lat.coords[at(p)];
        std::array<Index, 8> ids;
        for (int k = 0; k < 8; ++k) ids[static_cast<std::size_t>(k)] = lat.pointAt(u + cornerOffset(k));
        cells.cellOfGrid[at(lat.linearIndex(u))] = static_cast<Index>(cells.corners.size());
        cells.corners.push_back(ids);
        cells.lowest.push_back(u);
    }
    return cells;
}

Real hexVolume(const std::array<Vec3, 8>& x) {
    const GaussTable& t = gaussTable();
    const std::array<Vec3, 8> y = relativeCorners(x);
    Real v = 0;
    for (int q = 0; q < 8; ++q) {
        Vec3 J[3];
        jacobianAt(t, q, y, J);
        v += J[0].dot(J[1].cross(J[2]));
    }
    return v / Real(8);
}

Real hexVolumeGradient(const std::array<Vec3, 8>& x, std::array<Vec3, 8>& gradient) {
    const GaussTable& t = gaussTable();
    const std::array<Vec3, 8> y = relativeCorners(x);
    for (Vec3& g : gradient) g.setZero();
    Real v = 0;
    for (int q = 0; q < 8; ++q) {
        Vec3 J[3];
        jacobianAt(t, q, y, J);
        const Vec3 c0 = J[1].cross(J[2]), c1 = J[2].cross(J[0]), c2 = J[0].cross(J[1]);
        v += J[0].dot(c0);
        for (int k = 0; k < 8; ++k)
            gradient[static_cast<std::size_t>(k)] +=
                t.dW[q][k][0] * c0 + t.dW[q][k][1] * c1 + t.dW[q][k][2] * c2;
    }
    for (Vec3& g : gradient) g /= Real(8);
    return v / Real(8);
}

std::vector<Real> cellVolumes(const LatticeCells& cells, const std::vector<Vec3>& positions) {
    std::vector<Real> v(at(cells.size()));
    parallelFor(cells.size(), [&](Index c) { v[at(c)] = hexVolume(gatherCorners(cells, positions, c)); });
    return v;
}

Real totalVolume(const LatticeCells& cells, const std::vector<Vec3>& positions) {
    return parallelReduce(
        cells.size(), Real(0),
        [&](Real& acc, Index c) { acc += hexVolume(gatherCorners(cells, positions, c)); },
        [](Real a, Real b) { return a + b; });
}

VolumeProjectionReport projectVolumes(const LatticeCells& cells,
                                      const std::vector<Real>& restVolumes,
                                      const std::vector<unsigned char>& pinned,
                                      std::vector<Vec3>& positions,
                                      const VolumeProjectionSettings& settings) {
    const Index nc = cells.size();
    const Index np = static_cast<Index>(positions.size());
    DGV_CHECK_EQ(static_cast<Index>(restVolumes.size()), nc);
    DGV_CHECK(pinned.empty() || static_cast<Index>(pinned.size()) == np);
    auto isPinned = [&](Index p) { return !pinned.empty() && pinned[at(p)] != 0; };

    VolumeProjectionReport report;
    const std::vector<Vec3> start = positions;

    // Cell neighbours in the 27-stencil (ordered by increasing linear index), -1 if absent,
    // and which corner of the neighbour each of our corners is (or -1).
    std::vector<Index> nbCell(at(nc) * kStencil, -1);
    parallelFor(nc, [&](Index c) {
        const Vec3i& u = cells.lowest[at(c)];
        int s = 0;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx, ++s) {
                    const Vec3i v = u + Vec3i(dx, dy, dz);
                    if ((v.array() < 0).any() || (v.array() >= cells.dims.array()).any()) continue;
                    const Index lin = v.x() + Index(cells.dims.x()) * (v.y() + Index(cells.dims.y()) * v.z());
                    nbCell[at(c) * kStencil + static_cast<std::size_t>(s)] = cells.cellOfGrid[at(lin)];
                }
    });
    // Static table: for stencil slot s and our corner k, the neighbour's corner (or -1).
    int sharedCorner[kStencil][8];
    {
        int s = 0;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx, ++s)
                    for (int k = 0; k < 8; ++k) {
                        const Vec3i o = cornerOffset(k) - Vec3i(dx, dy, dz);
                        sharedCorner[s][k] = ((o.array() >= 0).all() && (o.array() <= 1).all())
                                                 ? (o.x() | (o.y() << 1) | (o.z() << 2))
                                                 : -1;
                    }
    }
    // Cells around each point: slot k = the cell whose corner k is the point.
    std::vector<std::array<Index, 8>> cellsOfPoint(at(np));
    for (auto& a : cellsOfPoint) a.fill(-1);
    for (Index c = 0; c < nc; ++c)
        for (std::size_t k = 0; k < 8; ++k) cellsOfPoint[at(cells.corners[at(c)][k])][k] = c;

    std::vector<std::array<Vec3, 8>> grad(at(nc));
    std::vector<Real> r(at(nc)), lambda(at(nc), 0);
    std::vector<unsigned char> active(at(nc), 1);

    auto evaluate = [&]() {
        // residual r_c = V_c / V0_c - 1 and gradients / V0_c, pinned corners zeroed
        parallelFor(nc, [&](Index c) {
            std::array<Vec3, 8>& g = grad[at(c)];
            const Real v = hexVolumeGradient(gatherCorners(cells, positions, c), g);
            const Real v0 = restVolumes[at(c)];
            r[at(c)] = v / v0 - 1;
            bool any = false;
            for (std::size_t k = 0; k < 8; ++k) {
                if (isPinned(cells.corners[at(c)][k])) g[k].setZero();
                else any = true;
                g[k] /= v0;
            }
            active[at(c)] = any ? 1 : 0;
        });
        return parallelReduce(
            nc, Real(0),
            [&](Real& acc, Index c) { if (active[at(c)]) acc = std::max(acc, std::abs(r[at(c)])); },
            [](Real a, Real b) { return std::max(a, b); });
    };

    Real err = evaluate();
    report.maxErrorBefore = err;
    report.unconstrainable = parallelReduce(
        nc, Index(0), [&](Index& acc, Index c) { acc += active[at(c)] ? 0 : 1; },
        [](Index a, Index b) { return a + b; });

    std::array<std::vector<Index>, 8> colourCells;
    for (Index c = 0; c < nc; ++c)
        if (active[at(c)]) {
            const Vec3i& u = cells.lowest[at(c)];
            colourCells[static_cast<std::size_t>((u.x() & 1) | ((u.y() & 1) << 1) | ((u.z() & 1) << 2))].push_back(c);
        }

    // The normal matrix J J^T on the active cells (which depend on the pins only): its
    // structure is fixed, its values are refilled on each Gauss-Newton iteration.
    std::vector<Index> rowOf(at(nc), -1);
    std::vector<Index> cellOfRow;
    for (Index c = 0; c < nc; ++c)
        if (active[at(c)]) {
            rowOf[at(c)] = static_cast<Index>(cellOfRow.size());
            cellOfRow.push_back(c);
        }
    const Index rows = static_cast<Index>(cellOfRow.size());
    SparseRows S;
    S.rows = rows;
    S.start.assign(at(rows) + 1, 0);
    std::vector<unsigned char> slotOf;  // stencil slot of each entry
    std::vector<Vec3i> coords(at(rows));
    for (Index i = 0; i < rows; ++i) {
        const Index c = cellOfRow[at(i)];
        coords[at(i)] = cells.lowest[at(c)];
        const std::size_t base = at(c) * kStencil;
        for (std::size_t k = 0; k < kStencil; ++k) {  // stencil order = increasing cell id
            const Index d = nbCell[base + k];
            if (d < 0 || !active[at(d)]) continue;
            S.column.push_back(static_cast<int>(rowOf[at(d)]));
            slotOf.push_back(static_cast<unsigned char>(k));
        }
        S.start[at(i) + 1] = static_cast<int>(S.column.size());
    }
    S.value.assign(S.column.size(), 0);
    std::vector<Real> rhs(at(rows)), sol(at(rows), 0);
    CgWorkspace workspace;
    // The multigrid: from the cache when it was built for these active cells, else built on
    // the first iteration (and on every one without reuseMultigrid).
    std::unique_ptr<AggregationMultigrid> ownMg;
    const AggregationMultigrid* mg = nullptr;
    VolumeProjectionCache::Impl* cache = nullptr;
    if (settings.cache && settings.multigrid) {
        if (!settings.cache->impl) settings.cache->impl = std::make_shared<VolumeProjectionCache::Impl>();
        cache = settings.cache->impl.get();
        if (cache->mg && cache->cellOfRow == cellOfRow && cache->parity == settings.parityAggregates) {
            mg = cache->mg.get();
        } else {
            cache->mg.reset();
            cache->cellOfRow = cellOfRow;
            cache->parity = settings.parityAggregates;
            settings.cache->builtFromPositions.clear();
            settings.cache->builtFromPinned.clear();
        }
    }
    MultigridSettings mgSettings;
    mgSettings.parityAggregates = settings.parityAggregates;
    mgSettings.eigenRatio = 100;  // measured best on the 137k ball (docs/math.md)
    mgSettings.smootherDegree = 4;

    while (err > settings.tolerance && report.iterations < settings.maxIterations && rows > 0) {
        ++report.iterations;
        // (J J^T)_cd = sum over shared corners of grad_c . grad_d
        parallelFor(rows, [&](Index i) {
            const Index c = cellOfRow[at(i)];
            const std::size_t base = at(c) * kStencil;
            for (int e = S.start[at(i)]; e < S.start[at(i) + 1]; ++e) {
                const int s = slotOf[static_cast<std::size_t>(e)];
                const Index d = nbCell[base + static_cast<std::size_t>(s)];
                Real sum = 0;
                for (int k = 0; k < 8; ++k) {
                    const int kd = sharedCorner[s][k];
                    if (kd >= 0) sum += grad[at(c)][static_cast<std::size_t>(k)].dot(grad[at(d)][static_cast<std::size_t>(kd)]);
                }
                S.value[static_cast<std::size_t>(e)] = sum;
            }
        });
        parallelFor(rows, [&](Index i) {
            rhs[at(i)] = r[at(cellOfRow[at(i)])];
            sol[at(i)] = 0;
        });
        if (settings.multigrid && (!mg || (!settings.reuseMultigrid && !cache))) {
            ownMg.reset();
            ownMg = std::make_unique<AggregationMultigrid>(S, coords, mgSettings);
            if (cache) {
                cache->mg = std::move(ownMg);
                mg = cache->mg.get();
                settings.cache->builtFromPositions = start;  // what the hierarchy was built from
                settings.cache->builtFromPinned = pinned;
            } else {
                mg = ownMg.get();
            }
        }
        // Inexact Gauss-Newton: no more linear accuracy than the step can use. The step leaves
        // about err^2 (the quadratic term) plus eta err, so eta ~ err on the way and
        // eta ~ tolerance / err on the last step, with a safety factor.
        const Real eta = settings.adaptiveLinearTolerance
                             ? std::max(settings.linearTolerance,
                                        std::min(Real(0.5), kSafety * std::max(err, settings.tolerance / err)))
                             : settings.linearTolerance;
        const SolveReport lin = conjugateGradients(S, mg, rhs, sol, 1, eta, 0,
                                                   settings.maxLinearIterations, &workspace);
        report.linearIterations += lin.iterations;
        parallelFor(nc, [&](Index c) {
            lambda[at(c)] = rowOf[at(c)] >= 0 ? sol[at(rowOf[at(c)])] : Real(0);
        });
        // dx = -J^T lambda, gathered per point.
        parallelFor(np, [&](Index p) {
            if (isPinned(p)) return;
            Vec3 dx = Vec3::Zero();
            for (std::size_t k = 0; k < 8; ++k) {
                const Index c = cellsOfPoint[at(p)][k];
                if (c >= 0) dx -= lambda[at(c)] * grad[at(c)][k];
            }
            positions[at(p)] += dx;
        });
        // Local polish: nonlinear Gauss-Seidel (Kaczmarz) sweeps over the cells in 8 parity
        // colours (cells of one colour share no corner): each cell moves its free corners along
        // its volume gradient to its rest volume. Removes the rough, local part of the residual
        // that the Krylov solve converges slowest on.
        for (int sweep = 0; sweep < settings.localSweeps; ++sweep)
            for (int colour = 0; colour < 8; ++colour)
                parallelFor(Index(colourCells[colour].size()), [&](Index i) {
                    const Index c = colourCells[colour][at(i)];
                    std::array<Vec3, 8> g;
                    const Real v = hexVolumeGradient(gatherCorners(cells, positions, c), g);
                    Real gg = 0;
                    for (std::size_t k = 0; k < 8; ++k) {
                        if (isPinned(cells.corners[at(c)][k])) g[k].setZero();
                        gg += g[k].squaredNorm();
                    }
                    if (!(gg > 0)) return;
                    const Real step = (restVolumes[at(c)] - v) / gg;
                    for (std::size_t k = 0; k < 8; ++k) positions[at(cells.corners[at(c)][k])] += step * g[k];
                });
        err = evaluate();
    }
    report.converged = err <= settings.tolerance;
    report.maxErrorAfter = err;
    report.maxMove = parallelReduce(
        np, Real(0),
        [&](Real& acc, Index p) { acc = std::max(acc, (positions[at(p)] - start[at(p)]).norm()); },
        [](Real a, Real b) { return std::max(a, b); });
    return report;
}

void rebuildVolumeProjectionCache(const LatticeCells& cells, const std::vector<Real>& restVolumes,
                                  const VolumeProjectionSettings& settings) {
    DGV_CHECK(settings.cache != nullptr);
    VolumeProjectionCache& cache = *settings.cache;
    cache.impl.reset();
    if (cache.builtFromPositions.empty()) {
        cache.builtFromPinned.clear();
        return;
    }
    std::vector<Vec3> positions = std::move(cache.builtFromPositions);
    const std::vector<unsigned char> pinned = std::move(cache.builtFromPinned);
    cache.builtFromPositions.clear();
    cache.builtFromPinned.clear();
    (void)projectVolumes(cells, restVolumes, pinned, positions, settings);
}

}  // namespace dgv
