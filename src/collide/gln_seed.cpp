#include "collide/gln_seed.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace dgv {
namespace {

/// The listing's sample points of one curve: γ(start), γ(start + dp), ..., closed at the end.
std::vector<Vec3> samplePoints(const ClosedCurve& c, Real tolerance) {
    const Real start = 0, end = static_cast<Real>(c.size());
    const Real dp = tolerance * (end - start) / 50;
    std::vector<Vec3> pts{polylinePointAt(c, start)};
    Real last = start;
    for (Index k = 1;; ++k) {
        const Real p = start + static_cast<Real>(k) * dp;
        if (p > end * (1 + 1e-12)) break;
        last = std::min(p, end);
        pts.push_back(polylinePointAt(c, last));
    }
    if (last < end) pts.push_back(polylinePointAt(c, end));
    return pts;
}

}  // namespace

Vec3 polylinePointAt(const ClosedCurve& c, Real p) {
    const Index n = static_cast<Index>(c.size());
    Index k = static_cast<Index>(std::floor(p));
    k = std::clamp<Index>(k, 0, n - 1);
    const Real f = p - static_cast<Real>(k);
    const Vec3& v0 = c[static_cast<std::size_t>(k)];
    const Vec3& v1 = c[static_cast<std::size_t>((k + 1) % n)];
    return v0 + f * (v1 - v0);
}

SeedGln glnSeed(const ClosedCurve& a, const ClosedCurve& b, Real tolerance) {
    DGV_CHECK_GE(a.size(), std::size_t(3));
    DGV_CHECK_GE(b.size(), std::size_t(3));
    DGV_CHECK(tolerance > 0);
    const std::vector<Vec3> p1 = samplePoints(a, tolerance), p2 = samplePoints(b, tolerance);
    SeedGln out;
    out.chordsA = static_cast<Index>(p1.size()) - 1;
    out.chordsB = static_cast<Index>(p2.size()) - 1;
    const double ds = 0.02 * tolerance;
    for (double s = 0; s <= 1; s += ds) ++out.samples;
    // Outer loop over the chords of curve 1 (parallel, deterministic sum), inner over curve 2.
    const Real sum = parallelReduce<Real>(
        out.chordsA, 0.0,
        [&](Real& acc, Index k) {
            const Vec3 v1minus = p1[static_cast<std::size_t>(k)];
            const Vec3 dv11pm = p1[static_cast<std::size_t>(k + 1)] - v1minus;
            for (std::size_t l = 0; l + 1 < p2.size(); ++l) {
                const Vec3 dv22pm = p2[l + 1] - p2[l];
                const Vec3 dv12mm = v1minus - p2[l];
                const double c = dv22pm.dot(dv22pm);
                double accum = 0;
                for (double s = 0; s <= 1; s += ds) {  // the listing's loop, rounding and all
                    const Vec3 va = dv12mm + s * dv11pm;
                    const double aa = va.dot(va);
                    const double bb = -2.0 * va.dot(dv22pm);
                    const double den = 4 * aa * c - bb * bb;
                    if (!(den > 0)) continue;  // γ1(s) on the line of the chord: no contribution
                    accum += ((2 * c + bb) / std::sqrt(aa + bb + c) - bb / std::sqrt(aa)) * 2 / den;
                }
                accum *= ds;
                acc += dv12mm.dot(dv11pm.cross(dv22pm)) * accum;
            }
        },
        [](Real x, Real y) { return x + y; }, 1);
    out.gln = sum / (4.0 * 3.14159265);
    return out;
}

}  // namespace dgv
