#include "deform/volume.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "solve/multigrid.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace dgv {

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

/// Deterministic parallel dot product.
Real dot(const std::vector<Real>& a, const std::vector<Real>& b) {
    return parallelReduce(
        static_cast<Index>(a.size()), Real(0),
        [&](Real& acc, Index i) { acc += a[at(i)] * b[at(i)]; },
        [](Real x, Real y) { return x + y; });
}

constexpr int kStencil = 27;

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
    std::vector<Real> r(at(nc)), lambda(at(nc)), A(at(nc) * kStencil), invDiag(at(nc));
    std::vector<Real> res(at(nc)), z(at(nc)), dir(at(nc)), Ad(at(nc));
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
    auto multiply = [&](const std::vector<Real>& x, std::vector<Real>& y) {
        parallelFor(nc, [&](Index c) {
            Real s = 0;
            const std::size_t base = at(c) * kStencil;
            for (std::size_t k = 0; k < kStencil; ++k) {
                const Index d = nbCell[base + k];
                if (d >= 0) s += A[base + k] * x[at(d)];
            }
            y[at(c)] = s;
        });
    };

    Real err = evaluate();
    report.maxErrorBefore = err;
    report.unconstrainable = parallelReduce(
        nc, Index(0), [&](Index& acc, Index c) { acc += active[at(c)] ? 0 : 1; },
        [](Index a, Index b) { return a + b; });

    while (err > settings.tolerance && report.iterations < settings.maxIterations) {
        ++report.iterations;
        // Normal matrix (J J^T)_cd = sum over shared corners of grad_c . grad_d.
        parallelFor(nc, [&](Index c) {
            const std::size_t base = at(c) * kStencil;
            for (int s = 0; s < kStencil; ++s) {
                const Index d = nbCell[base + static_cast<std::size_t>(s)];
                Real sum = 0;
                if (d >= 0 && active[at(c)] && active[at(d)]) {
                    for (int k = 0; k < 8; ++k) {
                        const int kd = sharedCorner[s][k];
                        if (kd >= 0) sum += grad[at(c)][static_cast<std::size_t>(k)].dot(grad[at(d)][static_cast<std::size_t>(kd)]);
                    }
                }
                A[base + static_cast<std::size_t>(s)] = sum;
            }
            const Real diag = A[base + 13];
            invDiag[at(c)] = diag > 0 ? Real(1) / diag : Real(0);
        });
        if (settings.multigrid) {
            // A lambda = r on the active cells, by multigrid-preconditioned CG (solve/multigrid).
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
            std::vector<Vec3i> coords(at(rows));
            for (Index i = 0; i < rows; ++i) {
                const Index c = cellOfRow[at(i)];
                coords[at(i)] = cells.lowest[at(c)];
                const std::size_t base = at(c) * kStencil;
                for (std::size_t k = 0; k < kStencil; ++k) {  // stencil order = increasing cell id
                    const Index d = nbCell[base + k];
                    if (d < 0 || !active[at(d)] || (A[base + k] == 0 && k != 13)) continue;
                    S.column.push_back(static_cast<int>(rowOf[at(d)]));
                    S.value.push_back(A[base + k]);
                }
                S.start[at(i) + 1] = static_cast<int>(S.column.size());
            }
            std::vector<Real> rhs(at(rows)), sol(at(rows), 0);
            for (Index i = 0; i < rows; ++i) rhs[at(i)] = r[at(cellOfRow[at(i)])];
            if (rows > 0) {
                const AggregationMultigrid mg(S, coords);
                const SolveReport lin = conjugateGradients(S, &mg, rhs, sol, 1, settings.linearTolerance,
                                                           0, settings.maxLinearIterations);
                report.linearIterations += lin.iterations;
            }
            parallelFor(nc, [&](Index c) {
                lambda[at(c)] = rowOf[at(c)] >= 0 ? sol[at(rowOf[at(c)])] : Real(0);
            });
        } else {
        // PCG on A lambda = r (inactive rows: zero).
        parallelFor(nc, [&](Index c) {
            lambda[at(c)] = 0;
            res[at(c)] = active[at(c)] ? r[at(c)] : Real(0);
            z[at(c)] = invDiag[at(c)] * res[at(c)];
            dir[at(c)] = z[at(c)];
        });
        const Real rr0 = dot(res, res);
        Real rz = dot(res, z);
        const Real stop = settings.linearTolerance * settings.linearTolerance * rr0;
        for (int it = 0; it < settings.maxLinearIterations && rr0 > 0; ++it) {
            multiply(dir, Ad);
            const Real dAd = dot(dir, Ad);
            if (!(dAd > 0)) break;
            const Real alpha = rz / dAd;
            parallelFor(nc, [&](Index c) {
                lambda[at(c)] += alpha * dir[at(c)];
                res[at(c)] -= alpha * Ad[at(c)];
            });
            ++report.linearIterations;
            const Real rr = dot(res, res);
            if (rr <= stop) break;
            parallelFor(nc, [&](Index c) { z[at(c)] = invDiag[at(c)] * res[at(c)]; });
            const Real rzNew = dot(res, z);
            const Real beta = rzNew / rz;
            rz = rzNew;
            parallelFor(nc, [&](Index c) { dir[at(c)] = z[at(c)] + beta * dir[at(c)]; });
        }
        }
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

}  // namespace dgv
