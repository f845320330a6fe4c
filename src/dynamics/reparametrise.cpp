// Re-parametrisation of a flowing body (reparametrise.hpp).

#include "dynamics/reparametrise.hpp"

#include "base/parallel.hpp"
#include "deform/volume.hpp"
#include "dynamics/body.hpp"
#include <cstdio>
#include "dynamics/stepper.hpp"
#include "geom/geometric_state.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace dgv {

namespace {

// The six tetrahedra of a cell along its diagonal from corner 0 to corner 7 (corner k at offset
// (k & 1, (k >> 1) & 1, (k >> 2) & 1)): one per order of the three axes. Neighbouring cells
// split their shared face along the same diagonal, so the tetrahedra of a lattice leave no gap.
constexpr std::array<std::array<int, 4>, 6> kTets = {
    {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}}};

// A sample of the old shape: the four old points of the tetrahedron it lies in and its
// barycentric weights (ids[0] = kNoPoint: outside every tetrahedron).
struct Sample {
    std::array<Index, 4> ids{{kNoPoint, kNoPoint, kNoPoint, kNoPoint}};
    std::array<Real, 4> w{{0, 0, 0, 0}};
    bool inside() const { return ids[0] != kNoPoint; }
};

// Sub-samples per cell along each axis when measuring how much of a new cell the old shape covers.
constexpr int kSub = 3;
constexpr int kSubSamples = kSub * kSub * kSub;

// Calls f(ids, v0, M⁻¹, lo, hi) for every tetrahedron of the old cells that is not flat, in cell
// order: its four point ids, its first vertex, the inverse of its edge matrix and its bounds.
template <typename F>
void forEachTetrahedron(const LatticeCells& cells, const std::vector<Vec3>& x, Real h, F&& f) {
    for (Index c = 0; c < cells.size(); ++c) {
        const std::array<Index, 8>& k = cells.corners[at(c)];
        for (const std::array<int, 4>& t : kTets) {
            const std::array<Index, 4> ids{{k[at(t[0])], k[at(t[1])], k[at(t[2])], k[at(t[3])]}};
            const Vec3& v0 = x[at(ids[0])];
            Mat3 m;
            m << x[at(ids[1])] - v0, x[at(ids[2])] - v0, x[at(ids[3])] - v0;
            if (!(std::abs(m.determinant()) > 1e-14 * h * h * h)) continue;  // a flat tetrahedron holds nothing
            Vec3 lo = v0, hi = v0;
            for (int j = 1; j < 4; ++j) {
                lo = lo.cwiseMin(x[at(ids[at(j)])]);
                hi = hi.cwiseMax(x[at(ids[at(j)])]);
            }
            f(ids, v0, Mat3(m.inverse()), lo, hi);
        }
    }
}

// Whether p lies in the tetrahedron (ids, v0, M⁻¹); if so its barycentric weights go to s.
bool barycentric(const std::array<Index, 4>& ids, const Vec3& v0, const Mat3& mi, const Vec3& p, Sample& s) {
    constexpr Real eps = 1e-10;
    const Vec3 l = mi * (p - v0);
    const Real l0 = 1 - l.sum();
    if (l.minCoeff() < -eps || l0 < -eps) return false;
    s.ids = ids;
    s.w = {l0, l.x(), l.y(), l.z()};
    return true;
}

Vec3 interpolate(const Sample& s, const std::vector<Vec3>& v) {
    Vec3 r = Vec3::Zero();
    for (int j = 0; j < 4; ++j) r += s.w[at(j)] * v[at(s.ids[at(j)])];
    return r;
}

