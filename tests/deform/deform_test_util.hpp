#pragma once
// Helpers for the deform tests: a box of parameter space sampled at refinement m (the same
// physical shape at spacing h/m), and smooth maps to deform it with.

#include "geom/lattice.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdlib>
#include <functional>
#include <vector>

namespace dgv::test {

using MapFn = std::function<Vec3(const Vec3&)>;

inline bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

/// Lattice of (cells * m + 1) points per axis, spacing h0/m, origin `origin`: rest positions
/// are the parameter points themselves.
inline Lattice boxLattice(const Vec3i& cells, int m, Real h0, const Vec3& origin = Vec3::Zero()) {
    const Vec3i dims = cells * m + Vec3i::Ones();
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 1);
    return buildLattice(origin, h0 / Real(m), dims, mask);
}

inline Lattice sphereLattice(Real radius) {
    const int n = static_cast<int>(std::ceil(2 * radius)) + 3;
    const Vec3i dims(n, n, n);
    const Vec3 c = Vec3::Constant(Real(n - 1) / 2);
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if ((Vec3(i, j, k) - c).norm() <= radius) mask[static_cast<std::size_t>(i + n * (j + n * k))] = 1;
    return buildLattice(-c, 1, dims, mask);
}

/// Whether the point is at least `margin` (fraction of the extent) inside the box: a region
/// fixed in space at every refinement.
inline bool innerPoint(const Lattice& lat, Index p, Real margin) {
    const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
    for (int a = 0; a < 3; ++a) {
        const Real t = Real(u[a]) / Real(lat.dims[a] - 1);
        if (t < margin || t > 1 - margin) return false;
    }
    return true;
}

inline std::vector<Vec3> mapPoints(const std::vector<Vec3>& x, const MapFn& f) {
    std::vector<Vec3> y(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) y[i] = f(x[i]);
    return y;
}

/// Twist about the x axis by `rate` radians per world unit along x.
inline MapFn twistMap(Real rate, const Vec3& centre) {
    return [=](const Vec3& p) {
        const Vec3 q = p - centre;
        const Real t = rate * q.x(), c = std::cos(t), s = std::sin(t);
        return Vec3(centre + Vec3(q.x(), c * q.y() - s * q.z(), s * q.y() + c * q.z()));
    };
}

/// Bend in the x-y plane: the x axis becomes an arc of radius R about (centre.x, centre.y+R).
inline MapFn bendMap(Real R, const Vec3& centre) {
    return [=](const Vec3& p) {
        const Vec3 q = p - centre;
        const Real a = q.x() / R, r = R - q.y();
        return Vec3(centre + Vec3(r * std::sin(a), R - r * std::cos(a), q.z()));
    };
}

/// Smooth non-uniform stretch (volume-changing).
inline MapFn stretchMap(Real amp, const Vec3& centre, Real length) {
    return [=](const Vec3& p) {
        const Vec3 q = (p - centre) / length;
        return Vec3(p + length * amp *
                            Vec3(std::sin(q.x()) + 0.3 * q.y() * q.y(), 0.5 * q.x() * q.y() + 0.2 * q.z(),
                                 0.4 * std::sin(q.z() + q.x())));
    };
}

}  // namespace dgv::test
