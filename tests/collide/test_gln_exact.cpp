// The exact linking number: the closed-form pair kernel, its SIMD and scalar builds, the
// certified driver, against independent counts (Banchoff) on the classic links.

#include "collide/gln_exact.hpp"
#include "collide/gln_farfield.hpp"
#include "tests/collide/curves.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace dgv;
using test::ring;

namespace {

const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ();

GlnResult direct(const ClosedCurve& a, const ClosedCurve& b, GlnKernel k = GlnKernel::Auto) {
    GlnSettings s;
    s.farField = false;
    s.kernel = k;
    return linkingNumber(a, b, s);
}

Real referenceSum(const ClosedCurve& a, const ClosedCurve& b) {
    Real sum = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        for (std::size_t j = 0; j < b.size(); ++j)
            sum += segmentPairSolidAngle(a[i], a[(i + 1) % a.size()], b[j], b[(j + 1) % b.size()]);
    return sum / (4 * M_PI);
}

}  // namespace

TEST_CASE("gln exact: the pair kernel matches the reference formula pair by pair", "[collide]") {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<Real> d(-1, 1);
    for (int trial = 0; trial < 200; ++trial) {
        ClosedCurve a, b;
        for (int k = 0; k < 5; ++k) a.emplace_back(d(rng), d(rng), d(rng));
        for (int k = 0; k < 7; ++k) b.emplace_back(d(rng), d(rng), d(rng));
        const CurveSoA sa = toSoA(a), sb = toSoA(b);
        for (int i = 0; i < 5; ++i) {
            const GlnSum s = glnTile(sa, i, i + 1, sb, 2, 3, GlnKernel::Scalar);
            const Real ref = segmentPairSolidAngle(a[i], a[(i + 1) % 5], b[2], b[3]) / 2;
            REQUIRE(s.pairs == 1);
            REQUIRE(std::abs(s.halfAngle - ref) <= s.bound + 1e-14);
        }
    }
}

TEST_CASE("gln exact: AVX2 and scalar kernels give bit-identical sums", "[collide]") {
    if (!glnAvx2Available()) return;
    const ClosedCurve a = test::fourierCurve(1, 6, 301), b = test::fourierCurve(2, 6, 517, Vec3(0.3, 0, 0));
    const CurveSoA sa = toSoA(a), sb = toSoA(b);
    for (auto [i0, i1, j0, j1] :
         std::vector<std::array<Index, 4>>{{0, 301, 0, 517}, {3, 40, 5, 6}, {7, 8, 1, 514}, {100, 300, 200, 517}}) {
        const GlnSum s = glnTile(sa, i0, i1, sb, j0, j1, GlnKernel::Scalar);
        const GlnSum v = glnTile(sa, i0, i1, sb, j0, j1, GlnKernel::Avx2);
        CHECK(s.halfAngle == v.halfAngle);
        CHECK(s.bound == v.bound);
        CHECK(s.pairs == v.pairs);
    }
    const GlnResult rs = direct(a, b, GlnKernel::Scalar), rv = direct(a, b, GlnKernel::Avx2);
    CHECK(rs.raw == rv.raw);
    CHECK(rs.linking == rv.linking);
}

TEST_CASE("gln exact: Hopf link is +-1 by orientation, unlinked rings 0", "[collide]") {
    const ClosedCurve a = ring(Vec3::Zero(), X, Y, 1, 64);
    const ClosedCurve b = ring(Vec3(1, 0, 0), X, Z, 1, 48);
    ClosedCurve bRev(b.rbegin(), b.rend());
    const GlnResult r = direct(a, b), rr = direct(a, bRev);
    REQUIRE(r.status == GlnStatus::Certified);
    REQUIRE(rr.status == GlnStatus::Certified);
    CHECK(std::abs(r.linking) == 1);
    CHECK(rr.linking == -r.linking);
    CHECK(r.linking == test::banchoff(a, b, Vec3(0.3, 0.5, 0.81).normalized()));
    CHECK(std::abs(r.raw - r.linking) < 1e-12);
    CHECK(r.bound < 1e-9);
    CHECK(std::abs(r.raw - referenceSum(a, b)) < 1e-12);
    // Swapping the curves keeps lk (the Gauss integral is symmetric).
    CHECK(direct(b, a).linking == r.linking);

    // A small ring through A's disk twice: overlapping boxes, unlinked.
    const ClosedCurve small = ring(Vec3(0.3, 0, 0), X, Z, 0.2, 40);
    const GlnResult u = direct(a, small);
    CHECK(u.status == GlnStatus::Certified);
    CHECK(u.linking == 0);
    CHECK_FALSE(u.culled);
    // Far apart: the bounding boxes settle it.
    const GlnResult far = linkingNumber(a, ring(Vec3(5, 0, 0), X, Z, 1, 48));
    CHECK(far.culled);
    CHECK(far.linking == 0);
}

