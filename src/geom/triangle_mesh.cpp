#include "geom/triangle_mesh.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>
#include <utility>

namespace dgv {

namespace {

/// One directed edge of a triangle, keyed by its undirected vertex pair.
struct EdgeUse {
    int lo, hi;
    int dir;  ///< +1 when the triangle walks lo -> hi, -1 when hi -> lo
    bool operator<(const EdgeUse& o) const {
        if (lo != o.lo) return lo < o.lo;
        if (hi != o.hi) return hi < o.hi;
        return dir < o.dir;
    }
};

}  // namespace

std::vector<int> samePositionRepresentatives(const std::vector<Vec3>& vertices) {
    const std::size_t n = vertices.size();
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    // Sorted by position, then by index: the first of each run of equal positions is the lowest.
    std::sort(order.begin(), order.end(), [&](int a, int b) {
        const Vec3& p = vertices[static_cast<std::size_t>(a)];
        const Vec3& q = vertices[static_cast<std::size_t>(b)];
        if (p.x() != q.x()) return p.x() < q.x();
        if (p.y() != q.y()) return p.y() < q.y();
        if (p.z() != q.z()) return p.z() < q.z();
        return a < b;
    });
    std::vector<int> rep(n);
    for (std::size_t i = 0; i < n; ++i) {
        const auto v = static_cast<std::size_t>(order[i]);
        const bool same = i > 0 && vertices[static_cast<std::size_t>(order[i - 1])] == vertices[v];
        rep[v] = same ? rep[static_cast<std::size_t>(order[i - 1])] : order[i];
    }
    return rep;
}

std::size_t dropDegenerateTriangles(TriangleMesh& mesh) {
    const std::size_t before = mesh.triangles.size();
    auto degenerate = [&](const std::array<int, 3>& t) {
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
        const Vec3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
        const Vec3& b = mesh.vertices[static_cast<std::size_t>(t[1])];
        const Vec3& c = mesh.vertices[static_cast<std::size_t>(t[2])];
        const Vec3 e0 = b - a, e1 = c - b, e2 = a - c;
        const Real longest2 = std::max({e0.squaredNorm(), e1.squaredNorm(), e2.squaredNorm()});
        return !(e0.cross(-e2).norm() > 1e-14 * longest2);
    };
    // Compacted in place with the per-triangle look beside them.
    const bool look = mesh.triangleMaterials.size() == before && mesh.cornerUvs.size() == before;
    std::size_t kept = 0;
    for (std::size_t f = 0; f < before; ++f) {
        if (degenerate(mesh.triangles[f])) continue;
        mesh.triangles[kept] = mesh.triangles[f];
        if (look) {
            mesh.triangleMaterials[kept] = mesh.triangleMaterials[f];
            mesh.cornerUvs[kept] = mesh.cornerUvs[f];
        }
        ++kept;
    }
    mesh.triangles.resize(kept);
    if (look) {
        mesh.triangleMaterials.resize(kept);
        mesh.cornerUvs.resize(kept);
    }
    return before - kept;
}

namespace {
/// Reverses triangle f's winding (its corners 1 and 2, their texture coordinates with them).
void turnTriangle(TriangleMesh& mesh, std::size_t f) {
    std::swap(mesh.triangles[f][1], mesh.triangles[f][2]);
    if (mesh.cornerUvs.size() == mesh.triangles.size()) std::swap(mesh.cornerUvs[f][1], mesh.cornerUvs[f][2]);
}
}  // namespace

Vec3 meanSurfaceColour(const TriangleMesh& mesh, const Vec3& fallback) {
    if (!mesh.hasMaterials()) return fallback;
    std::vector<Vec3> colours(mesh.materials.size());
    for (std::size_t m = 0; m < colours.size(); ++m) colours[m] = mesh.materials[m].meanColour();
    Vec3 sum = Vec3::Zero();
    Real area = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
        const auto& t = mesh.triangles[f];
        const Vec3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
        const Real af = (mesh.vertices[static_cast<std::size_t>(t[1])] - a)
                            .cross(mesh.vertices[static_cast<std::size_t>(t[2])] - a)
                            .norm();
        const int m = mesh.triangleMaterials[f];
        sum += af * (m >= 0 && static_cast<std::size_t>(m) < colours.size() ? colours[static_cast<std::size_t>(m)] : fallback);
        area += af;
    }
    return area > 0 ? Vec3(sum / area) : fallback;
}