/// The world-aligned grid of the new lattice: spacing h around the body, a margin of one
/// spacing each side.
struct RemapGrid {
    Vec3 origin = Vec3::Zero();
    Vec3i dims = Vec3i::Zero(), cellDims = Vec3i::Zero();
    Real h = 1;
    std::size_t cellIndex(const Vec3i& w) const {
        return at(w.x() + Index(cellDims.x()) * (w.y() + Index(cellDims.y()) * w.z()));
    }
    std::size_t gridIndex(const Vec3i& u) const {
        return at(u.x() + Index(dims.x()) * (u.y() + Index(dims.y()) * u.z()));
    }
    Vec3i cellOf(Index c) const {
        return Vec3i(int(c % cellDims.x()), int((c / cellDims.x()) % cellDims.y()),
                     int(c / (Index(cellDims.x()) * cellDims.y())));
    }
    Index cellCount() const { return Index(cellDims.prod()); }
};

RemapGrid gridAround(const std::vector<Vec3>& x, Real h) {
    RemapGrid g;
    g.h = h;
    Vec3 lo = x.front(), hi = x.front();
    for (const Vec3& p : x) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    for (int d = 0; d < 3; ++d) {
        g.origin[d] = (std::floor(lo[d] / h) - 1) * h;
        g.dims[d] = static_cast<int>(std::floor((hi[d] - g.origin[d]) / h)) + 3;
    }
    g.cellDims = g.dims - Vec3i::Ones();
    return g;
}

/// How much of each new cell the old shape covers, by kSub³ samples per cell, and the mean
/// velocity of the samples inside; with a rest shape to carry, each new cell's old tetrahedron
/// of its first sample.
struct Coverage {
    std::vector<int> inside;             ///< per cell: its samples inside the old shape
    std::vector<Vec3> velocitySum;       ///< per cell
    std::vector<std::array<Index, 4>> cellTet;
};

Coverage sampleCoverage(const LatticeCells& cells, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                        const RemapGrid& g, bool carriesRest) {
    const Real h = g.h;
    const Index cellCount = g.cellCount();
    Coverage cov;
    std::vector<unsigned char> covered(at(cellCount * kSubSamples), 0);  // per sample
    cov.inside.assign(at(cellCount), 0);
    cov.velocitySum.assign(at(cellCount), Vec3::Zero());
    cov.cellTet.assign(carriesRest ? at(cellCount) : 0, {{kNoPoint, kNoPoint, kNoPoint, kNoPoint}});
    const Vec3i fineDims = kSub * g.cellDims;
    forEachTetrahedron(
        cells, x, h,
        [&](const std::array<Index, 4>& ids, const Vec3& v0, const Mat3& mi, const Vec3& tlo, const Vec3& thi) {
            Vec3i a, b;
            for (int d = 0; d < 3; ++d) {
                a[d] = std::max(0, static_cast<int>(std::ceil((tlo[d] - g.origin[d]) / h * kSub - Real(0.5))));
                b[d] = std::min(fineDims[d] - 1,
                                static_cast<int>(std::floor((thi[d] - g.origin[d]) / h * kSub - Real(0.5))));
            }
            for (int kk = a.z(); kk <= b.z(); ++kk)
                for (int jj = a.y(); jj <= b.y(); ++jj)
                    for (int ii = a.x(); ii <= b.x(); ++ii) {
                        const Vec3i cell(ii / kSub, jj / kSub, kk / kSub);
                        const std::size_t c = g.cellIndex(cell);
                        const std::size_t f =
                            c * kSubSamples + at((ii % kSub) + kSub * ((jj % kSub) + kSub * (kk % kSub)));
                        if (covered[f]) continue;
                        const Vec3 p = g.origin + (h / kSub) * (Vec3(ii, jj, kk) + Vec3::Constant(Real(0.5)));
                        Sample s;
                        if (!barycentric(ids, v0, mi, p, s)) continue;
                        covered[f] = 1;
                        ++cov.inside[c];
                        cov.velocitySum[c] += interpolate(s, v);
                        if (carriesRest && cov.cellTet[c][0] == kNoPoint) cov.cellTet[c] = ids;
                    }
        });
    return cov;
}

