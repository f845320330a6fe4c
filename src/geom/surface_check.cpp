#include "geom/surface_check.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace dgv {

namespace {

/// cof(F) n0 with F's columns the tangents / h: n0x (f2 × f3) + n0y (f3 × f1) + n0z (f1 × f2).
Vec3 cofactorTimes(const GeometricState& state, std::size_t q, Real invH, const Vec3& n0) {
    const Vec3 f1 = state.tangent[0][q] * invH, f2 = state.tangent[1][q] * invH, f3 = state.tangent[2][q] * invH;
    return n0.x() * f2.cross(f3) + n0.y() * f3.cross(f1) + n0.z() * f1.cross(f2);
}

/// The stretch of e0 that the rule carrying vertex v predicts: its anchor's frame, and for a
/// vertex following its neighbourhood's fit (blend s) also the blended frame
/// (1 − s) x_a(anchor) + s ∂fit/∂u, the larger of the two. A fitted vertex moves with its fit's
/// gradient, which at a boundary can differ from its anchor's one-sided frame by a factor of
/// several (measured: a jelly pulled into a tube, 3.2× stretched, its boundary anchors' frames
/// 0.6×).
Real vertexFrameLength(const MeshEmbedding& emb, const GeometricState& state, std::size_t v, Real invH,
                       const Vec3& e0) {
    const std::size_t q = at(emb.anchor[v]);
    const Vec3 te = state.tangent[0][q] * e0.x() + state.tangent[1][q] * e0.y() + state.tangent[2][q] * e0.z();
    const Real s = emb.fitBlend.empty() ? Real(0) : emb.fitBlend[v];
    if (!(s > 0)) return te.norm() * invH;
    Vec3 ge = Vec3::Zero();
    for (Index j = emb.fitStart[v]; j < emb.fitStart[v + 1]; ++j)
        ge += emb.fitGradient[at(j)].dot(e0) * state.position[at(emb.fitPoint[at(j)])];
    return std::max(te.norm(), ((1 - s) * te + s * ge).norm()) * invH;
}

Vec3 normalOf(const std::vector<Vec3>& v, const std::array<int, 3>& t) {
    const Vec3& a = v[static_cast<std::size_t>(t[0])];
    return (v[static_cast<std::size_t>(t[1])] - a).cross(v[static_cast<std::size_t>(t[2])] - a);
}

Real longestEdge(const std::vector<Vec3>& v, const std::array<int, 3>& t) {
    const Vec3& a = v[static_cast<std::size_t>(t[0])];
    const Vec3& b = v[static_cast<std::size_t>(t[1])];
    const Vec3& c = v[static_cast<std::size_t>(t[2])];
    return std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
}

/// The edge pass's figures (the folds are counted from their own flags).
struct Counts {
    Index torn = 0;
    Real worst = 0;
};

Counts combine(Counts x, const Counts& y) {
    x.torn += y.torn;
    x.worst = std::max(x.worst, y.worst);
    return x;
}

}  // namespace

bool SurfaceCheck::ok() const {
    return tornEdges == 0 && Real(flippedTriangles) <= kMaxFlippedFraction * Real(triangles);
}

SurfaceCheckSetup prepareSurfaceCheck(const TriangleMesh& restMesh) {
    // (low vertex, high vertex, triangle) per triangle edge, sorted: equal edges are adjacent.
    std::vector<std::tuple<int, int, Index>> half;
    half.reserve(3 * restMesh.triangles.size());
    for (std::size_t t = 0; t < restMesh.triangles.size(); ++t)
        for (int e = 0; e < 3; ++e) {
            const int a = restMesh.triangles[t][static_cast<std::size_t>(e)];
            const int b = restMesh.triangles[t][static_cast<std::size_t>((e + 1) % 3)];
            if (a == b) continue;
            half.emplace_back(std::min(a, b), std::max(a, b), static_cast<Index>(t));
        }
    std::sort(half.begin(), half.end());
    SurfaceCheckSetup setup;
    for (std::size_t i = 0; i < half.size();) {
        std::size_t j = i;
        while (j < half.size() && std::get<0>(half[j]) == std::get<0>(half[i]) &&
               std::get<1>(half[j]) == std::get<1>(half[i]))
            ++j;
        setup.edges.push_back({std::get<0>(half[i]), std::get<1>(half[i])});
        if (j - i == 2)  // a manifold edge; non-manifold fans carry no one fold direction
            setup.neighbours.push_back({std::get<2>(half[i]), std::get<2>(half[i + 1]), std::get<0>(half[i])});
        i = j;
    }
    return setup;
}