Box3 meshBounds(const TriangleMesh& mesh) {
    Box3 box;
    for (const auto& t : mesh.triangles)
        for (int v : t) box.extend(mesh.vertices[static_cast<std::size_t>(v)]);
    return box;
}

Real meshSignedVolume(const TriangleMesh& mesh) {
    Real sum = 0;
    for (const auto& t : mesh.triangles) {
        const Vec3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
        const Vec3& b = mesh.vertices[static_cast<std::size_t>(t[1])];
        const Vec3& c = mesh.vertices[static_cast<std::size_t>(t[2])];
        sum += a.dot(b.cross(c));
    }
    return sum / 6;
}

MeshReport analyseMesh(const TriangleMesh& mesh) {
    MeshReport r;
    r.vertices = mesh.vertices.size();
    r.triangles = mesh.triangles.size();
    r.bounds = meshBounds(mesh);
    r.signedVolume = meshSignedVolume(mesh);

    std::vector<EdgeUse> uses;
    uses.reserve(mesh.triangles.size() * 3);
    for (const auto& t : mesh.triangles) {
        for (int k = 0; k < 3; ++k) {
            const int a = t[k], b = t[(k + 1) % 3];
            if (a == b) continue;
            uses.push_back(a < b ? EdgeUse{a, b, +1} : EdgeUse{b, a, -1});
        }
    }
    std::sort(uses.begin(), uses.end());

    bool consistent = true;
    for (std::size_t i = 0; i < uses.size();) {
        std::size_t j = i;
        while (j < uses.size() && uses[j].lo == uses[i].lo && uses[j].hi == uses[i].hi) ++j;
        const std::size_t n = j - i;
        if (n == 1) ++r.boundaryEdges;
        if (n >= 3) ++r.nonManifoldEdges;
        if (n == 2 && uses[i].dir == uses[i + 1].dir) consistent = false;
        i = j;
    }
    const bool any = !mesh.triangles.empty();
    r.manifold = any && r.nonManifoldEdges == 0 && consistent;
    r.closed = any && r.boundaryEdges == 0 && r.nonManifoldEdges == 0;
    return r;
}

void transformMesh(TriangleMesh& mesh, const Mat3& linear, const Vec3& translation) {
    for (Vec3& v : mesh.vertices) v = linear * v + translation;
    if (linear.determinant() < 0)
        for (std::size_t f = 0; f < mesh.triangles.size(); ++f) turnTriangle(mesh, f);
}