/// The covered cells, most covered first (by their own samples, ties by their six neighbours'),
/// as (−key, cell).
std::vector<std::pair<long, Index>> rankCells(const RemapGrid& g, const Coverage& cov) {
    std::vector<std::pair<long, Index>> ranked;
    for (int k = 0; k < g.cellDims.z(); ++k)
        for (int j = 0; j < g.cellDims.y(); ++j)
            for (int i = 0; i < g.cellDims.x(); ++i) {
                const Vec3i w(i, j, k);
                const int own = cov.inside[g.cellIndex(w)];
                if (own == 0) continue;
                long key = long(own) * 7 * kSubSamples;
                for (int d = 0; d < 3; ++d)
                    for (int sgn = -1; sgn <= 1; sgn += 2) {
                        Vec3i q = w;
                        q[d] += sgn;
                        if (q[d] >= 0 && q[d] < g.cellDims[d]) key += cov.inside[g.cellIndex(q)];
                    }
                ranked.emplace_back(-key, Index(g.cellIndex(w)));
            }
    std::sort(ranked.begin(), ranked.end());
    return ranked;
}

/// The grid points of the first `count` ranked cells into mask; returns how many cells of the
/// grid are complete (all 8 corners in the mask).
Index chooseCells(const RemapGrid& g, const std::vector<std::pair<long, Index>>& ranked, std::size_t count,
                  std::vector<unsigned char>& mask) {
    std::fill(mask.begin(), mask.end(), 0);
    for (std::size_t r = 0; r < count; ++r) {
        const Vec3i w = g.cellOf(ranked[r].second);
        for (int q = 0; q < 8; ++q) mask[g.gridIndex(w + Vec3i(q & 1, (q >> 1) & 1, (q >> 2) & 1))] = 1;
    }
    Index complete = 0;
    for (int k = 0; k < g.cellDims.z(); ++k)
        for (int j = 0; j < g.cellDims.y(); ++j)
            for (int i = 0; i < g.cellDims.x(); ++i) {
                bool all = true;
                for (int q = 0; q < 8 && all; ++q)
                    all = mask[g.gridIndex(Vec3i(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1)))] != 0;
                complete += all ? 1 : 0;
            }
    return complete;
}

/// The new cells: the most covered ones, as many as make the complete cells' total closest to
/// target (in cells); the new points, their corners, as a mask of the grid's points. A cell
/// between chosen ones (a gap of under a voxel between two parts of the shape) is complete too
/// and counts, so the count is searched for: the complete cells grow with it, so the least
/// count that reaches the target, or the one before it if that is closer.
std::vector<unsigned char> chooseNewCells(const RemapGrid& g, const std::vector<std::pair<long, Index>>& ranked,
                                          Real target) {
    std::vector<unsigned char> mask(at(Index(g.dims.prod())), 0);
    auto complete = [&](std::size_t count) { return Real(chooseCells(g, ranked, count, mask)); };
    std::size_t least = 1, most = ranked.size();
    while (least < most) {
        const std::size_t mid = (least + most) / 2;
        if (complete(mid) >= target)
            most = mid;
        else
            least = mid + 1;
    }
    std::size_t count = least;
    if (count > 1 && std::abs(complete(count - 1) - target) < std::abs(complete(count) - target)) --count;
    (void)complete(count);
    return mask;
}

