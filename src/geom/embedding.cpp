#include "geom/embedding.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

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

}  // namespace

MeshEmbedding embedVertices(const Lattice& lat, const std::vector<Vec3>& restVertices) {
    DGV_CHECK_GT(lat.size(), Index(0));
    MeshEmbedding emb;
    const std::size_t nv = restVertices.size();
    emb.corners.resize(nv);
    emb.weights.resize(nv);
    emb.anchor.resize(nv);
    emb.offset.resize(nv);
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
    });
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
    });
}

}  // namespace dgv
