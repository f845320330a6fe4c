#pragma once
// Small meshes built in the render tests themselves (no dependency on geom/primitives).

#include "render/renderer.hpp"

#include <array>
#include <cmath>
#include <map>

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

namespace dgv::test {

/// Axis-aligned box centred at `centre` with edge lengths `size`, each face an n x n grid of
/// quads; vertices on edges and corners are shared between faces (so smoothing across the
/// edges would round them: the crease test). Triangles CCW from outside.
inline DrawMesh box(const Vec3& centre, const Vec3& size, int n = 4) {
    DrawMesh m;
    std::map<std::array<int, 3>, int> index;  // integer lattice coordinates 0..n per axis
    auto vertex = [&](std::array<int, 3> c) {
        auto [it, inserted] = index.emplace(c, static_cast<int>(m.positions.size()));
        if (inserted)
            m.positions.push_back(centre + Vec3((Real(c[0]) / n - 0.5) * size.x(), (Real(c[1]) / n - 0.5) * size.y(),
                                                (Real(c[2]) / n - 0.5) * size.z()));
        return it->second;
    };
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (int side = 0; side < 2; ++side) {
            for (int i = 0; i < n; ++i) {
                for (int j = 0; j < n; ++j) {
                    auto corner = [&](int di, int dj) {
                        std::array<int, 3> c{};
                        c[static_cast<std::size_t>(axis)] = side * n;
                        c[static_cast<std::size_t>(u)] = i + di;
                        c[static_cast<std::size_t>(v)] = j + dj;
                        return vertex(c);
                    };
                    const int a = corner(0, 0), b = corner(1, 0), c = corner(1, 1), d = corner(0, 1);
                    // (u, v, axis) is right-handed: CCW seen from +axis is a, b, c, d.
                    if (side == 1) {
                        m.triangles.push_back({a, b, c});
                        m.triangles.push_back({a, c, d});
                    } else {
                        m.triangles.push_back({a, c, b});
                        m.triangles.push_back({a, d, c});
                    }
                }
            }
        }
    }
    return m;
}

}  // namespace dgv::test