/// How much of the old shape the new cells leave more than a cell away: the covered share of the
/// cells that are neither new cells nor next to one (26 neighbours), in cells. Where the shape is
/// under a voxel thick, every cell is partly covered and the count's ranking can gather the
/// material of a thin sheet into a thick strip, a jump of several voxels (a draped sheet: 0.77 of
/// its volume; within a cell of where it was, a remap moves nothing by this measure).
Real coverLeftFar(const RemapGrid& g, const Coverage& cov, const LatticeCells& newCells) {
    std::vector<unsigned char> taken(at(g.cellCount()), 0);
    for (Index c = 0; c < newCells.size(); ++c) taken[g.cellIndex(newCells.lowest[at(c)])] = 1;
    Real far = 0;
    for (int k = 0; k < g.cellDims.z(); ++k)
        for (int j = 0; j < g.cellDims.y(); ++j)
            for (int i = 0; i < g.cellDims.x(); ++i) {
                const std::size_t c = g.cellIndex(Vec3i(i, j, k));
                if (cov.inside[c] == 0 || taken[c]) continue;
                bool near = false;
                for (int dz = -1; dz <= 1 && !near; ++dz)
                    for (int dy = -1; dy <= 1 && !near; ++dy)
                        for (int dx = -1; dx <= 1 && !near; ++dx) {
                            const Vec3i q(i + dx, j + dy, k + dz);
                            if ((q.array() < 0).any() || (q.array() >= g.cellDims.array()).any()) continue;
                            near = taken[g.cellIndex(q)] != 0;
                        }
                if (!near) far += Real(cov.inside[c]) / kSubSamples;
            }
    return far;
}

/// Each new point's old tetrahedron and barycentric weights (outside every one: none).
std::vector<Sample> sampleNewPoints(const LatticeCells& cells, const std::vector<Vec3>& x, const RemapGrid& g,
                                    const std::vector<unsigned char>& mask) {
    const Real h = g.h;
    std::vector<Sample> corners(at(Index(g.dims.prod())));
    forEachTetrahedron(
        cells, x, h,
        [&](const std::array<Index, 4>& ids, const Vec3& v0, const Mat3& mi, const Vec3& tlo, const Vec3& thi) {
            Vec3i a, b;
            for (int d = 0; d < 3; ++d) {
                a[d] = std::max(0, static_cast<int>(std::ceil((tlo[d] - g.origin[d]) / h)));
                b[d] = std::min(g.dims[d] - 1, static_cast<int>(std::floor((thi[d] - g.origin[d]) / h)));
            }
            for (int kk = a.z(); kk <= b.z(); ++kk)
                for (int jj = a.y(); jj <= b.y(); ++jj)
                    for (int ii = a.x(); ii <= b.x(); ++ii) {
                        Sample& s = corners[g.gridIndex(Vec3i(ii, jj, kk))];
                        if (!s.inside() && mask[g.gridIndex(Vec3i(ii, jj, kk))])
                            (void)barycentric(ids, v0, mi, g.origin + h * Vec3(ii, jj, kk), s);
                    }
        });
    return corners;
}

/// The rest shape's connection (putty) at new point p from the old points ids with weights w
/// (docs in reparametrise's body, "The rest shape's connection on the new lattice").
void restConnectionAt(const DeformableBody& body, Real hNew, Index p, const std::array<Index, 32>& ids,
                      const std::array<Real, 32>& w, int used, std::array<std::vector<Mat3>, 3>& restGamma) {
    const GeometricState& current = body.state();
    Mat3 frame = Mat3::Zero();
    std::array<Mat3, 3> d{{Mat3::Zero(), Mat3::Zero(), Mat3::Zero()}};
    for (std::size_t j = 0; j < at(used); ++j) {
        Mat3 f;
        f << current.tangent[0][at(ids[j])], current.tangent[1][at(ids[j])], current.tangent[2][at(ids[j])];
        frame += w[j] * f;
        for (std::size_t c = 0; c < 3; ++c)
            d[c] += w[j] * (body.plasticGamma()[c][at(ids[j])] - current.christoffel[c][at(ids[j])]);
    }
    const Eigen::FullPivLU<Mat3> lu(frame);
    if (used == 0 || !lu.isInvertible()) return;  // no rest shape to pull toward here
    const Mat3 G = hNew * lu.inverse(), Gi = frame / hNew;
    std::array<Mat3, 3> m;  // (Γ_p − Γ)^f in the new coordinates' lower indices
    for (std::size_t f = 0; f < 3; ++f) m[f] = G.transpose() * d[f] * G;
    for (std::size_t c = 0; c < 3; ++c) {
        Mat3 g = Mat3::Zero();
        for (std::size_t f = 0; f < 3; ++f) g += Gi(static_cast<Index>(c), static_cast<Index>(f)) * m[f];
        restGamma[c][at(p)] = Real(0.5) * (g + g.transpose());
    }
}

