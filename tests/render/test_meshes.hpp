#pragma once
// Small meshes built in the render tests themselves (no dependency on geom/primitives).

#include "render/renderer.hpp"

#include <cmath>

namespace dgv::test {

/// UV sphere, triangles CCW seen from outside.
inline DrawMesh uvSphere(const Vec3& centre, Real radius, int rings = 32, int segments = 64) {
    DrawMesh m;
    const Real pi = 3.14159265358979323846;
    for (int i = 0; i <= rings; ++i) {
        const Real theta = pi * i / rings;  // from +Y down
        for (int j = 0; j < segments; ++j) {
            const Real phi = 2 * pi * j / segments;
            m.positions.push_back(centre + radius * Vec3(std::sin(theta) * std::cos(phi), std::cos(theta),
                                                         -std::sin(theta) * std::sin(phi)));
        }
    }
    auto id = [&](int i, int j) { return i * segments + (j % segments); };
    for (int i = 0; i < rings; ++i) {
        for (int j = 0; j < segments; ++j) {
            const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            if (i != 0) m.triangles.push_back({a, b, d});
            if (i != rings - 1) m.triangles.push_back({d, b, c});
        }
    }
    return m;
}

/// Torus around the Y axis, major radius R, minor radius r.
inline DrawMesh torus(const Vec3& centre, Real R, Real r, int major = 96, int minor = 48) {
    DrawMesh m;
    const Real pi = 3.14159265358979323846;
    for (int i = 0; i < major; ++i) {
        const Real u = 2 * pi * i / major;
        for (int j = 0; j < minor; ++j) {
            const Real v = 2 * pi * j / minor;
            const Real rr = R + r * std::cos(v);
            m.positions.push_back(centre + Vec3(rr * std::cos(u), r * std::sin(v), -rr * std::sin(u)));
        }
    }
    auto id = [&](int i, int j) { return (i % major) * minor + (j % minor); };
    for (int i = 0; i < major; ++i) {
        for (int j = 0; j < minor; ++j) {
            const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            m.triangles.push_back({a, b, c});
            m.triangles.push_back({a, c, d});
        }
    }
    return m;
}

}  // namespace dgv::test
