// The exact signed distance to a closed triangle mesh (mesh_distance.hpp).

#include "collide/mesh_distance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dgv {

namespace {

constexpr int kLeafSize = 4;

// Where on a triangle the nearest point lies: a vertex k, the edge k (from vertex k to k + 1) or
// the face.
enum class Feature { Vertex, Edge, Face };

struct Nearest {
    Vec3 point = Vec3::Zero();
    Feature feature = Feature::Face;
    int index = 0;
};

Nearest onSegment(const Vec3& x, const Vec3& a, const Vec3& b, int edge) {
    const Vec3 ab = b - a;
    const Real len2 = ab.squaredNorm();
    const Real t = len2 > 0 ? (x - a).dot(ab) / len2 : Real(0);
    if (t <= 0) return {a, Feature::Vertex, edge};
    if (t >= 1) return {b, Feature::Vertex, (edge + 1) % 3};
    return {a + t * ab, Feature::Edge, edge};
}

// The nearest point of triangle (a, b, c) to x, by the Voronoi regions of its features.
Nearest onTriangle(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c, bool degenerate) {
    if (degenerate) {  // no face: the nearest of the three edges
        Nearest best = onSegment(x, a, b, 0);
        Real d = (x - best.point).squaredNorm();
        for (int e = 1; e < 3; ++e) {
            const Nearest n = onSegment(x, e == 1 ? b : c, e == 1 ? c : a, e);
            const Real dn = (x - n.point).squaredNorm();
            if (dn < d) {
                d = dn;
                best = n;
            }
        }
        return best;
    }
    const Vec3 ab = b - a, ac = c - a, ap = x - a;
    const Real d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return {a, Feature::Vertex, 0};
    const Vec3 bp = x - b;
    const Real d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return {b, Feature::Vertex, 1};
    const Real vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return {a + (d1 / (d1 - d3)) * ab, Feature::Edge, 0};
    const Vec3 cp = x - c;
    const Real d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return {c, Feature::Vertex, 2};
    const Real vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return {a + (d2 / (d2 - d6)) * ac, Feature::Edge, 2};
    const Real va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
        return {b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b), Feature::Edge, 1};
    const Real inv = 1 / (va + vb + vc);
    return {a + ab * (vb * inv) + ac * (vc * inv), Feature::Face, 0};
}

Real boxDistance2(const Box3& b, const Vec3& x) {
    const Vec3 d = (b.min - x).cwiseMax(x - b.max).cwiseMax(Vec3::Zero());
    return d.squaredNorm();
}