OrientReport orientOutward(TriangleMesh& mesh) {
    OrientReport report;
    report.volumeBefore = meshSignedVolume(mesh);
    // Parts: union-find over the vertices of each triangle.
    std::vector<std::size_t> parent(mesh.vertices.size());
    for (std::size_t v = 0; v < parent.size(); ++v) parent[v] = v;
    auto root = [&](std::size_t v) {
        while (parent[v] != v) v = parent[v] = parent[parent[v]];
        return v;
    };
    for (const auto& t : mesh.triangles)
        for (int k = 1; k < 3; ++k) {
            const std::size_t a = root(static_cast<std::size_t>(t[0])), b = root(static_cast<std::size_t>(t[k]));
            if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
    // Per part (keyed by its root): bounds, then the signed volume about the bounds centre.
    std::vector<std::size_t> partOf(mesh.vertices.size(), SIZE_MAX);
    std::vector<Box3> bounds;
    std::vector<std::size_t> triPart(mesh.triangles.size());
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const std::size_t r = root(static_cast<std::size_t>(mesh.triangles[i][0]));
        if (partOf[r] == SIZE_MAX) {
            partOf[r] = bounds.size();
            bounds.emplace_back();
        }
        triPart[i] = partOf[r];
        for (int v : mesh.triangles[i]) bounds[triPart[i]].extend(mesh.vertices[static_cast<std::size_t>(v)]);
    }
    std::vector<Real> volume(bounds.size(), 0);
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const Vec3 c = bounds[triPart[i]].centre();
        const auto& t = mesh.triangles[i];
        const Vec3 a = mesh.vertices[static_cast<std::size_t>(t[0])] - c;
        const Vec3 b = mesh.vertices[static_cast<std::size_t>(t[1])] - c;
        const Vec3 d = mesh.vertices[static_cast<std::size_t>(t[2])] - c;
        volume[triPart[i]] += a.dot(b.cross(d)) / 6;
    }
    // A negative part inside the bounds of an outward one is a cavity (a hollow ball's inner
    // shell, wound inward on purpose): it stays as it is.
    report.parts = bounds.size();
    std::vector<unsigned char> turn(bounds.size(), 0);
    for (std::size_t p = 0; p < bounds.size(); ++p) {
        if (!(volume[p] < 0)) continue;
        bool cavity = false;
        for (std::size_t q = 0; q < bounds.size() && !cavity; ++q)
            cavity = q != p && volume[q] > 0 && (bounds[q].min.array() <= bounds[p].min.array()).all() &&
                     (bounds[p].max.array() <= bounds[q].max.array()).all();
        turn[p] = cavity ? 0 : 1;
        report.flippedParts += turn[p];
    }
    if (report.flippedParts > 0)
        for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
            if (turn[triPart[i]]) turnTriangle(mesh, i);
    return report;
}

std::vector<Vec3> vertexNormals(const TriangleMesh& mesh) { return vertexNormals(mesh.vertices, mesh.triangles); }

std::vector<Vec3> vertexNormals(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles) {
    std::vector<Vec3> normals(vertices.size(), Vec3::Zero());
    for (const auto& t : triangles) {
        const Vec3& a = vertices[static_cast<std::size_t>(t[0])];
        const Vec3& b = vertices[static_cast<std::size_t>(t[1])];
        const Vec3& c = vertices[static_cast<std::size_t>(t[2])];
        const Vec3 n = (b - a).cross(c - a);  // |n| = twice the area: area weighting
        for (int v : t) normals[static_cast<std::size_t>(v)] += n;
    }
    for (Vec3& n : normals) {
        const Real len = n.norm();
        if (len > 0) n /= len;
    }
    return normals;
}

void smoothTaubin(TriangleMesh& mesh, int iterations, Real lambda, Real mu) {
    const std::size_t n = mesh.vertices.size();
    std::vector<std::vector<int>> neighbours(n);
    for (const std::array<int, 3>& t : mesh.triangles)
        for (int e = 0; e < 3; ++e) {
            const int a = t[static_cast<std::size_t>(e)], b = t[static_cast<std::size_t>((e + 1) % 3)];
            neighbours[static_cast<std::size_t>(a)].push_back(b);
            neighbours[static_cast<std::size_t>(b)].push_back(a);
        }
    for (std::vector<int>& nb : neighbours) {
        std::sort(nb.begin(), nb.end());
        nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    }
    std::vector<Vec3> next(n);
    auto umbrella = [&](Real f) {
        for (std::size_t v = 0; v < n; ++v) {
            const std::vector<int>& nb = neighbours[v];
            if (nb.empty()) {
                next[v] = mesh.vertices[v];
                continue;
            }
            Vec3 mean = Vec3::Zero();
            for (const int q : nb) mean += mesh.vertices[static_cast<std::size_t>(q)];
            mean /= static_cast<Real>(nb.size());
            next[v] = mesh.vertices[v] + f * (mean - mesh.vertices[v]);
        }
        mesh.vertices.swap(next);
    };
    for (int k = 0; k < iterations; ++k) {
        umbrella(lambda);
        umbrella(mu);
    }
}

}  // namespace dgv
