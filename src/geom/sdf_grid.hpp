#pragma once
/// @file sdf_grid.hpp
/// @brief A dense grid of signed-distance samples (negative inside), e.g. a level set loaded from
/// a .vdb file (io/vdb_read.hpp), usable as a static collider.
///
/// Sample (i, j, k), 0 <= i < dims.x ..., sits at origin + spacing * (i, j, k) (world units);
/// values are stored i fastest: values[i + dims.x * (j + dims.y * k)].
/// Inside the box [origin, origin + spacing * (dims - 1)]: trilinear interpolation of the samples.
/// Outside it: distance(x) = distance(c) + |x - c|, c = x clamped to the box (the samples on the
/// box boundary lie outside the object for a grid loaded from a level set, so this grows like a
/// distance away from the box); gradient() is the exact gradient of that rule.
/// A narrow-band level set holds true distances only within `narrowBand` of the surface; farther
/// samples are +-narrowBand (clamped), where the gradient is zero.

#include "base/types.hpp"

#include <algorithm>
#include <cmath>

#include <vector>

namespace dgv {

/// SdfGrid's rule (above) on any source of samples: `at(i, j, k)` returns sample (i, j, k) of a
/// grid of `dims` samples at origin + spacing · (i, j, k). Shared with collide/sampled_distance,
/// whose samples are computed on demand.
template <class At>
Real sdfDistance(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at);
template <class At>
Vec3 sdfGradient(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at);
/// Both, from one lookup of the eight samples.
template <class At>
Real sdfDistance(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at, Vec3& gradient);

struct SdfGrid {
    Vec3 origin = Vec3::Zero();  ///< world position of sample (0, 0, 0)
    Real spacing = 1;            ///< world units between samples (> 0)
    Vec3i dims = Vec3i::Zero();  ///< samples per axis (each >= 2)
    Real narrowBand = 0;         ///< |distance| is exact below this (0: everywhere)
    std::vector<float> values;   ///< dims.prod() signed distances, world units

    bool empty() const { return values.empty(); }
    Index linearIndex(int i, int j, int k) const { return i + Index(dims.x()) * (j + Index(dims.y()) * k); }
    float at(int i, int j, int k) const { return values[static_cast<std::size_t>(linearIndex(i, j, k))]; }
    /// World box spanned by the samples.
    Box3 bounds() const;
    /// Signed distance at x (rule above). The grid must not be empty.
    Real distance(const Vec3& x) const;
    /// Gradient of distance() at x (not normalised; about unit length in the narrow band).
    Vec3 gradient(const Vec3& x) const;
};

namespace sdf_detail {

/// Cell index (lower sample) and fraction along one axis for a coordinate t in [0, n-1].
inline void locate(Real t, int n, int& i, Real& f) {
    i = std::min(std::max(static_cast<int>(std::floor(t)), 0), n - 2);
    f = t - Real(i);
}

/// The eight samples around x, clamped into the samples' box (`c`): the cell's lower sample's
/// fractions along each axis and the samples themselves, v[dx][dy][dz] = at(i + dx, ...).
struct Corners {
    Vec3 c;
    Real fx, fy, fz;
    Real v[2][2][2];
};
template <class At>
Corners gather(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at) {
    const Vec3 hi = origin + spacing * (dims.cast<Real>() - Vec3::Ones());
    Corners q;
    q.c = x.cwiseMax(origin).cwiseMin(hi);
    const Vec3 t = (q.c - origin) / spacing;
    int i, j, k;
    locate(t.x(), dims.x(), i, q.fx);
    locate(t.y(), dims.y(), j, q.fy);
    locate(t.z(), dims.z(), k, q.fz);
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) q.v[dx][dy][dz] = at(i + dx, j + dy, k + dz);
    return q;
}

/// SdfGrid::distance's value from the eight samples.
inline Real interpolate(const Corners& q, const Vec3& x) {
    auto lerp = [](Real a, Real bb, Real f) { return a + (bb - a) * f; };
    const auto& v = q.v;
    const Real c00 = lerp(v[0][0][0], v[1][0][0], q.fx), c10 = lerp(v[0][1][0], v[1][1][0], q.fx);
    const Real c01 = lerp(v[0][0][1], v[1][0][1], q.fx), c11 = lerp(v[0][1][1], v[1][1][1], q.fx);
    const Real inside = lerp(lerp(c00, c10, q.fy), lerp(c01, c11, q.fy), q.fz);
    return inside + (x - q.c).norm();
}

/// SdfGrid::gradient's value from the eight samples.
inline Vec3 slope(const Corners& q, Real spacing, const Vec3& x) {
    const Real wx[2] = {1 - q.fx, q.fx}, wy[2] = {1 - q.fy, q.fy}, wz[2] = {1 - q.fz, q.fz};
    Vec3 g = Vec3::Zero();
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                const Real s = q.v[dx][dy][dz];
                g.x() += s * (dx ? 1 : -1) * wy[dy] * wz[dz];
                g.y() += s * wx[dx] * (dy ? 1 : -1) * wz[dz];
                g.z() += s * wx[dx] * wy[dy] * (dz ? 1 : -1);
            }
    g /= spacing;
    const Vec3 out = x - q.c;
    const Real n = out.norm();
    if (n > 0) {
        for (int a = 0; a < 3; ++a)
            if (x[a] != q.c[a]) g[a] = out[a] / n;
    }
    return g;
}

}  // namespace sdf_detail

template <class At>
Real sdfDistance(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at) {
    return sdf_detail::interpolate(sdf_detail::gather(origin, spacing, dims, x, at), x);
}

template <class At>
Vec3 sdfGradient(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at) {
    return sdf_detail::slope(sdf_detail::gather(origin, spacing, dims, x, at), spacing, x);
}

template <class At>
Real sdfDistance(const Vec3& origin, Real spacing, const Vec3i& dims, const Vec3& x, const At& at, Vec3& gradient) {
    const sdf_detail::Corners q = sdf_detail::gather(origin, spacing, dims, x, at);
    gradient = sdf_detail::slope(q, spacing, x);
    return sdf_detail::interpolate(q, x);
}

}  // namespace dgv