SurfaceCheck checkSurface(const SurfaceCheckSetup& setup, const TriangleMesh& restMesh, const MeshEmbedding& emb,
                          const GeometricState& state, Real spacing, const std::vector<Vec3>& deformed) {
    DGV_CHECK_EQ(deformed.size(), restMesh.vertices.size());
    DGV_CHECK_EQ(emb.size(), restMesh.vertices.size());
    DGV_CHECK(spacing > 0);
    const Real invH = 1 / spacing;
    const auto& tris = restMesh.triangles;
    const auto& rest = restMesh.vertices;
    // Folds: neighbouring triangles turned more than 120° apart where the frame at their shared
    // edge predicts them within 90° of each other. A flag per pair (one writer each), then each
    // folded pair's triangles are marked, so a triangle counts once.
    std::vector<unsigned char> pairFolded(setup.neighbours.size(), 0);
    parallelFor(static_cast<Index>(setup.neighbours.size()), [&](Index k) {
        const auto& pair = setup.neighbours[at(k)];
        const auto& t1 = tris[at(pair[0])];
        const auto& t2 = tris[at(pair[1])];
        const Vec3 n1 = normalOf(deformed, t1), n2 = normalOf(deformed, t2);
        const Real len = n1.norm() * n2.norm();
        if (!(len > 0) || n1.dot(n2) >= kFoldCosine * len) return;  // degenerate, or not folded
        // A triangle thinner than kFoldHeight voxels (twice its area over its longest edge) is
        // below what the lattice resolves: a sliver whose vertices cross a hair apart is not a
        // fold anyone sees.
        const Real minHeight = kFoldHeight * spacing;
        if (n1.norm() < minHeight * longestEdge(deformed, t1) || n2.norm() < minHeight * longestEdge(deformed, t2))
            return;
        const Vec3 r1 = normalOf(rest, t1), r2 = normalOf(rest, t2);
        const std::size_t q = at(emb.anchor[at(pair[2])]);
        const Vec3 m1 = cofactorTimes(state, q, invH, r1);
        const Vec3 m2 = cofactorTimes(state, q, invH, r2);
        pairFolded[at(k)] = m1.dot(m2) > 0 ? 1 : 0;
    });
    std::vector<unsigned char> folded(tris.size(), 0);
    for (std::size_t k = 0; k < pairFolded.size(); ++k)
        if (pairFolded[k]) {
            folded[at(setup.neighbours[k][0])] = 1;
            folded[at(setup.neighbours[k][1])] = 1;
        }
    const Counts total = parallelReduce(
        static_cast<Index>(setup.edges.size()), Counts{},
        [&](Counts& acc, Index k) {
            const std::size_t a = static_cast<std::size_t>(setup.edges[at(k)][0]);
            const std::size_t b = static_cast<std::size_t>(setup.edges[at(k)][1]);
            const Vec3 e0 = rest[b] - rest[a];
            const Real predicted =
                std::max(vertexFrameLength(emb, state, a, invH, e0), vertexFrameLength(emb, state, b, invH, e0));
            const Real bound = kTearRatio * predicted + kTearSlack * spacing;
            const Real len = (deformed[b] - deformed[a]).norm();
            if (!(len <= bound)) ++acc.torn;  // also NaN
            acc.worst = std::max(acc.worst, kTearRatio * len / bound);
        },
        combine);
    SurfaceCheck out;
    out.triangles = static_cast<Index>(tris.size());
    for (unsigned char f : folded) out.flippedTriangles += f;
    out.tornEdges = total.torn;
    out.worstStretch = total.worst;
    return out;
}

}  // namespace dgv
