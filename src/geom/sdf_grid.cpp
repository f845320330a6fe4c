#include "geom/sdf_grid.hpp"

#include "base/check.hpp"

#include <algorithm>
#include <cmath>

namespace dgv {

namespace {

/// Cell index (lower sample) and fraction along one axis for a coordinate t in [0, n-1].
inline void locate(Real t, int n, int& i, Real& f) {
    i = std::min(std::max(static_cast<int>(std::floor(t)), 0), n - 2);
    f = t - Real(i);
}

}  // namespace

Box3 SdfGrid::bounds() const {
    Box3 b;
    b.min = origin;
    b.max = origin + spacing * (dims.cast<Real>() - Vec3::Ones());
    return b;
}

Real SdfGrid::distance(const Vec3& x) const {
    DGV_CHECK(!values.empty() && (dims.array() >= 2).all());
    const Box3 b = bounds();
    const Vec3 c = x.cwiseMax(b.min).cwiseMin(b.max);
    const Vec3 t = (c - origin) / spacing;
    int i, j, k;
    Real fx, fy, fz;
    locate(t.x(), dims.x(), i, fx);
    locate(t.y(), dims.y(), j, fy);
    locate(t.z(), dims.z(), k, fz);
    auto lerp = [](Real a, Real bb, Real f) { return a + (bb - a) * f; };
    const Real c00 = lerp(at(i, j, k), at(i + 1, j, k), fx), c10 = lerp(at(i, j + 1, k), at(i + 1, j + 1, k), fx);
    const Real c01 = lerp(at(i, j, k + 1), at(i + 1, j, k + 1), fx),
               c11 = lerp(at(i, j + 1, k + 1), at(i + 1, j + 1, k + 1), fx);
    const Real inside = lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
    return inside + (x - c).norm();
}

Vec3 SdfGrid::gradient(const Vec3& x) const {
    DGV_CHECK(!values.empty() && (dims.array() >= 2).all());
    const Box3 b = bounds();
    const Vec3 c = x.cwiseMax(b.min).cwiseMin(b.max);
    const Vec3 t = (c - origin) / spacing;
    int i, j, k;
    Real fx, fy, fz;
    locate(t.x(), dims.x(), i, fx);
    locate(t.y(), dims.y(), j, fy);
    locate(t.z(), dims.z(), k, fz);
    Real v[2][2][2];
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) v[dx][dy][dz] = at(i + dx, j + dy, k + dz);
    const Real wx[2] = {1 - fx, fx}, wy[2] = {1 - fy, fy}, wz[2] = {1 - fz, fz};
    Vec3 g = Vec3::Zero();
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                const Real s = v[dx][dy][dz];
                g.x() += s * (dx ? 1 : -1) * wy[dy] * wz[dz];
                g.y() += s * wx[dx] * (dy ? 1 : -1) * wz[dz];
                g.z() += s * wx[dx] * wy[dy] * (dz ? 1 : -1);
            }
    g /= spacing;
    const Vec3 out = x - c;
    const Real n = out.norm();
    if (n > 0) {
        for (int a = 0; a < 3; ++a)
            if (x[a] != c[a]) g[a] = out[a] / n;
    }
    return g;
}

}  // namespace dgv
