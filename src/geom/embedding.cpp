#include "geom/embedding.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

namespace dgv {

namespace {

/// Nearest material point to continuous lattice coordinate u (Euclidean; ties: smallest id).
Index nearestPoint(const Lattice& lat, const Vec3& u) {
    const Vec3i& dims = lat.dims;
    // Nearest grid point, clamped to a range where the int arithmetic below cannot overflow.
    Vec3i c;
    for (int a = 0; a < 3; ++a) {
        const Real r = std::round(std::clamp(u[a], Real(-1e6), Real(dims[a]) + Real(1e6)));
        c[a] = static_cast<int>(r);
    }
    int rStart = 0, rMax = 0;
    for (int a = 0; a < 3; ++a) {
        rStart = std::max({rStart, -c[a], c[a] - (dims[a] - 1)});
        rMax = std::max({rMax, c[a], (dims[a] - 1) - c[a]});
    }
    Index best = kNoPoint;
    Real bestD2 = std::numeric_limits<Real>::max();
    auto consider = [&](int i, int j, int k, Index rowBase) {
        const Index q = lat.pointOfCell[at(rowBase + i)];
        if (q == kNoPoint) return;
        const Real d2 = (Vec3(i, j, k) - u).squaredNorm();
        if (d2 < bestD2 || (d2 == bestD2 && q < best)) {
            bestD2 = d2;
            best = q;
        }
    };
    for (int r = rStart; r <= rMax; ++r) {
        // Every grid point on shell r (Chebyshev distance r from c) is >= r - 1/2 away from u.
        const Real bound = Real(r) - Real(0.5);
        if (best != kNoPoint && bound > 0 && bound * bound > bestD2) break;
        const int k0 = std::max(c.z() - r, 0), k1 = std::min(c.z() + r, dims.z() - 1);
        const int j0 = std::max(c.y() - r, 0), j1 = std::min(c.y() + r, dims.y() - 1);
        const int i0 = std::max(c.x() - r, 0), i1 = std::min(c.x() + r, dims.x() - 1);
        for (int k = k0; k <= k1; ++k) {
            for (int j = j0; j <= j1; ++j) {
                const Index rowBase = Index(dims.x()) * (j + Index(dims.y()) * k);
                if (std::abs(k - c.z()) == r || std::abs(j - c.y()) == r) {
                    for (int i = i0; i <= i1; ++i) consider(i, j, k, rowBase);
                } else {
                    if (c.x() - r >= 0 && c.x() - r < dims.x()) consider(c.x() - r, j, k, rowBase);
                    if (r > 0 && c.x() + r >= 0 && c.x() + r < dims.x()) {
                        consider(c.x() + r, j, k, rowBase);
                    }
                }
            }
        }
    }
    DGV_CHECK(best != kNoPoint);
    return best;
}

/// The far vertex's blend towards its neighbourhood fit: 0 up to kFitFrom voxels from its
/// anchor, 1 from kFitFull, a smoothstep between.
Real fitBlendAt(Real distance) {
    const Real t = std::clamp((distance - kFitFrom) / (kFitFull - kFitFrom), Real(0), Real(1));
    return t * t * (3 - 2 * t);
}

/// The walk gathering a fit's points goes kFitWalkMargin voxels past its weights' reach, so a point
/// does not join the fit with a weight where a path to it opens as u moves.
constexpr Real kFitWalkMargin = 2;

/// The moving-least-squares affine fit at lattice coordinate u, centred on u itself: the points
/// within R = |u − u(anchor)| + kFitRadius of u, reached from `anchor` through the 6-neighbour
/// network within R + kFitWalkMargin (so a fit never joins two parts across a gap), weighted
/// (1 − r²/R²)² by their distance r from u. The weights, and so the fit, change continuously along the surface: the
/// anchor's distance is the distance to the nearest point, continuous in u, while the anchor
/// itself jumps (a fit centred on the anchor gave two vertices a quarter voxel apart on a
/// spider's leg the fits of neighbouring anchors, extrapolated 1.5 voxels; they landed 8 rest
/// lengths apart). Writes the points, the weights alpha_j (sum 1, sum alpha_j u_j = u) and their
/// derivatives in u (sum 0, sum grad_j u_jᵀ = 1); false when the points do not span 3-D.
bool neighbourhoodFit(const Lattice& lat, Index anchor, const Vec3& u, std::vector<Index>& points,
                      std::vector<Real>& alphas, std::vector<Vec3>& gradients) {
    const Real radius = (lat.coords[at(anchor)].cast<Real>() - u).norm() + kFitRadius;
    const Real r2Max = radius * radius;
    const Real r2Walk = (radius + kFitWalkMargin) * (radius + kFitWalkMargin);
    points.assign(1, anchor);
    std::unordered_set<Index> seen{anchor};
    for (std::size_t head = 0; head < points.size(); ++head) {
        for (const Index q : lat.neighbours[at(points[head])]) {
            if (q == kNoPoint || (lat.coords[at(q)].cast<Real>() - u).squaredNorm() >= r2Walk) continue;
            if (seen.insert(q).second) points.push_back(q);
        }
    }
    points.erase(std::remove_if(points.begin(), points.end(),
                                [&](Index q) { return (lat.coords[at(q)].cast<Real>() - u).squaredNorm() >= r2Max; }),
                 points.end());
    std::sort(points.begin(), points.end());  // the sums below in one order whatever the walk
    // The weighted least-squares affine map about the points' weighted mean ū:
    // alpha_j = w_j (1/W + (u_j − ū)ᵀ S⁻¹ (u − ū)), grad_j = w_j S⁻¹ (u_j − ū), with
    // S = sum_j w_j (u_j − ū)(u_j − ū)ᵀ.
    std::vector<Real> w(points.size());
    Real wSum = 0;
    Vec3 mean = Vec3::Zero();
    for (std::size_t j = 0; j < points.size(); ++j) {
        const Real f = Real(1) - (lat.coords[at(points[j])].cast<Real>() - u).squaredNorm() / r2Max;
        w[j] = f * f;
        wSum += w[j];
        mean += w[j] * lat.coords[at(points[j])].cast<Real>();
    }
    mean /= wSum;
    Mat3 spread = Mat3::Zero();
    for (std::size_t j = 0; j < points.size(); ++j) {
        const Vec3 d = lat.coords[at(points[j])].cast<Real>() - mean;
        spread += w[j] * d * d.transpose();
    }
    // A neighbourhood that is a sheet or a rod leaves the fit undetermined off it: its thinnest
    // direction must spread a tenth of a voxel (rms) at least.
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(spread / wSum, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues()(0) > Real(0.01))) return false;
    const Eigen::LDLT<Mat3> spreadInv(spread);
    const Vec3 toU = spreadInv.solve(u - mean);
    alphas.resize(points.size());
    gradients.resize(points.size());
    for (std::size_t j = 0; j < points.size(); ++j) {
        const Vec3 d = lat.coords[at(points[j])].cast<Real>() - mean;
        alphas[j] = w[j] * (1 / wSum + d.dot(toU));
        gradients[j] = w[j] * spreadInv.solve(d);
    }
    // One refinement of the two identities the affine reproduction rests on (sum 1, sum alpha_j
    // u_j = u): far out the weights extrapolate, and their round-off grew with the points.
    Real sum = 0;
    Vec3 reached = Vec3::Zero();
    for (std::size_t j = 0; j < points.size(); ++j) {
        sum += alphas[j];
        reached += alphas[j] * (lat.coords[at(points[j])].cast<Real>() - mean);
    }
    const Vec3 miss = (u - mean) - reached;
    for (std::size_t j = 0; j < points.size(); ++j) alphas[j] += (1 - sum) * w[j] / wSum + gradients[j].dot(miss);
    return true;
}

}  // namespace

