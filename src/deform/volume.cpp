#include "deform/volume.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "solve/multigrid.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <memory>

namespace dgv {

/// What a call derives from the cells alone, and from the cells and the active set; kept in the
/// cache so that a step's call does none of it (about 20 ms of 190 at 137k cells).
struct CellTopology {
    const LatticeCells* cells = nullptr;  ///< the cells it was made for (with their sizes and grid)
    Index cellCount = 0, pointCount = 0;
    Vec3i dims = Vec3i::Zero();
    /// Cell neighbours in the 27-stencil (ordered by increasing linear index), -1 if absent.
    std::vector<Index> nbCell;
    /// Cells around each point: slot k = the cell whose corner k is the point (or -1).
    std::vector<std::array<Index, 8>> cellsOfPoint;
    // From the active cells:
    std::vector<unsigned char> active;              ///< #C: the active set the rest was made for
    std::array<std::vector<Index>, 8> colourCells;  ///< active cells by parity colour
    std::vector<Index> rowOf, cellOfRow;            ///< active cell <-> row of the normal matrix
    SparseRows structure;                           ///< J J^T's pattern (values unset)
    std::vector<unsigned char> slotOf;              ///< stencil slot of each entry
    std::vector<int> mirror;                        ///< the entry of the transposed position
    std::vector<Vec3i> coords;                      ///< lattice coordinate of each row
};

struct VolumeProjectionCache::Impl {
    std::vector<Index> cellOfRow;  ///< the active cells the hierarchy was built for
    bool parity = true;
    std::unique_ptr<AggregationMultigrid> mg;
    CellTopology topology;
};

namespace {

inline Vec3i cornerOffset(int k) { return Vec3i(k & 1, (k >> 1) & 1, (k >> 2) & 1); }

/// The trilinear cell in centred coordinates s in [-1/2, 1/2]^3 (corner k at s_a = ±1/2 by its
/// bits): x(s) = a + b s1 + c s2 + d s3 + e s1 s2 + f s1 s3 + g s2 s3 + k s1 s2 s3, and its
/// volume ∫ det(∂x/∂s) ds. Expanding the determinant, every term with an odd power of some s_a
/// integrates to zero and ∫ s_a^2 = 1/12, which leaves
///     V = [b, c, d] + ([b, e, f] − [c, e, g] + [d, f, g]) / 12,   [u, v, w] = u · (v × w)
/// (k drops out). The coefficients are the Walsh-Hadamard transform of the corners:
/// W[m] = Σ_k Π_{a in m} σ_a(k) x_k (σ_a = ±1 by bit a of k), b, c, d = W[1], W[2], W[4] / 4 and
/// e, f, g = W[3], W[5], W[6] / 2; taken of the corners relative to corner 0, so no
/// coordinate's size enters the rounding.
struct CentredCell {
    Vec3 b, c, d, e, f, g;
};

/// In place: W[m] from values[k] (the butterfly on each bit; 24 vector additions).
inline void walshHadamard(std::array<Vec3, 8>& w) {
    for (int bit = 1; bit < 8; bit <<= 1)
        for (int k = 0; k < 8; ++k)
            if (!(k & bit)) {
                const Vec3 lo = w[static_cast<std::size_t>(k)], hi = w[static_cast<std::size_t>(k | bit)];
                w[static_cast<std::size_t>(k)] = lo + hi;
                w[static_cast<std::size_t>(k | bit)] = hi - lo;
            }
}

inline CentredCell centredCell(const std::array<Vec3, 8>& x) {
    std::array<Vec3, 8> w;
    w[0].setZero();
    for (std::size_t k = 1; k < 8; ++k) w[k] = x[k] - x[0];
    walshHadamard(w);
    return {Real(0.25) * w[1], Real(0.25) * w[2], Real(0.25) * w[4],
            Real(0.5) * w[3],  Real(0.5) * w[5],  Real(0.5) * w[6]};
}

inline std::array<Vec3, 8> gatherCorners(const LatticeCells& cells, const std::vector<Vec3>& x, Index c) {
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

namespace {
constexpr Real r12 = Real(1) / Real(12);
}  // namespace

Real hexVolume(const std::array<Vec3, 8>& x) {
    const CentredCell m = centredCell(x);  // the same operations as hexVolumeGradient's value
    return m.b.dot(m.c.cross(m.d)) +
           r12 * (m.b.dot(m.e.cross(m.f)) - m.c.dot(m.e.cross(m.g)) + m.d.dot(m.f.cross(m.g)));
}

Real hexVolumeGradient(const std::array<Vec3, 8>& x, std::array<Vec3, 8>& gradient) {
    const CentredCell m = centredCell(x);
    // ∂V/∂(b, c, d, e, f, g) from the formula above.
    const Vec3 cd = m.c.cross(m.d), db = m.d.cross(m.b), bc = m.b.cross(m.c);
    const Vec3 ef = m.e.cross(m.f), eg = m.e.cross(m.g), fg = m.f.cross(m.g);
    const Vec3 gb = cd + r12 * ef;
    const Vec3 gc = db - r12 * eg;
    const Vec3 gd = bc + r12 * fg;
    const Vec3 ge = r12 * (m.f.cross(m.b) - m.g.cross(m.c));
    const Vec3 gf = r12 * (m.b.cross(m.e) + m.g.cross(m.d));
    const Vec3 gg = r12 * (m.d.cross(m.f) - m.c.cross(m.e));
    const Real v = m.b.dot(cd) + r12 * (m.b.dot(ef) - m.c.dot(eg) + m.d.dot(fg));
    // ∂V/∂x_k = Σ_m Π_{a in m} σ_a(k) C[m] with C[m] the coefficient derivatives times the
    // transform's scale: the same butterfly with (lo, hi) -> (lo − hi, lo + hi).
    std::array<Vec3, 8>& w = gradient;
    w[0].setZero();
    w[7].setZero();
    w[1] = Real(0.25) * gb;
    w[2] = Real(0.25) * gc;
    w[4] = Real(0.25) * gd;
    w[3] = Real(0.5) * ge;
    w[5] = Real(0.5) * gf;
    w[6] = Real(0.5) * gg;
    for (int bit = 1; bit < 8; bit <<= 1)
        for (int k = 0; k < 8; ++k)
            if (!(k & bit)) {
                const Vec3 lo = w[static_cast<std::size_t>(k)], hi = w[static_cast<std::size_t>(k | bit)];
                w[static_cast<std::size_t>(k)] = lo - hi;
                w[static_cast<std::size_t>(k | bit)] = lo + hi;
            }
    return v;
}

std::vector<Real> cellVolumes(const LatticeCells& cells, const std::vector<Vec3>& positions) {
    std::vector<Real> v(at(cells.size()));
    parallelFor(cells.size(), [&](Index c) { v[at(c)] = hexVolume(gatherCorners(cells, positions, c)); });
    return v;
}

Real totalVolume(const LatticeCells& cells, const std::vector<Vec3>& positions) {
    return parallelReduce(
        cells.size(), Real(0), [&](Real& acc, Index c) { acc += hexVolume(gatherCorners(cells, positions, c)); },
        [](Real a, Real b) { return a + b; });
}

VolumeProjectionReport projectVolumes(const LatticeCells& cells, const std::vector<Real>& restVolumes,
                                      const std::vector<unsigned char>& pinned, std::vector<Vec3>& positions,
                                      const VolumeProjectionSettings& settings) {
    const Index nc = cells.size();
    const Index np = static_cast<Index>(positions.size());
    DGV_CHECK_EQ(static_cast<Index>(restVolumes.size()), nc);
    DGV_CHECK(pinned.empty() || static_cast<Index>(pinned.size()) == np);
    const std::vector<Vec3>* slide = settings.slideNormals;
    DGV_CHECK(!slide || static_cast<Index>(slide->size()) == np);
    // pinned[p]: 0 free, 1 fixed, kSlides: only along the plane normal to (*slide)[p]
    auto isPinned = [&](Index p) { return !pinned.empty() && pinned[at(p)] == 1; };
    auto slides = [&](Index p) { return !pinned.empty() && pinned[at(p)] == kSlides; };
    const std::vector<Real>* weights = settings.weights;
    DGV_CHECK(!weights || static_cast<Index>(weights->size()) == np);
    // The step in the metric of the weights: gradients scaled by sqrt(w) at each corner (the
    // normal matrix is then J W J^T) and the displacements by sqrt(w) again (dx = -W J^T λ).
    std::vector<Real> rootW;
    if (weights) {
        rootW.resize(at(np));
        for (Index p = 0; p < np; ++p) {
            DGV_CHECK((*weights)[at(p)] > 0);
            rootW[at(p)] = std::sqrt((*weights)[at(p)]);
        }
    }
    bool anySliding = false;
    for (Index p = 0; p < Index(pinned.size()); ++p) {
        DGV_CHECK(pinned[at(p)] <= 1 || (pinned[at(p)] == kSlides && slide));
        anySliding = anySliding || pinned[at(p)] == kSlides;
    }
    // A corner's share of a cell's gradient: zero if fixed, the tangential part if it slides.
    auto constrain = [&](Index p, Vec3& g) {
        if (isPinned(p)) {
            g.setZero();
        } else if (slides(p)) {
            const Vec3& nrm = (*slide)[at(p)];
            g -= g.dot(nrm) * nrm;
        }
    };

    VolumeProjectionReport report;
    const std::vector<Vec3> start = positions;

    // The topology: from the cache when it was made for these cells, else made here.
    if (settings.cache && !settings.cache->impl) settings.cache->impl = std::make_shared<VolumeProjectionCache::Impl>();
    CellTopology ownTopology;
    CellTopology& topo = settings.cache ? settings.cache->impl->topology : ownTopology;
    if (topo.cells != &cells || topo.cellCount != nc || topo.pointCount != np || topo.dims != cells.dims) {
        topo = CellTopology();
        topo.cells = &cells;
        topo.cellCount = nc;
        topo.pointCount = np;
        topo.dims = cells.dims;
        topo.nbCell.assign(at(nc) * kStencil, -1);
        parallelFor(nc, [&](Index c) {
            const Vec3i& u = cells.lowest[at(c)];
            int s = 0;
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx, ++s) {
                        const Vec3i v = u + Vec3i(dx, dy, dz);
                        if ((v.array() < 0).any() || (v.array() >= cells.dims.array()).any()) continue;
                        const Index lin = v.x() + Index(cells.dims.x()) * (v.y() + Index(cells.dims.y()) * v.z());
                        topo.nbCell[at(c) * kStencil + static_cast<std::size_t>(s)] = cells.cellOfGrid[at(lin)];
                    }
        });
        topo.cellsOfPoint.resize(at(np));
        for (auto& a : topo.cellsOfPoint) a.fill(-1);
        for (Index c = 0; c < nc; ++c)
            for (std::size_t k = 0; k < 8; ++k) topo.cellsOfPoint[at(cells.corners[at(c)][k])][k] = c;
    }
    const std::vector<Index>& nbCell = topo.nbCell;
    const std::vector<std::array<Index, 8>>& cellsOfPoint = topo.cellsOfPoint;
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

    std::vector<std::array<Vec3, 8>> grad(at(nc));
    std::vector<Real> r(at(nc)), lambda(at(nc), 0);
    std::vector<unsigned char> active(at(nc), 1);

    auto evaluate = [&](bool withGradients) {
        // residual r_c = V_c / V0_c - 1 and (withGradients) gradients / V0_c, pinned corners
        // zeroed, and the active flags; without: the residual alone (the same bits)
        parallelFor(nc, [&](Index c) {
            if (!withGradients) {
                r[at(c)] = hexVolume(gatherCorners(cells, positions, c)) / restVolumes[at(c)] - 1;
                return;
            }
            std::array<Vec3, 8>& g = grad[at(c)];
            const Real v = hexVolumeGradient(gatherCorners(cells, positions, c), g);
            const Real v0 = restVolumes[at(c)];
            r[at(c)] = v / v0 - 1;
            bool any = false;
            for (std::size_t k = 0; k < 8; ++k) {
                const Index p = cells.corners[at(c)][k];
                if (!isPinned(p)) any = true;
                constrain(p, g[k]);
                g[k] /= v0;
                if (weights) g[k] *= rootW[at(p)];
            }
            active[at(c)] = any ? 1 : 0;
        });
        return parallelReduce(
            nc, Real(0),
            [&](Real& acc, Index c) {
                if (active[at(c)]) acc = std::max(acc, std::abs(r[at(c)]));
            },
            [](Real a, Real b) { return std::max(a, b); });
    };

    Real err = evaluate(true);
    bool gradientsFresh = true;  // the gradients are those of the current positions
    report.maxErrorBefore = err;
    report.unconstrainable = parallelReduce(
        nc, Index(0), [&](Index& acc, Index c) { acc += active[at(c)] ? 0 : 1; },
        [](Index a, Index b) { return a + b; });
    // The body's total volume error over the constrainable cells (their rest volume is fixed
    // by the pins, as the active flags are).
    const Real activeVolume = parallelReduce(
        nc, Real(0),
        [&](Real& acc, Index c) {
            if (active[at(c)]) acc += restVolumes[at(c)];
        },
        [](Real a, Real b) { return a + b; });
    auto driftOf = [&] {
        const Real sum = parallelReduce(
            nc, Real(0),
            [&](Real& acc, Index c) {
                if (active[at(c)]) acc += restVolumes[at(c)] * r[at(c)];
            },
            [](Real a, Real b) { return a + b; });
        return activeVolume > 0 ? sum / activeVolume : Real(0);
    };
    Real drift = driftOf();
    auto done = [&] { return err <= settings.tolerance && std::abs(drift) <= settings.driftTolerance; };
    // dx = -J^T lambda (the gradients of the current evaluation), gathered per point.
    auto applyMultipliers = [&](const std::vector<Real>& lam) {
        parallelFor(np, [&](Index p) {
            if (isPinned(p)) return;  // a sliding point's gradients are tangential already
            Vec3 dx = Vec3::Zero();
            for (std::size_t k = 0; k < 8; ++k) {
                const Index c = cellsOfPoint[at(p)][k];
                if (c >= 0) dx -= lam[at(c)] * grad[at(c)][k];
            }
            positions[at(p)] += weights ? Vec3(rootW[at(p)] * dx) : dx;
        });
    };
    // The caller's prediction of the multipliers, applied first as a Gauss-Newton step that
    // costs no linear solve, and kept only if it lowers the largest cell error.
    std::vector<Real> applied;  // the multipliers applied, summed over the steps
    if (settings.multipliers) {
        applied.assign(at(nc), 0);
        const std::vector<Real>& guess = *settings.multipliers;
        if (guess.size() == at(nc) && !done()) {
            const std::vector<Vec3> entry = positions;
            applyMultipliers(guess);
            const Real errGuess = evaluate(true);
            if (errGuess < err) {
                err = errGuess;
                drift = driftOf();
                parallelFor(nc, [&](Index c) { applied[at(c)] = active[at(c)] ? guess[at(c)] : Real(0); });
                ++report.predicted;
            } else {
                positions = entry;
                (void)evaluate(true);
            }
        }
    }

    // The normal matrix J J^T on the active cells (which depend on the pins only): its
    // structure is fixed, its values are refilled on each Gauss-Newton iteration.
    if (topo.active != active) {
        topo.active = active;
        for (auto& list : topo.colourCells) list.clear();
        for (Index c = 0; c < nc; ++c)
            if (active[at(c)]) {
                const Vec3i& u = cells.lowest[at(c)];
                topo.colourCells[static_cast<std::size_t>((u.x() & 1) | ((u.y() & 1) << 1) | ((u.z() & 1) << 2))]
                    .push_back(c);
            }
        topo.rowOf.assign(at(nc), -1);
        topo.cellOfRow.clear();
        for (Index c = 0; c < nc; ++c)
            if (active[at(c)]) {
                topo.rowOf[at(c)] = static_cast<Index>(topo.cellOfRow.size());
                topo.cellOfRow.push_back(c);
            }
        const Index activeRows = static_cast<Index>(topo.cellOfRow.size());
        SparseRows& T = topo.structure;
        T = SparseRows();
        T.rows = activeRows;
        T.start.assign(at(activeRows) + 1, 0);
        topo.slotOf.clear();
        topo.coords.resize(at(activeRows));
        for (Index i = 0; i < activeRows; ++i) {
            const Index c = topo.cellOfRow[at(i)];
            topo.coords[at(i)] = cells.lowest[at(c)];
            const std::size_t base = at(c) * kStencil;
            for (std::size_t k = 0; k < kStencil; ++k) {  // stencil order = increasing cell id
                const Index d = nbCell[base + k];
                if (d < 0 || !active[at(d)]) continue;
                T.column.push_back(static_cast<int>(topo.rowOf[at(d)]));
                topo.slotOf.push_back(static_cast<unsigned char>(k));
            }
            T.start[at(i) + 1] = static_cast<int>(T.column.size());
        }
        // The transposed entry of each: in row j, the slot opposite (26 - s).
        topo.mirror.resize(T.column.size());
        parallelFor(activeRows, [&](Index i) {
            for (int e = T.start[at(i)]; e < T.start[at(i) + 1]; ++e) {
                const int j = T.column[at(e)];
                const int opposite = kStencil - 1 - topo.slotOf[at(e)];
                int f = T.start[at(j)];
                while (topo.slotOf[at(f)] != opposite) ++f;  // present: adjacency is symmetric
                topo.mirror[at(e)] = f;
            }
        });
    }
    const std::array<std::vector<Index>, 8>& colourCells = topo.colourCells;
    const std::vector<Index>& rowOf = topo.rowOf;
    const std::vector<Index>& cellOfRow = topo.cellOfRow;
    const std::vector<unsigned char>& slotOf = topo.slotOf;
    const std::vector<Vec3i>& coords = topo.coords;
    const Index rows = static_cast<Index>(cellOfRow.size());
    SparseRows& S = topo.structure;
    S.value.resize(S.column.size());  // every entry is written by each fill (below)
    std::vector<Real> rhs(at(rows)), sol(at(rows), 0);
    CgWorkspace workspace;
    // The multigrid: from the cache when it was built for these active cells, else built on
    // the first iteration (and on every one without reuseMultigrid).
    std::unique_ptr<AggregationMultigrid> ownMg;
    const AggregationMultigrid* mg = nullptr;
    VolumeProjectionCache::Impl* cache = nullptr;
    if (settings.cache && settings.multigrid) {
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

    while (!done() && report.iterations < settings.maxIterations && rows > 0) {
        ++report.iterations;
        if (!gradientsFresh) (void)evaluate(true);
        // (J J^T)_cd = sum over shared corners of grad_c . grad_d, each pair once (on the row of
        // the later cell: slots up to the centre) and written to both positions: exactly
        // symmetric, half the products.
        auto fill = [&](const std::vector<std::array<Vec3, 8>>& gr) {
            parallelFor(rows, [&](Index i) {
                const Index c = cellOfRow[at(i)];
                const std::size_t base = at(c) * kStencil;
                for (int e = S.start[at(i)]; e < S.start[at(i) + 1]; ++e) {
                    const int s = slotOf[static_cast<std::size_t>(e)];
                    if (s > kStencil / 2) break;  // entries are in slot order
                    const Index d = nbCell[base + static_cast<std::size_t>(s)];
                    Real sum = 0;
                    for (int k = 0; k < 8; ++k) {
                        const int kd = sharedCorner[s][k];
                        if (kd >= 0)
                            sum += gr[at(c)][static_cast<std::size_t>(k)].dot(gr[at(d)][static_cast<std::size_t>(kd)]);
                    }
                    S.value[static_cast<std::size_t>(e)] = sum;
                    S.value[static_cast<std::size_t>(topo.mirror[static_cast<std::size_t>(e)])] = sum;
                }
            });
        };
        const bool build = settings.multigrid && (!mg || (!settings.reuseMultigrid && !cache));
        if (build && anySliding) {
            // The hierarchy is built as if the sliding points were free (it depends on the
            // positions and the fixed points alone, which a checkpoint keeps): the sliding
            // corners' full gradients, here only.
            std::vector<std::array<Vec3, 8>> full(at(nc));
            parallelFor(nc, [&](Index c) {
                std::array<Vec3, 8>& g = full[at(c)];
                (void)hexVolumeGradient(gatherCorners(cells, positions, c), g);
                for (std::size_t k = 0; k < 8; ++k) {
                    const Index p = cells.corners[at(c)][k];
                    if (isPinned(p)) g[k].setZero();
                    g[k] /= restVolumes[at(c)];
                    if (weights) g[k] *= rootW[at(p)];
                }
            });
            fill(full);
        } else {
            fill(grad);
        }
        parallelFor(rows, [&](Index i) {
            rhs[at(i)] = r[at(cellOfRow[at(i)])];
            sol[at(i)] = 0;
        });
        if (build) {
            ownMg.reset();
            ownMg = std::make_unique<AggregationMultigrid>(S, coords, mgSettings);
            if (cache) {
                cache->mg = std::move(ownMg);
                mg = cache->mg.get();
                settings.cache->builtFromPositions = start;  // what the hierarchy was built from
                settings.cache->builtFromPinned = pinned;
                for (unsigned char& f : settings.cache->builtFromPinned)
                    if (f == kSlides) f = 0;
            } else {
                mg = ownMg.get();
            }
            if (anySliding) fill(grad);  // the constrained matrix for the solve
        }
        // Inexact Gauss-Newton: no more linear accuracy than the step can use. The step leaves
        // about err^2 (the quadratic term) plus eta err, so eta ~ err on the way and
        // eta ~ tolerance / err on the last step, with a safety factor.
        const Real eta = settings.adaptiveLinearTolerance
                             ? std::max(settings.linearTolerance,
                                        std::min(Real(0.5), kSafety * std::max(err, settings.tolerance / err)))
                             : settings.linearTolerance;
        const SolveReport lin =
            conjugateGradients(S, mg, rhs, sol, 1, eta, 0, settings.maxLinearIterations, &workspace);
        report.linearIterations += lin.iterations;
        parallelFor(nc, [&](Index c) {
            lambda[at(c)] = rowOf[at(c)] >= 0 ? sol[at(rowOf[at(c)])] : Real(0);
            if (!applied.empty()) applied[at(c)] += lambda[at(c)];
        });
        applyMultipliers(lambda);
        // The error alone: the gradients are only needed if another iteration follows (about
        // 5 ms of writing them at 137k cells, where one iteration is the rule).
        err = evaluate(false);
        drift = driftOf();
        // Local polish, only where the step left the tolerance unmet: nonlinear Gauss-Seidel
        // (Kaczmarz) sweeps over the cells in 8 parity colours (cells of one colour share no
        // corner): each cell moves its free corners along its volume gradient to its rest
        // volume. Removes the rough, local part of the residual that the Krylov solve converges
        // slowest on. (Run only where the tolerance is still unmet: on every step they cost
        // 20-30 ms of the step at 137k cells, mostly where the Gauss-Newton step had met it.)
        if (!done() && settings.localSweeps > 0) {
            for (int sweep = 0; sweep < settings.localSweeps; ++sweep)
                for (int colour = 0; colour < 8; ++colour)
                    parallelFor(Index(colourCells[colour].size()), [&](Index i) {
                        const Index c = colourCells[colour][at(i)];
                        std::array<Vec3, 8> g;
                        const Real v = hexVolumeGradient(gatherCorners(cells, positions, c), g);
                        Real gg = 0;
                        std::array<Real, 8> w;
                        for (std::size_t k = 0; k < 8; ++k) {
                            const Index p = cells.corners[at(c)][k];
                            constrain(p, g[k]);
                            w[k] = weights ? (*weights)[at(p)] : Real(1);
                            gg += w[k] * g[k].squaredNorm();
                        }
                        if (!(gg > 0)) return;
                        const Real step = (restVolumes[at(c)] - v) / gg;
                        for (std::size_t k = 0; k < 8; ++k)
                            positions[at(cells.corners[at(c)][k])] += (step * w[k]) * g[k];
                    });
            err = evaluate(false);
            drift = driftOf();
        }
        gradientsFresh = false;
    }
    if (settings.multipliers) *settings.multipliers = std::move(applied);
    report.converged = done();
    report.maxErrorAfter = err;
    report.driftAfter = drift;
    report.maxMove = parallelReduce(
        np, Real(0), [&](Real& acc, Index p) { acc = std::max(acc, (positions[at(p)] - start[at(p)]).norm()); },
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
