#include "geom/tube.hpp"

#include "base/check.hpp"

#include <Eigen/Geometry>

#include <cmath>

namespace dgv {

TriangleMesh makeTube(const std::vector<Vec3>& curve, Real radius, int sides) {
    DGV_CHECK_GE(curve.size(), std::size_t(3));
    DGV_CHECK_GE(sides, 3);
    DGV_CHECK(radius > 0);
    const int n = static_cast<int>(curve.size());
    auto at = [&](int i) -> const Vec3& { return curve[static_cast<std::size_t>(((i % n) + n) % n)]; };
    // Tangents: central differences, falling back to any neighbour for repeated vertices.
    std::vector<Vec3> tangent(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        Vec3 t = at(i + 1) - at(i - 1);
        for (int k = 2; t.squaredNorm() == 0 && k < n; ++k) t = at(i + k) - at(i - k);
        tangent[static_cast<std::size_t>(i)] = t.squaredNorm() > 0 ? t.normalized() : Vec3::UnitX();
    }
    // Rotation-minimising normals by projection, then the closing twist spread over the loop.
    std::vector<Vec3> normal(static_cast<std::size_t>(n + 1));
    const Vec3& t0 = tangent[0];
    Vec3 seed = std::abs(t0.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    normal[0] = (seed - seed.dot(t0) * t0).normalized();
    for (int i = 1; i <= n; ++i) {
        const Vec3& t = tangent[static_cast<std::size_t>(i % n)];
        Vec3 v = normal[static_cast<std::size_t>(i - 1)];
        v -= v.dot(t) * t;
        if (v.squaredNorm() < 1e-24) v = t.unitOrthogonal();
        normal[static_cast<std::size_t>(i)] = v.normalized();
    }
    const Vec3& nEnd = normal[static_cast<std::size_t>(n)];
    const Real twist = std::atan2(t0.dot(normal[0].cross(nEnd)), normal[0].dot(nEnd));

    TriangleMesh mesh;
    mesh.vertices.reserve(static_cast<std::size_t>(n) * sides);
    for (int i = 0; i < n; ++i) {
        const Vec3& t = tangent[static_cast<std::size_t>(i)];
        const Real undo = -twist * i / n;
        const Vec3 nv = Eigen::AngleAxis<Real>(undo, t) * normal[static_cast<std::size_t>(i)];
        const Vec3 bv = t.cross(nv);
        for (int s = 0; s < sides; ++s) {
            const Real a = 2 * M_PI * s / sides;
            mesh.vertices.push_back(at(i) + radius * (std::cos(a) * nv + std::sin(a) * bv));
        }
    }
    for (int i = 0; i < n; ++i) {
        const int i1 = (i + 1) % n;
        for (int s = 0; s < sides; ++s) {
            const int s1 = (s + 1) % sides;
            const int a = i * sides + s, b = i * sides + s1, c = i1 * sides + s1, d = i1 * sides + s;
            // (nv, bv, t) is right-handed: around the ring, then along the curve, turns outward.
            mesh.triangles.push_back({a, b, c});
            mesh.triangles.push_back({a, c, d});
        }
    }
    return mesh;
}

}  // namespace dgv