/// The new points' velocities and (carriesRest) rest connection: interpolated in the old
/// tetrahedra at the new points; a new point outside them (a corner of a new cell that pokes out
/// of the old shape) takes the mean of its cells' samples, and the rest connection the mean of
/// its cells' first tetrahedra's corners.
void interpolateAtNewPoints(const DeformableBody& body, const Lattice& grid, const RemapGrid& g, const Coverage& cov,
                            const std::vector<Sample>& corners, bool carriesRest, std::vector<Vec3>& vNew,
                            std::array<std::vector<Mat3>, 3>& restGamma) {
    const std::vector<Vec3>& v = body.velocities();
    const Index n = grid.size();
    const Real hNew = grid.spacing;
    parallelFor(n, [&](Index p) {
        const Vec3i& u = grid.coords[at(p)];
        const Sample& s = corners[g.gridIndex(u)];
        std::array<Index, 32> ids{};
        std::array<Real, 32> w{};
        if (s.inside()) {
            vNew[at(p)] = interpolate(s, v);
            if (carriesRest) {
                for (std::size_t j = 0; j < 4; ++j) {
                    ids[j] = s.ids[j];
                    w[j] = s.w[j];
                }
                restConnectionAt(body, hNew, p, ids, w, 4, restGamma);
            }
            return;
        }
        Vec3 total = Vec3::Zero();
        int samples = 0, used = 0;
        for (int c = 0; c < 8; ++c) {
            const Vec3i q = u - Vec3i(c & 1, (c >> 1) & 1, (c >> 2) & 1);
            if ((q.array() < 0).any() || (q.array() >= g.cellDims.array()).any()) continue;
            total += cov.velocitySum[g.cellIndex(q)];
            samples += cov.inside[g.cellIndex(q)];
            if (carriesRest && cov.cellTet[g.cellIndex(q)][0] != kNoPoint)
                for (Index id : cov.cellTet[g.cellIndex(q)]) ids[at(used++)] = id;
        }
        vNew[at(p)] = samples > 0 ? Vec3(total / samples) : Vec3::Zero();
        if (carriesRest && used > 0) {
            std::fill(w.begin(), w.begin() + used, Real(1) / used);
            restConnectionAt(body, hNew, p, ids, w, used, restGamma);
        }
    });
}

/// The new points' velocities put right so they carry the old points' momentum and angular
/// momentum about the centre; returns the turn δω given back, as the matrix r ↦ δω × r.
Mat3 keepMomentaOnRemap(const DeformableBody& body, const std::vector<Real>& mNew, const std::vector<Vec3>& xNew,
                        std::vector<Vec3>& vNew) {
    const Lattice& old = body.lattice();
    const std::vector<Vec3>& x = body.positions();
    const std::vector<Vec3>& v = body.velocities();
    const Index n = static_cast<Index>(xNew.size());
    // The same momentum as the old points carry over the last step.
    const std::vector<Real>& mOld = body.masses();
    Vec3 pOld = Vec3::Zero(), pNew = Vec3::Zero();
    Real massOld = 0, massNew = 0;
    for (Index p = 0; p < old.size(); ++p) {
        pOld += mOld[at(p)] * v[at(p)];
        massOld += mOld[at(p)];
    }
    for (Index p = 0; p < n; ++p) {
        pNew += mNew[at(p)] * vNew[at(p)];
        massNew += mNew[at(p)];
    }
    const Vec3 shift = pOld / massOld - pNew / massNew;
    for (Vec3& w : vNew) w += shift;
    // ... and the same angular momentum about the centre: the interpolation smooths the velocity
    // at the lattice scale, which took 3 % of a wound-up ball's spin; the rotation δω that gives
    // it back goes into the point velocities and into the flex's spin below.
    const Vec3 cOld = centreOfMass(mOld, x), cNew = centreOfMass(mNew, xNew);
    Vec3 lOld = Vec3::Zero(), lNew = Vec3::Zero();
    Mat3 inertia = Mat3::Zero();
    for (Index p = 0; p < old.size(); ++p) lOld += mOld[at(p)] * (x[at(p)] - cOld).cross(v[at(p)]);
    for (Index p = 0; p < n; ++p) {
        const Vec3 r = xNew[at(p)] - cNew;
        lNew += mNew[at(p)] * r.cross(vNew[at(p)]);
        inertia += mNew[at(p)] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    }
    const Vec3 spin = inertia.ldlt().solve(lOld - lNew);
    for (Index p = 0; p < n; ++p) vNew[at(p)] += spin.cross(xNew[at(p)] - cNew);
    Mat3 spinMatrix;  // spinMatrix r = spin × r
    spinMatrix << 0, -spin.z(), spin.y(), spin.z(), 0, -spin.x(), -spin.y(), spin.x(), 0;
    return spinMatrix;
}

