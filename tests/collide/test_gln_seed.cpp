// The seed's numerical GLN (collide/gln_seed.hpp): faithful to the notes' listing, and its
// behaviour against the exact linking number.

#include "collide/gln_exact.hpp"
#include "collide/gln_farfield.hpp"
#include "collide/gln_seed.hpp"
#include "tests/collide/curves.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>

using namespace dgv;
using test::ring;

namespace {

/// The notes' listing `gln_segmented_compute`, transcribed line by line (Maya's curve replaced by
/// polylinePointAt on the knot domain [0, n]).
Real listing(const ClosedCurve& curve1, const ClosedCurve& curve2, double tolerance) {
    double plsampling = 50, p2sampling = 50;
    double gln = 0;
    double plstart = 0, plend = static_cast<double>(curve1.size());
    double p2start = 0, p2end = static_cast<double>(curve2.size());
    double dp1 = tolerance * (plend - plstart) / plsampling;
    double dp2 = tolerance * (p2end - p2start) / p2sampling;
    Vec3 vlminus = polylinePointAt(curve1, plstart), vlplus;
    Vec3 v2minus = polylinePointAt(curve2, p2start), v2plus;
    for (double pl = plstart + dp1; pl <= plend; pl += dp1) {
        vlplus = polylinePointAt(curve1, pl);
        const Vec3 dv11pm = vlplus - vlminus;
        for (double p2 = p2start + dp2; p2 <= p2end; p2 += dp2) {
            v2plus = polylinePointAt(curve2, p2);
            const Vec3 dv22pm = v2plus - v2minus;
            const Vec3 dv12mm = vlminus - v2minus;
            double c = dv22pm.dot(dv22pm);
            double ds = 0.02 * tolerance;
            double accum = 0;
            for (double s = 0; s <= 1; s += ds) {
                Vec3 va = dv12mm + s * dv11pm;
                double a = va.dot(va);
                double b = -2.0 * va.dot(dv22pm);
                accum += ((2 * c + b) / std::sqrt(a + b + c) - b / std::sqrt(a)) * 2 / (4 * a * c - b * b);
            }
            accum *= ds;
            gln += dv12mm.dot(dv11pm.cross(dv22pm)) * accum;
            v2minus = v2plus;
        }
        vlminus = vlplus;
    }
    gln /= (4.0 * 3.14159265);
    return gln;
}

}  // namespace

TEST_CASE("gln seed: agrees with the notes' listing where the listing closes its curves", "[collide][gln]") {
    // 50 and 25 vertices at tolerance 1 and 2: dp = 1 exactly, so the listing's accumulated
    // parameters are exact integers and it reaches the end of the domain (closing the curves).
    const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ();
    for (const Real tol : {1.0, 2.0}) {
        const int n = static_cast<int>(50 / tol);
        for (Real c : {0.5, 1.0, 1.7, 2.6}) {
            const ClosedCurve a = ring(Vec3::Zero(), X, Y, 1, n), b = ring(Vec3(c, 0.1, 0), X, Z, 1, n);
            const SeedGln s = glnSeed(a, b, tol);
            const Real ref = listing(a, b, tol);
            INFO("tol " << tol << " c " << c << " seed " << s.gln << " listing " << ref);
            CHECK(s.chordsA == n);
            // Same terms, summed in another order: a few ulps of the sum of |terms| (< 10 here).
            CHECK(std::abs(s.gln - ref) < 1e-13);
        }
    }
}

TEST_CASE("gln seed: converges to the exact linking number as the tolerance shrinks", "[collide][gln]") {
    const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ();
    const ClosedCurve a = ring(Vec3::Zero(), X, Y, 1, 200), b = ring(Vec3(1, 0, 0), X, Z, 1, 200);
    const long long lk = linkingNumber(a, b).linking;
    REQUIRE(std::abs(lk) == 1);
    Real prev = HUGE_VAL;
    for (const Real tol : {5.0, 2.0, 1.0, 0.5}) {
        const Real err = std::abs(glnSeed(a, b, tol).gln - static_cast<Real>(lk));
        if (std::getenv("DGV_TEST_VERBOSE")) std::printf("seed Hopf: tolerance %g error %.3g\n", tol, err);
        INFO("tol " << tol << " error " << err);
        CHECK(err < prev);
        prev = err;
    }
    // Unlinked and far apart: the integrand is smooth, the value small.
    const ClosedCurve far = ring(Vec3(4, 0, 0), X, Z, 1, 200);
    CHECK(std::abs(glnSeed(a, far, 1).gln) < 0.01);
}
