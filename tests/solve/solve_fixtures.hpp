#pragma once
// Lattices and smooth maps shared by the solve tests.
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"
#include "solve/holonomy.hpp"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <vector>

namespace dgv::test {

inline bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

inline Lattice boxLattice(const Vec3i& dims, Real spacing = 1) {
    return buildLattice(Vec3::Zero(), spacing, dims,
                        std::vector<unsigned char>(static_cast<std::size_t>(dims.prod()), 1));
}

/// Ball of the given radius (in lattice steps) centred in a (2r+3)^3 grid.
inline Lattice sphereLattice(Real radius, Real spacing = 1) {
    const int n = int(std::ceil(2 * radius)) + 3;
    const Vec3i dims(n, n, n);
    const Vec3 c = Vec3::Constant(Real(n - 1) / 2);
    std::vector<unsigned char> m(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if ((Vec3(i, j, k) - c).norm() <= radius) m[static_cast<std::size_t>(i + n * (j + n * k))] = 1;
    return buildLattice(Vec3::Zero(), spacing, dims, m);
}

using MapFn = std::function<Vec3(const Vec3&)>;

/// Smooth deformations of the unit-ish box [0,1]^3 (material coordinates s in world units).
inline MapFn twistMap(Real radiansPerUnit) {
    return [=](const Vec3& s) {
        const Real t = radiansPerUnit * s.z(), c = std::cos(t), n = std::sin(t);
        const Real dx = s.x() - 0.5, dy = s.y() - 0.5;
        return Vec3(0.5 + c * dx - n * dy, 0.5 + n * dx + c * dy, s.z());
    };
}
inline MapFn bendMap(Real curvature) {
    // Bend about the y axis: the line x = 0.5 becomes an arc of radius 1/curvature.
    return [=](const Vec3& s) {
        const Real r = 1 / curvature + (s.x() - 0.5), t = curvature * (s.z() - 0.5);
        return Vec3(r * std::cos(t) - 1 / curvature + 0.5, s.y(), r * std::sin(t) + 0.5);
    };
}
inline MapFn stretchMap(Real amount) {
    // Non-uniform stretch: x' = x + a x^2, y' = y (1 + a z), z' = z + a sin(x).
    return [=](const Vec3& s) {
        return Vec3(s.x() + amount * s.x() * s.x(), s.y() * (1 + amount * s.z()), s.z() + amount * std::sin(2 * s.x()));
    };
}

/// Positions of a map applied to the rest positions of a lattice.
inline std::vector<Vec3> mapped(const Lattice& lat, const MapFn& phi) {
    std::vector<Vec3> x(static_cast<std::size_t>(lat.size()));
    for (Index p = 0; p < lat.size(); ++p) x[static_cast<std::size_t>(p)] = phi(lat.restPosition(p));
    return x;
}

inline std::vector<Mat3> framesOf(const GeometricState& st) {
    std::vector<Mat3> f(static_cast<std::size_t>(st.size()));
    for (Index p = 0; p < st.size(); ++p)
        for (int a = 0; a < 3; ++a)
            f[static_cast<std::size_t>(p)].col(a) =
                st.tangent[static_cast<std::size_t>(a)][static_cast<std::size_t>(p)];
    return f;
}

}  // namespace dgv::test