/// The body's dynamic state on the new lattice, at its rest positions.
void stateOnNewLattice(const DeformableBody& body, const Lattice& grid, const std::vector<Real>& mNew,
                       const std::vector<Vec3>& xNew, const std::vector<Vec3>& vNew, const Mat3& spinMatrix,
                       DeformableBodyState& s) {
    const Index n = grid.size();
    s.positions = xNew;
    s.velocities = vNew;
    const Real dt = body.lastStepLength();
    s.lastStep = dt;
    s.freeFlight = body.freeFlight();
    for (auto& g : s.deltaGamma) g.assign(at(n), Mat3::Zero());
    if (dt > 0) {
        // The twist's rate: the connection change the points' velocities make over one step (no
        // affine motion changes Γ, so this is the non-affine part alone); the frames before
        // the last step from the same velocities.
        std::vector<Vec3> ahead(at(n)), behind(at(n));
        parallelFor(n, [&](Index p) {
            ahead[at(p)] = s.positions[at(p)] + dt * vNew[at(p)];
            behind[at(p)] = s.positions[at(p)] - dt * vNew[at(p)];
        });
        GeometricState now, next, prev;
        computeGeometricState(grid, s.positions, now, BoundaryStencils::Realisable);
        computeGeometricState(grid, ahead, next, BoundaryStencils::Realisable);
        computeGeometricState(grid, behind, prev, BoundaryStencils::Realisable);
        for (std::size_t c = 0; c < 3; ++c)
            parallelFor(
                n, [&](Index p) { s.deltaGamma[c][at(p)] = next.christoffel[c][at(p)] - now.christoffel[c][at(p)]; });
        s.tangentPrev = prev.tangent;
        s.havePrev = true;
    }
    s.contact.assign(at(n), 0);
    s.contactDepth.assign(at(n), 0);
    s.centre = centreOfMass(mNew, s.positions);
    s.centreVelocity = body.centreVelocity();
    // The new rest shape is the current one: A = 1, and the flex velocity is the old one's
    // velocity gradient Ȧ A⁻¹ (trace-free: tangent to SL(3) at 1).
    s.flex = Mat3::Identity();
    Mat3 l = body.flexVelocity() * body.flex().inverse();
    l -= (l.trace() / 3) * Mat3::Identity();
    s.flexVelocity = l + spinMatrix;
    s.halfStep = body.halfStep();
    s.displacement.assign(at(n), Vec3::Zero());
    s.displacementPrev.assign(at(n), Vec3::Zero());
}

}  // namespace

