#include "collide/curve_distance.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dgv {

Real segmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
    const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
    const Real a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
    Real s = 0, t = 0;
    if (a <= 0 && e <= 0) return r.norm();
    if (a <= 0) {
        t = std::clamp(f / e, Real(0), Real(1));
    } else {
        const Real c = d1.dot(r);
        if (e <= 0) {
            s = std::clamp(-c / a, Real(0), Real(1));
        } else {
            const Real b = d1.dot(d2), denom = a * e - b * b;
            s = denom > 0 ? std::clamp((b * f - c * e) / denom, Real(0), Real(1)) : 0;
            t = (b * s + f) / e;
            if (t < 0) {
                t = 0;
                s = std::clamp(-c / a, Real(0), Real(1));
            } else if (t > 1) {
                t = 1;
                s = std::clamp((b - c) / a, Real(0), Real(1));
            }
        }
    }
    return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

Real curveDistance(const ClosedCurve& a, const ClosedCurve& b) {
    DGV_CHECK(!a.empty() && !b.empty());
    const Index n = static_cast<Index>(a.size()), m = static_cast<Index>(b.size());
    return parallelReduce<Real>(
        n, std::numeric_limits<Real>::infinity(),
        [&](Real& best, Index i) {
            const Vec3& p0 = a[static_cast<std::size_t>(i)];
            const Vec3& p1 = a[static_cast<std::size_t>((i + 1) % n)];
            for (Index j = 0; j < m; ++j) {
                const Vec3& q0 = b[static_cast<std::size_t>(j)];
                const Vec3& q1 = b[static_cast<std::size_t>((j + 1) % m)];
                // Cheap lower bound: the gap between the two segments' boxes.
                const Vec3 gap = (p0.cwiseMin(p1) - q0.cwiseMax(q1)).cwiseMax(q0.cwiseMin(q1) - p0.cwiseMax(p1));
                if (gap.cwiseMax(0.0).squaredNorm() >= best * best) continue;
                best = std::min(best, segmentDistance(p0, p1, q0, q1));
            }
        },
        [](Real x, Real y) { return std::min(x, y); }, 64);
}

}  // namespace dgv
