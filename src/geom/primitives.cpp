#include "geom/primitives.hpp"

#include "base/errors.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <cmath>
#include <map>
#include <sstream>
#include <utility>
#include <vector>

namespace dgv {

namespace {

constexpr Real kPi = 3.14159265358979323846;

void requirePositive(Real value, const char* name) {
    if (!(std::isfinite(value) && value > 0)) {
        std::ostringstream os;
        os << "must be a positive finite number, got " << value;
        throw InputError("", name, os.str());
    }
}

void requireAtLeast(int value, int least, const char* name) {
    if (value < least)
        throw InputError("", name, "must be at least " + std::to_string(least) + ", got " + std::to_string(value));
}

/// Surface of revolution around Y. `profile` is (radius, y) from the top pole (radius 0) to the
/// bottom pole (radius 0); interior profile points become rings of `segments` shared vertices.
/// Vertex at angle phi: (rho cos phi, y, -rho sin phi), which makes (ring i, ring i+1, next
/// segment) counter-clockwise seen from outside.
TriangleMesh revolve(const std::vector<std::pair<Real, Real>>& profile, int segments) {
    TriangleMesh m;
    const int rings = static_cast<int>(profile.size()) - 2;  // interior rings
    m.vertices.reserve(static_cast<std::size_t>(rings * segments + 2));
    m.vertices.emplace_back(0, profile.front().second, 0);
    for (int i = 1; i <= rings; ++i) {
        const auto [rho, y] = profile[static_cast<std::size_t>(i)];
        for (int j = 0; j < segments; ++j) {
            const Real phi = 2 * kPi * j / segments;
            m.vertices.emplace_back(rho * std::cos(phi), y, -rho * std::sin(phi));
        }
    }
    m.vertices.emplace_back(0, profile.back().second, 0);
    const int north = 0, south = rings * segments + 1;
    auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };

    for (int j = 0; j < segments; ++j) m.triangles.push_back({north, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i < rings; ++i) {
        for (int j = 0; j < segments; ++j) {
            const int a = ring(i, j), b = ring(i + 1, j), c = ring(i + 1, j + 1), d = ring(i, j + 1);
            m.triangles.push_back({a, b, c});
            m.triangles.push_back({a, c, d});
        }
    }
    for (int j = 0; j < segments; ++j) m.triangles.push_back({ring(rings, j), south, ring(rings, j + 1)});
    return m;
}

}  // namespace

TriangleMesh makeSphere(Real radius, int segments, int rings) {
    requirePositive(radius, "radius");
    requireAtLeast(segments, 3, "segments");
    requireAtLeast(rings, 2, "rings");
    std::vector<std::pair<Real, Real>> profile;
    for (int i = 0; i <= rings; ++i) {
        const Real theta = kPi * i / rings;
        profile.emplace_back(i == 0 || i == rings ? 0 : radius * std::sin(theta), radius * std::cos(theta));
    }
    return revolve(profile, segments);
}

TriangleMesh makeCapsule(Real radius, Real height, int segments, int rings) {
    requirePositive(radius, "radius");
    if (!(std::isfinite(height) && height >= 0)) throw InputError("", "height", "must be a finite number >= 0");
    requireAtLeast(segments, 3, "segments");
    requireAtLeast(rings, 1, "rings");
    // `rings` latitude bands per hemisphere; the cylinder is one band between the equators.
    std::vector<std::pair<Real, Real>> profile;
    const Real half = height / 2;
    for (int i = 0; i <= rings; ++i) {
        const Real theta = 0.5 * kPi * i / rings;
        profile.emplace_back(i == 0 ? 0 : radius * std::sin(theta), half + radius * std::cos(theta));
    }
    for (int i = (height > 0 ? 0 : 1); i <= rings; ++i) {
        const Real theta = 0.5 * kPi + 0.5 * kPi * i / rings;
        profile.emplace_back(i == rings ? 0 : radius * std::sin(theta), -half + radius * std::cos(theta));
    }
    return revolve(profile, segments);
}

TriangleMesh makeBox(const Vec3& size, int divisions) {
    requirePositive(size.x(), "size");
    requirePositive(size.y(), "size");
    requirePositive(size.z(), "size");
    requireAtLeast(divisions, 1, "divisions");
    const int d = divisions;
    TriangleMesh m;
    std::map<std::array<int, 3>, int> vertexOf;  // integer grid coordinate -> vertex id
    auto vertex = [&](const std::array<int, 3>& g) {
        auto it = vertexOf.find(g);
        if (it != vertexOf.end()) return it->second;
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = size[a] * (Real(g[a]) / d - 0.5);
        const int id = static_cast<int>(m.vertices.size());
        m.vertices.push_back(p);
        vertexOf.emplace(g, id);
        return id;
    };
    for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int side = 0; side <= d; side += d) {
            for (int u = 0; u < d; ++u) {
                for (int v = 0; v < d; ++v) {
                    auto corner = [&](int du, int dv) {
                        std::array<int, 3> g{};
                        g[a] = side;
                        g[b] = u + du;
                        g[c] = v + dv;
                        return vertex(g);
                    };
                    // Counter-clockwise seen from +a, since e_b x e_c = e_a.
                    const int p0 = corner(0, 0), p1 = corner(1, 0), p2 = corner(1, 1), p3 = corner(0, 1);
                    if (side == d) {
                        m.triangles.push_back({p0, p1, p2});
                        m.triangles.push_back({p0, p2, p3});
                    } else {
                        m.triangles.push_back({p0, p2, p1});
                        m.triangles.push_back({p0, p3, p2});
                    }
                }
            }
        }
    }
    return m;
}

TriangleMesh makeTorus(Real majorRadius, Real minorRadius, int majorSegments, int minorSegments) {
    requirePositive(majorRadius, "major_radius");
    requirePositive(minorRadius, "minor_radius");
    if (!(minorRadius < majorRadius)) throw InputError("", "minor_radius", "must be smaller than major_radius");
    requireAtLeast(majorSegments, 3, "major_segments");
    requireAtLeast(minorSegments, 3, "minor_segments");
    TriangleMesh m;
    m.vertices.reserve(static_cast<std::size_t>(majorSegments * minorSegments));
    for (int j = 0; j < majorSegments; ++j) {
        const Real phi = 2 * kPi * j / majorSegments;
        const Vec3 radial(std::cos(phi), 0, -std::sin(phi));
        for (int k = 0; k < minorSegments; ++k) {
            const Real theta = 2 * kPi * k / minorSegments;
            m.vertices.push_back((majorRadius + minorRadius * std::cos(theta)) * radial +
                                 Vec3(0, minorRadius * std::sin(theta), 0));
        }
    }
    auto id = [&](int j, int k) { return (j % majorSegments) * minorSegments + (k % minorSegments); };
    for (int j = 0; j < majorSegments; ++j) {
        for (int k = 0; k < minorSegments; ++k) {
            const int a = id(j, k), b = id(j + 1, k), c = id(j + 1, k + 1), d = id(j, k + 1);
            m.triangles.push_back({a, b, c});
            m.triangles.push_back({a, c, d});
        }
    }
    return m;
}

}  // namespace dgv
