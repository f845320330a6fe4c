#include "geom/embedding.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

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

/// The moving-least-squares affine fit at lattice coordinate u over the points within kFitRadius
/// of `anchor`, reached through the 6-neighbour network (so a fit never joins two parts across a
/// gap). Writes the points and weights alpha_j (sum 1, sum alpha_j u_j = u); false when the
/// points do not span 3-D.
bool neighbourhoodFit(const Lattice& lat, Index anchor, const Vec3& u, std::vector<Index>& points,
                      std::vector<Real>& alphas) {
    const Vec3 ua = lat.coords[at(anchor)].cast<Real>();
    const Real r2Max = kFitRadius * kFitRadius;
    points.assign(1, anchor);
    for (std::size_t head = 0; head < points.size(); ++head) {
        for (const Index q : lat.neighbours[at(points[head])]) {
            if (q == kNoPoint || (lat.coords[at(q)].cast<Real>() - ua).squaredNorm() > r2Max) continue;
            if (std::find(points.begin(), points.end(), q) == points.end()) points.push_back(q);
        }
    }
    std::sort(points.begin(), points.end());  // the sums below in one order whatever the walk
    Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
    std::vector<Real> w(points.size());
    for (std::size_t j = 0; j < points.size(); ++j) {
        const Vec3 d = lat.coords[at(points[j])].cast<Real>() - ua;
        const Real f = Real(1) - d.squaredNorm() / r2Max;
        w[j] = f * f;
        const Eigen::Vector4d b(1, d.x(), d.y(), d.z());
        m += w[j] * b * b.transpose();
    }
    // A neighbourhood that is a sheet or a rod leaves the fit undetermined off it.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(m, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues()(0) > Real(1e-3) * eig.eigenvalues()(3))) return false;
    const Vec3 du = u - ua;
    const Eigen::Vector4d c = m.ldlt().solve(Eigen::Vector4d(1, du.x(), du.y(), du.z()));
    alphas.resize(points.size());
    for (std::size_t j = 0; j < points.size(); ++j) {
        const Vec3 d = lat.coords[at(points[j])].cast<Real>() - ua;
        alphas[j] = w[j] * (c(0) + c(1) * d.x() + c(2) * d.y() + c(3) * d.z());
    }
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
        if (blend > 0 && neighbourhoodFit(lat, anchor, u, fitPoints[v], fitWeights[v])) {
            emb.fitBlend[v] = blend;
        } else {
            fitPoints[v].clear();
            fitWeights[v].clear();
        }
    });
    emb.fitStart.assign(nv + 1, 0);
    for (std::size_t v = 0; v < nv; ++v) emb.fitStart[v + 1] = emb.fitStart[v] + Index(fitPoints[v].size());
    emb.fitPoint.reserve(at(emb.fitStart[nv]));
    emb.fitWeight.reserve(at(emb.fitStart[nv]));
    for (std::size_t v = 0; v < nv; ++v) {
        emb.fitPoint.insert(emb.fitPoint.end(), fitPoints[v].begin(), fitPoints[v].end());
        emb.fitWeight.insert(emb.fitWeight.end(), fitWeights[v].begin(), fitWeights[v].end());
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