LatticeDistortion latticeDistortion(const DeformableBody& body) {
    const GeometricState& gs = body.state();
    const Real h = body.lattice().spacing;
    const Index n = body.lattice().size();
    struct Acc {
        Real gamma = 0, aspect = 1, det = std::numeric_limits<Real>::infinity();
    };
    const Acc r = parallelReduce(
        n, Acc(),
        [&](Acc& acc, Index p) {
            Real g2 = 0;
            for (std::size_t c = 0; c < 3; ++c) g2 += gs.christoffel[c][at(p)].squaredNorm();
            acc.gamma = std::max(acc.gamma, std::sqrt(g2));
            Mat3 f;
            f << gs.tangent[0][at(p)], gs.tangent[1][at(p)], gs.tangent[2][at(p)];
            f /= h;
            acc.det = std::min(acc.det, f.determinant());
            const Vec3 sv = Eigen::JacobiSVD<Mat3>(f).singularValues();
            acc.aspect = std::max(acc.aspect, sv[2] > 0 ? sv[0] / sv[2] : std::numeric_limits<Real>::infinity());
        },
        [](const Acc& a, const Acc& b) {
            Acc c;
            c.gamma = std::max(a.gamma, b.gamma);
            c.aspect = std::max(a.aspect, b.aspect);
            c.det = std::min(a.det, b.det);
            return c;
        });
    LatticeDistortion d;
    d.maxGamma = r.gamma;
    d.maxAspect = r.aspect;
    d.minFrameDet = n > 0 ? r.det : 1;
    return d;
}