Index MeshEmbedding::farVertices() const {
    Index n = 0;
    for (std::size_t v = 0; v < size(); ++v) n += !trilinear(v) && offset[v].norm() >= kFitFull ? 1 : 0;
    return n;
}

Index MeshEmbedding::fittedVertices() const {
    Index n = 0;
    for (const Real s : fitBlend) n += s > 0 ? 1 : 0;
    return n;
}

MeshEmbedding embedVertices(const Lattice& lat, const std::vector<Vec3>& restVertices, bool fitOutside) {
    DGV_CHECK_GT(lat.size(), Index(0));
    MeshEmbedding emb;
    const std::size_t nv = restVertices.size();
    emb.corners.resize(nv);
    emb.weights.resize(nv);
    emb.anchor.resize(nv);
    emb.offset.resize(nv);
    emb.fitBlend.assign(nv, Real(0));
    std::vector<std::vector<Index>> fitPoints(nv);
    std::vector<std::vector<Real>> fitWeights(nv);
    std::vector<std::vector<Vec3>> fitGradients(nv);
    const Real invH = Real(1) / lat.spacing;
    parallelFor(static_cast<Index>(nv), [&](Index vi) {
        const std::size_t v = at(vi);
        const Vec3 u = (restVertices[v] - lat.originWorld) * invH;
        DGV_CHECK(u.allFinite());
        std::array<Index, 8>& corners = emb.corners[v];
        std::array<Real, 8>& weights = emb.weights[v];
        corners.fill(kNoPoint);
        weights.fill(Real(0));
        bool full = true;
        Vec3i base;
        Vec3 frac;
        for (int a = 0; a < 3; ++a) {
            const Real f = std::floor(u[a]);
            if (!(f >= 0 && f + 1 <= Real(lat.dims[a] - 1))) full = false;
            base[a] = full ? static_cast<int>(f) : 0;
            frac[a] = u[a] - f;
        }
        std::array<Index, 8> cand;
        for (int corner = 0; corner < 8 && full; ++corner) {
            const Vec3i q = base + Vec3i(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            cand[static_cast<std::size_t>(corner)] = lat.pointAt(q);
            if (cand[static_cast<std::size_t>(corner)] == kNoPoint) full = false;
        }
        Index anchor = kNoPoint;
        if (full) {
            corners = cand;
            Real bestD2 = std::numeric_limits<Real>::max();
            for (int corner = 0; corner < 8; ++corner) {
                const Vec3 d(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
                const Real wx = d.x() != 0 ? frac.x() : Real(1) - frac.x();
                const Real wy = d.y() != 0 ? frac.y() : Real(1) - frac.y();
                const Real wz = d.z() != 0 ? frac.z() : Real(1) - frac.z();
                weights[static_cast<std::size_t>(corner)] = wx * wy * wz;
                const Index q = cand[static_cast<std::size_t>(corner)];
                const Real d2 = (d - frac).squaredNorm();
                if (d2 < bestD2 || (d2 == bestD2 && q < anchor)) {
                    bestD2 = d2;
                    anchor = q;
                }
            }
        } else {
            anchor = nearestPoint(lat, u);
        }
        emb.anchor[v] = anchor;
        emb.offset[v] = u - lat.coords[at(anchor)].cast<Real>();
        const Real blend = full ? Real(0) : fitOutside ? Real(1) : fitBlendAt(emb.offset[v].norm());
        if (blend > 0 && neighbourhoodFit(lat, anchor, u, fitPoints[v], fitWeights[v], fitGradients[v])) {
            emb.fitBlend[v] = blend;
        } else {
            fitPoints[v].clear();
            fitWeights[v].clear();
            fitGradients[v].clear();
        }
    });
    emb.fitStart.assign(nv + 1, 0);
    for (std::size_t v = 0; v < nv; ++v) emb.fitStart[v + 1] = emb.fitStart[v] + Index(fitPoints[v].size());
    emb.fitPoint.reserve(at(emb.fitStart[nv]));
    emb.fitWeight.reserve(at(emb.fitStart[nv]));
    emb.fitGradient.reserve(at(emb.fitStart[nv]));
    for (std::size_t v = 0; v < nv; ++v) {
        emb.fitPoint.insert(emb.fitPoint.end(), fitPoints[v].begin(), fitPoints[v].end());
        emb.fitWeight.insert(emb.fitWeight.end(), fitWeights[v].begin(), fitWeights[v].end());
        emb.fitGradient.insert(emb.fitGradient.end(), fitGradients[v].begin(), fitGradients[v].end());
    }
    return emb;
}

void deformVertices(const MeshEmbedding& emb, const GeometricState& state, std::vector<Vec3>& vertices) {
    const std::size_t nv = emb.size();
    vertices.resize(nv);
    const bool second = emb.secondOrder;
    parallelFor(static_cast<Index>(nv), [&](Index vi) {
        const std::size_t v = at(vi);
        if (emb.trilinear(v)) {
            Vec3 x = Vec3::Zero();
            for (std::size_t k = 0; k < 8; ++k) {
                x += emb.weights[v][k] * state.position[at(emb.corners[v][k])];
            }
            vertices[v] = x;
            return;
        }
        const std::size_t q = at(emb.anchor[v]);
        const Vec3& d = emb.offset[v];
        Vec3 dx = state.tangent[0][q] * d.x() + state.tangent[1][q] * d.y() + state.tangent[2][q] * d.z();
        if (second) {
            Vec3 quad = Vec3::Zero();
            for (std::size_t k = 0; k < 6; ++k) {
                const int a = kSymmetricPairs[k][0], b = kSymmetricPairs[k][1];
                const Real w = (a == b ? Real(0.5) : Real(1)) * d[a] * d[b];
                quad += w * state.second[k][q];
            }
            dx += quad;
        }
        vertices[v] = state.position[q] + dx;
        const Real s = emb.fitBlend.empty() ? Real(0) : emb.fitBlend[v];
        if (s > 0) {
            Vec3 fit = Vec3::Zero();
            for (Index j = emb.fitStart[v]; j < emb.fitStart[v + 1]; ++j) {
                fit += emb.fitWeight[at(j)] * state.position[at(emb.fitPoint[at(j)])];
            }
            vertices[v] += s * (fit - vertices[v]);
        }
    });
}

}  // namespace dgv
