#pragma once
// Test curves for the linking-number tests, and an independent linking number: Banchoff's
// signed crossing count in one generic projection (lk = Σ over crossings where curve 1 passes
// over curve 2, viewed from +u, of sign(u·(t1 × t2))).

#include "collide/gln_exact.hpp"

#include <cmath>
#include <random>

namespace dgv::test {

/// centre + radius (cos φ u + sin φ v), n vertices, exact at quarter turns when 4 | n.
inline ClosedCurve ring(const Vec3& centre, const Vec3& u, const Vec3& v, Real radius, int n) {
    ClosedCurve c;
    for (int k = 0; k < n; ++k) {
        Real cs, sn;
        if ((4 * k) % n == 0) {
            const int q = 4 * k / n;
            cs = q == 0 ? 1 : q == 2 ? -1 : 0;
            sn = q == 1 ? 1 : q == 3 ? -1 : 0;
        } else {
            const Real phi = 2 * M_PI * k / n;
            cs = std::cos(phi);
            sn = std::sin(phi);
        }
        c.push_back(centre + radius * (cs * u + sn * v));
    }
    return c;
}

/// Component of the (2, 2k) torus link: (1, k) curve on a torus, shifted by `phase` around the tube.
inline ClosedCurve torusCurve(Real R, Real r, int k, Real phase, int n) {
    ClosedCurve c;
    for (int i = 0; i < n; ++i) {
        const Real t = 2 * M_PI * i / n, p = k * t + phase;
        c.emplace_back((R + r * std::cos(p)) * std::cos(t), (R + r * std::cos(p)) * std::sin(t), r * std::sin(p));
    }
    return c;
}

/// A random smooth closed curve: Σ_{m=1}^{modes} (a_m cos mt + b_m sin mt) / m, plus `offset`.
inline ClosedCurve fourierCurve(unsigned seed, int modes, int n, const Vec3& offset = Vec3::Zero()) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<Real> g(0, 1);
    std::vector<Vec3> a(static_cast<std::size_t>(modes)), b(static_cast<std::size_t>(modes));
    for (int m = 0; m < modes; ++m) {
        a[static_cast<std::size_t>(m)] = Vec3(g(rng), g(rng), g(rng)) / (m + 1);
        b[static_cast<std::size_t>(m)] = Vec3(g(rng), g(rng), g(rng)) / (m + 1);
    }
    ClosedCurve c;
    for (int i = 0; i < n; ++i) {
        const Real t = 2 * M_PI * i / n;
        Vec3 p = offset;
        for (int m = 0; m < modes; ++m)
            p += a[static_cast<std::size_t>(m)] * std::cos((m + 1) * t) +
                 b[static_cast<std::size_t>(m)] * std::sin((m + 1) * t);
        c.push_back(p);
    }
    return c;
}

/// Whitehead link: a figure-eight loop with one crossing (2 sin t, sin 2t, 0.3 cos t) ...
inline ClosedCurve whiteheadLoop(int n) {
    ClosedCurve c;
    for (int i = 0; i < n; ++i) {
        const Real t = 2 * M_PI * i / n;
        c.emplace_back(2 * std::sin(t), std::sin(2 * t), 0.3 * std::cos(t));
    }
    return c;
}
/// ... and a loop rising through both lobes of it (in opposite senses relative to the lobes, so
/// lk = 0) and returning outside it: linked, with linking number 0.
inline ClosedCurve whiteheadClasp() {
    return {{1.2, 0, -1}, {1.2, 0, 1.5}, {-3, 0, 1.5}, {-3, 0, -1}, {-1.2, 0, -1},
            {-1.2, 0, 1}, {-1.2, 2, 1},  {3, 2, 1},    {3, 2, -1}};
}

/// Banchoff's count along view direction `u` (unit, generic).
inline long long banchoff(const ClosedCurve& a, const ClosedCurve& b, const Vec3& u) {
    const Vec3 e1 = u.unitOrthogonal(), e2 = u.cross(e1);
    long long lk = 0;
    const std::size_t n = a.size(), m = b.size();
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3 &p0 = a[i], &p1 = a[(i + 1) % n];
        for (std::size_t j = 0; j < m; ++j) {
            const Vec3 &q0 = b[j], &q1 = b[(j + 1) % m];
            // 2-D intersection of the projected segments: p0 + s dp = q0 + t dq.
            const Vec3 dp = p1 - p0, dq = q1 - q0, r = q0 - p0;
            const Real ax = dp.dot(e1), ay = dp.dot(e2), bx = -dq.dot(e1), by = -dq.dot(e2);
            const Real rx = r.dot(e1), ry = r.dot(e2);
            const Real det = ax * by - ay * bx;
            if (det == 0) continue;
            const Real s = (rx * by - ry * bx) / det, t = (ax * ry - ay * rx) / det;
            if (s < 0 || s >= 1 || t < 0 || t >= 1) continue;
            const Vec3 x1 = p0 + s * dp, x2 = q0 + t * dq;
            if ((x1 - x2).dot(u) <= 0) continue;  // curve 1 must be over curve 2
            lk += u.dot(dp.cross(dq)) > 0 ? 1 : -1;
        }
    }
    return lk;
}

}  // namespace dgv::test