Reparametrisation reparametrise(const DeformableBody& body) {
    Reparametrisation out;
    const DynamicsSettings& set = body.settings();
    if (body.anyPinned()) {
        out.refused = "it is pinned (a remap does not yet carry pins)";
        return out;
    }
    // Putty's rest shape goes with it: its connection relative to the current shape, Γ_p − Γ, is
    // interpolated at the new points with the frames and moved into the new lattice's coordinates
    // below. A jelly's is refused: it fails a frame where it is creased at the lattice scale, and
    // its rest connection so moved wound its memory up there (a dented ball of 6 voxels, k = 300:
    // Σ|δΓ|² 0.18 → 1.4 in 72 steps and a fault, where the ball that kept its lattice came round;
    // docs/math.md). Putty's Γ_p − Γ is under its yield, and the yield takes up what the move leaves.
    if (set.shapeStiffness > 0 && set.yieldStrain == 0) {
        out.refused = "it is a jelly (a remap does not yet carry a jelly's rest shape)";
        return out;
    }
    const bool carriesRest = set.shapeStiffness > 0;
    const std::vector<Vec3>& x = body.positions();
    const Real h = body.lattice().spacing;
    const LatticeCells& cells = body.cells();
    if (cells.size() == 0) {
        out.refused = "it has no complete cell";
        return out;
    }

    // A world-aligned grid of spacing h around the body (a margin of one spacing each side).
    const RemapGrid g = gridAround(x, h);
    const Vec3i& cellDims = g.cellDims;
    if (!(Real(cellDims.x()) * cellDims.y() * cellDims.z() <= Real(kMaxRemapGridCells))) {
        out.refused = "its parts lie too far apart for one grid (" + std::to_string(cellDims.x()) + " x " +
                      std::to_string(cellDims.y()) + " x " + std::to_string(cellDims.z()) + " cells)";
        return out;
    }
    const Coverage cov = sampleCoverage(cells, x, body.velocities(), g, carriesRest);
    // The new cells: the most covered ones, as many as make the complete cells' total closest to
    // the body's volume (chooseNewCells).
    Real restTotal = 0;
    for (Real r : body.restVolumes()) restTotal += r;
    const Real target = restTotal / (h * h * h);
    // The samples must see the shape: a sheet thinner than a sample spacing (a third of a voxel)
    // falls between them, and what they miss cannot be put anywhere near where it was.
    {
        long samples = 0;
        for (const int c : cov.inside) samples += c;
        out.sampled = Real(samples) / kSubSamples / target;
    }
    if (!(out.sampled >= kMinRemapSampled)) {
        char why[200];
        std::snprintf(why, sizeof why, "its samples see %.0f %% of its volume (parts under a third of a voxel thick)",
                      100 * out.sampled);
        out.refused = why;
        return out;
    }
    const std::vector<std::pair<long, Index>> ranked = rankCells(g, cov);
    if (ranked.empty()) {
        out.refused = "no cell of the new lattice lies inside its shape";
        return out;
    }
    const std::vector<unsigned char> mask = chooseNewCells(g, ranked, target);
    Lattice grid = buildLattice(g.origin, h, g.dims, mask);
    const LatticeCells newCells = buildCells(grid);
    out.mismatch = coverLeftFar(g, cov, newCells) / target;
    if (!(out.mismatch <= kMaxRemapMismatch)) {
        char why[200];
        std::snprintf(
            why, sizeof why,
            "its new cells would leave %.1f %% of its volume more than a cell away (parts under a voxel thick)",
            100 * out.mismatch);
        out.refused = why;
        return out;
    }

    // The spacing that makes the new cells' total the body's rest volume.
    const Real dilation = std::cbrt(restTotal / (static_cast<Real>(newCells.size()) * h * h * h));
    if (!(std::abs(dilation - 1) <= kMaxRemapDilation)) {
        char why[200];
        std::snprintf(why, sizeof why, "its new cells would hold %.1f %% of its volume (parts under a voxel thick)",
                      100 / (dilation * dilation * dilation));
        out.refused = why;
        return out;
    }
    out.pivot = body.centre();
    out.dilation = dilation;
    grid.originWorld = out.pivot + dilation * (g.origin - out.pivot);
    grid.spacing = h * dilation;

    // Velocities and the rest shape's connection at the new points. The rest shape's connection
    // on the new lattice (putty): with u the old lattice's coordinates and v the new one's,
    // G = ∂u/∂v = h' F⁻¹ (F the old frame [x_1 x_2 x_3], h' the new spacing), and a connection
    // changes coordinates as Γ'^c_ab = (G⁻¹)^c_f (Γ^f_de G^d_a G^e_b + ∂_b G^f_a). The new lattice
    // starts in the current shape (Γ' = 0), so the rest shape's connection in v is
    // (G⁻¹)^c_f (Γ_p − Γ)^f_de G^d_a G^e_b: what the memory asks for is what it asked for on the
    // old lattice, in the new coordinates. Γ_p − Γ and F are taken at a new point as a weighted
    // mean of the old points': inside the old tetrahedra their barycentric weights; outside, the
    // corners of each of its cells' first tetrahedra alike (a rest shape's fields are smooth;
    // continuing the tetrahedra's affine maps instead threw the values of sheared ones).
    const std::vector<Sample> corners = sampleNewPoints(cells, x, g, mask);
    const Index n = grid.size();
    std::vector<Vec3> vNew(at(n), Vec3::Zero());
    std::array<std::vector<Mat3>, 3> restGamma;
    if (carriesRest)
        for (auto& gm : restGamma) gm.assign(at(n), Mat3::Zero());
    interpolateAtNewPoints(body, grid, g, cov, corners, carriesRest, vNew, restGamma);
    const std::vector<Vec3> xNew = restPositions(grid);
    const std::vector<Real> mNew = pointMasses(grid, set.density, MassRule::CellShare);
    const Mat3 spinMatrix = keepMomentaOnRemap(body, mNew, xNew, vNew);
    DeformableBodyState& s = out.state;
    stateOnNewLattice(body, grid, mNew, xNew, vNew, spinMatrix, s);
    // The rest shape (putty): its connection from above, and the flex's rest stretch keeping the
    // elastic part of the flex, A P⁻¹: on the new lattice A = 1, so P' = P A⁻¹ (det 1). The yield
    // goes on from there.
    if (carriesRest) {
        s.plasticGamma = std::move(restGamma);
        const Mat3 P = body.plasticFlex() * body.flex().inverse();
        const Real det = P.determinant();
        if (!(det > 0)) {
            out = Reparametrisation();
            out.refused = "its flex has turned over (det A <= 0)";
            return out;
        }
        s.plasticFlex = P / std::cbrt(det);
    }
    out.lattice = std::move(grid);
    return out;
}

}  // namespace dgv