TEST_CASE("gln exact: the Whitehead link has lk 0 although linked", "[collide]") {
    const ClosedCurve w = test::whiteheadLoop(200), c = test::whiteheadClasp();
    const GlnResult r = direct(w, c);
    REQUIRE(r.status == GlnStatus::Certified);
    CHECK(r.linking == 0);
    CHECK(test::banchoff(w, c, Vec3(0.1, 0.2, 0.97).normalized()) == 0);
    // Each lobe alone links the clasp once: the two lobes' contributions cancel.
    CHECK(std::abs(r.raw) < 1e-10);
}

TEST_CASE("gln exact: (2,2k) torus links have lk = k", "[collide]") {
    for (int k : {1, 2, 3, 5, 8}) {
        const ClosedCurve a = test::torusCurve(2, 0.7, k, 0, 64 * k + 31),
                          b = test::torusCurve(2, 0.7, k, M_PI, 64 * k + 17);
        const GlnResult r = direct(a, b);
        INFO("k = " << k << ", raw " << r.raw);
        REQUIRE(r.status == GlnStatus::Certified);
        CHECK(std::abs(r.linking) == k);
        CHECK(r.linking == test::banchoff(a, b, Vec3(0.21, -0.33, 0.92).normalized()));
    }
}

TEST_CASE("gln exact: random tangled curves agree with Banchoff's crossing count", "[collide]") {
    for (unsigned seed = 1; seed <= 12; ++seed) {
        const ClosedCurve a = test::fourierCurve(seed, 5 + seed % 4, 120 + 13 * seed);
        const ClosedCurve b = test::fourierCurve(1000 + seed, 4 + seed % 3, 90 + 7 * seed, Vec3(0.2, -0.1, 0.1));
        const GlnResult r = direct(a, b);
        INFO("seed " << seed << ", raw " << r.raw << ", bound " << r.bound);
        REQUIRE(r.status == GlnStatus::Certified);
        CHECK(r.linking == test::banchoff(a, b, Vec3(0.37, 0.61, -0.7).normalized()));
        CHECK(r.linking == test::banchoff(a, b, Vec3(-0.8, 0.1, 0.59).normalized()));
        CHECK(std::abs(r.raw - referenceSum(a, b)) < 1e-9);
    }
}

TEST_CASE("gln exact: near misses 1e-9 apart are still decided", "[collide]") {
    const ClosedCurve a = ring(Vec3::Zero(), X, Y, 1, 256);
    for (Real gap : {1e-9, -1e-9, 1e-12, -1e-12}) {
        // B's vertex at angle π sits at x = centre − 1, near A's vertex (1, 0, 0).
        const ClosedCurve b = ring(Vec3(2 + gap, 0, 0), X, Z, 1, 256);
        const GlnResult r = direct(a, b);
        INFO("gap " << gap << ", raw " << r.raw << ", bound " << r.bound);
        REQUIRE(r.status == GlnStatus::Certified);
        CHECK(std::abs(r.linking) == (gap < 0 ? 1 : 0));
    }
    // Touching exactly: a shared vertex.
    const GlnResult t = direct(a, ring(Vec3(2, 0, 0), X, Z, 1, 256));
    CHECK(t.status == GlnStatus::Intersect);
    CHECK(t.intersections > 0);
    // Crossing segments in one plane.
    const ClosedCurve sq1 = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    const ClosedCurve sq2 = {{0, 0, 0}, {2, 0, 0}, {2, 0, 1}, {0, 0, 1}};
    CHECK(direct(sq1, sq2).status == GlnStatus::Intersect);
}

TEST_CASE("gln exact: huge and tiny coordinates", "[collide]") {
    const ClosedCurve a = ring(Vec3::Zero(), X, Y, 1, 64);
    const ClosedCurve b = ring(Vec3(1, 0, 0), X, Z, 1, 48);
    const long long lk = direct(a, b).linking;
    for (Real s : {1e8, 1e-7, 1e-150, 1e150}) {
        ClosedCurve sa = a, sb = b;
        for (Vec3& p : sa) p *= s;
        for (Vec3& p : sb) p *= s;
        const GlnResult r = direct(sa, sb);
        INFO("scale " << s);
        REQUIRE(r.status == GlnStatus::Certified);
        CHECK(r.linking == lk);
    }
    // Unit-size curves far from the origin (coordinates 1e8: differences still exact).
    ClosedCurve ta = a, tb = b;
    for (Vec3& p : ta) p += Vec3(1e8, -1e8, 1e8);
    for (Vec3& p : tb) p += Vec3(1e8, -1e8, 1e8);
    const GlnResult r = direct(ta, tb);
    REQUIRE(r.status == GlnStatus::Certified);
    CHECK(r.linking == lk);
}