Real angleAt(const Vec3& p, const Vec3& q, const Vec3& r) {
    const Vec3 u = q - p, v = r - p;
    return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace

MeshDistance::MeshDistance(const TriangleMesh& mesh) {
    const std::size_t t = mesh.triangles.size();
    if (t == 0) return;
    // Pseudonormals on the mesh's connectivity: per vertex the angle-weighted sum of the unit
    // face normals, per edge (keyed by its two vertex indices) the sum of its faces' normals.
    std::vector<Vec3> faceNormal(t), vertexNormal(mesh.vertices.size(), Vec3::Zero());
    std::vector<unsigned char> degenerate(t, 0);
    struct EdgeRef {
        std::uint64_t key;
        std::uint32_t tri;
        std::uint8_t k;
    };
    std::vector<EdgeRef> edges;
    edges.reserve(3 * t);
    for (std::size_t f = 0; f < t; ++f) {
        const auto& tri = mesh.triangles[f];
        const Vec3 &a = mesh.vertices[static_cast<std::size_t>(tri[0])],
                   &b = mesh.vertices[static_cast<std::size_t>(tri[1])],
                   &c = mesh.vertices[static_cast<std::size_t>(tri[2])];
        const Vec3 n = (b - a).cross(c - a);
        const Real len = n.norm();
        const Real scale = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
        degenerate[f] = !(len > 1e-14 * scale);
        faceNormal[f] = degenerate[f] ? Vec3::Zero() : Vec3(n / len);
        if (!degenerate[f]) {
            vertexNormal[static_cast<std::size_t>(tri[0])] += angleAt(a, b, c) * faceNormal[f];
            vertexNormal[static_cast<std::size_t>(tri[1])] += angleAt(b, c, a) * faceNormal[f];
            vertexNormal[static_cast<std::size_t>(tri[2])] += angleAt(c, a, b) * faceNormal[f];
        }
        for (int k = 0; k < 3; ++k) {
            const auto lo = static_cast<std::uint64_t>(std::min(tri[k], tri[(k + 1) % 3]));
            const auto hi = static_cast<std::uint64_t>(std::max(tri[k], tri[(k + 1) % 3]));
            edges.push_back({lo << 32 | hi, static_cast<std::uint32_t>(f), static_cast<std::uint8_t>(k)});
        }
    }
    std::sort(edges.begin(), edges.end(), [](const EdgeRef& x, const EdgeRef& y) {
        return x.key != y.key ? x.key < y.key : (x.tri != y.tri ? x.tri < y.tri : x.k < y.k);
    });
    std::vector<std::array<Vec3, 3>> edgeNormal(t);
    for (std::size_t e = 0; e < edges.size();) {
        std::size_t end = e;
        Vec3 sum = Vec3::Zero();
        while (end < edges.size() && edges[end].key == edges[e].key) sum += faceNormal[edges[end++].tri];
        for (; e < end; ++e) edgeNormal[edges[e].tri][edges[e].k] = sum;
    }

    std::vector<Vec3> centroids(t);
    std::vector<Tri> tris(t);
    for (std::size_t f = 0; f < t; ++f) {
        Tri& tr = tris[f];
        for (int k = 0; k < 3; ++k) {
            const auto v = static_cast<std::size_t>(mesh.triangles[f][static_cast<std::size_t>(k)]);
            tr.v[static_cast<std::size_t>(k)] = mesh.vertices[v];
            const Real len = vertexNormal[v].norm();
            tr.vertexNormal[static_cast<std::size_t>(k)] = len > 0 ? Vec3(vertexNormal[v] / len) : Vec3::Zero();
            mBounds.extend(mesh.vertices[v]);
        }
        tr.faceNormal = faceNormal[f];
        tr.edgeNormal = edgeNormal[f];
        tr.source = static_cast<int>(f);
        centroids[f] = (tr.v[0] + tr.v[1] + tr.v[2]) / 3;
    }
    std::vector<Box3> boxes(t);
    for (std::size_t f = 0; f < t; ++f)
        for (const Vec3& v : tris[f].v) boxes[f].extend(v);
    mTree = BoxTree(boxes, centroids, kLeafSize);
    // The triangles in leaf order: a leaf's are contiguous.
    const std::vector<int>& order = mTree.order();
    mTriangles.resize(t);
    for (std::size_t k = 0; k < t; ++k) mTriangles[k] = tris[static_cast<std::size_t>(order[k])];
}

Real MeshDistance::signedDistance(const Vec3& x, Vec3* gradient, Real beyond) const {
    const Closest c = closest(x, beyond);
    if (gradient) *gradient = c.gradient;
    return c.distance;
}

MeshDistance::Closest MeshDistance::closest(const Vec3& x, Real beyond) const {
    Closest out;
    if (mTriangles.empty()) return out;
    if (const Real b2 = boxDistance2(mBounds, x); b2 > beyond * beyond) {
        out.distance = std::sqrt(b2);
        out.gradient = (x - x.cwiseMax(mBounds.min).cwiseMin(mBounds.max)) / out.distance;
        return out;
    }
    Real best = std::numeric_limits<Real>::infinity();
    Nearest nearest;
    int nearestTri = -1;
    // Nearest-first traversal with an explicit stack; a node is skipped once its box is no
    // nearer than the best triangle so far.
    std::array<std::pair<int, Real>, 64> stack;
    int top = 0;
    const std::vector<BoxTree::Node>& nodes = mTree.nodes();
    stack[static_cast<std::size_t>(top++)] = {0, boxDistance2(nodes[0].box, x)};
    while (top > 0) {
        const auto [id, d2] = stack[static_cast<std::size_t>(--top)];
        if (d2 >= best) continue;
        const BoxTree::Node& node = nodes[static_cast<std::size_t>(id)];
        if (node.left < 0) {
            for (int f = node.first; f < node.first + node.count; ++f) {
                const Tri& tr = mTriangles[static_cast<std::size_t>(f)];
                const Nearest n = onTriangle(x, tr.v[0], tr.v[1], tr.v[2], tr.faceNormal.isZero());
                const Real dn = (x - n.point).squaredNorm();
                if (dn < best) {
                    best = dn;
                    nearest = n;
                    nearestTri = f;
                }
            }
            continue;
        }
        const Real dl = boxDistance2(nodes[static_cast<std::size_t>(node.left)].box, x);
        const Real dr = boxDistance2(nodes[static_cast<std::size_t>(node.right)].box, x);
        // The nearer child goes on top, so it is visited first. The depth is about log2(T / 4)
        // and each level leaves at most one node behind: 64 entries cover any mesh.
        if (dl < dr) {
            stack[static_cast<std::size_t>(top++)] = {node.right, dr};
            stack[static_cast<std::size_t>(top++)] = {node.left, dl};
        } else {
            stack[static_cast<std::size_t>(top++)] = {node.left, dl};
            stack[static_cast<std::size_t>(top++)] = {node.right, dr};
        }
    }
    const Tri& tr = mTriangles[static_cast<std::size_t>(nearestTri)];
    Vec3 pseudo = nearest.feature == Feature::Face   ? tr.faceNormal
                  : nearest.feature == Feature::Edge ? tr.edgeNormal[static_cast<std::size_t>(nearest.index)]
                                                     : tr.vertexNormal[static_cast<std::size_t>(nearest.index)];
    if (!(pseudo.squaredNorm() > 0)) pseudo = tr.faceNormal;  // a feature whose faces cancel
    const Vec3 d = x - nearest.point;
    const Real dist = std::sqrt(best);
    const Real sign = d.dot(pseudo) < 0 ? Real(-1) : Real(1);
    if (dist > 1e-12 * (1 + mBounds.size().norm()))
        out.gradient = sign * d / dist;
    else
        out.gradient = pseudo.squaredNorm() > 0 ? Vec3(pseudo.normalized()) : Vec3(Vec3::UnitY());
    out.distance = sign * dist;
    out.triangle = tr.source;
    // The nearest point's barycentric coordinates: by areas on the face, exact on an edge or
    // a vertex (the point lies on it).
    const Vec3 e0 = tr.v[1] - tr.v[0], e1 = tr.v[2] - tr.v[0], r = nearest.point - tr.v[0];
    const Real d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1), den = d00 * d11 - d01 * d01;
    if (den > 0) {
        const Real b1 = std::clamp((d11 * e0.dot(r) - d01 * e1.dot(r)) / den, Real(0), Real(1));
        const Real b2 = std::clamp((d00 * e1.dot(r) - d01 * e0.dot(r)) / den, Real(0), 1 - b1);
        out.barycentric = Vec3(1 - b1 - b2, b1, b2);
    } else {
        // a degenerate triangle: the nearest vertex
        int k = 0;
        for (int i = 1; i < 3; ++i)
            if ((tr.v[static_cast<std::size_t>(i)] - nearest.point).squaredNorm() <
                (tr.v[static_cast<std::size_t>(k)] - nearest.point).squaredNorm())
                k = i;
        out.barycentric = Vec3::Unit(k);
    }
    return out;
}

}  // namespace dgv
