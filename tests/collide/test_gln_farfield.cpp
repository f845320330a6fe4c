// The certified linking number with the far field (collide/gln_farfield.hpp, collide/bvh.hpp):
// the multipole of a node pair against the exact sum over its segment pairs, with its bound;
// the driver's integer against the direct sum and Banchoff's count on curves too big for it.

#include "collide/bvh.hpp"
#include "collide/gln_exact.hpp"
#include "collide/gln_farfield.hpp"
#include "tests/collide/curves.hpp"

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <cmath>

using namespace dgv;

namespace {

/// The exact Gauss integral of two open sub-chains (Σ Ω / 4π), by the direct kernel.
Real exactPair(const CurveSoA& a, const BvhNode& na, const CurveSoA& b, const BvhNode& nb) {
    return glnTileCareful(a, na.begin, na.end, b, nb.begin, nb.end).halfAngle / (2 * M_PI);
}

}  // namespace

TEST_CASE("gln farfield: node moments and radii describe their segments", "[collide][gln]") {
    const ClosedCurve c = test::fourierCurve(3, 6, 1000);
    const CurveSoA s = toSoA(c);
    const CurveBvh t = buildCurveBvh(s, 16);
    // The root's line element integrates to zero around a closed curve.
    CHECK(t.nodes[0].m0.norm() < 1e-12 * t.nodes[0].length);
    for (const BvhNode& n : t.nodes) {
        Vec3 m0 = Vec3::Zero();
        Real len = 0;
        for (Index i = n.begin; i <= n.end; ++i) {
            const Vec3 p(s.x[static_cast<std::size_t>(i)], s.y[static_cast<std::size_t>(i)],
                         s.z[static_cast<std::size_t>(i)]);
            // Every vertex of the node, so every point of its segments, lies within the radius.
            REQUIRE((p - n.centre).norm() <= n.radius * (1 + 1e-14));
            if (i < n.end) {
                m0 += Vec3(s.x[static_cast<std::size_t>(i + 1)], s.y[static_cast<std::size_t>(i + 1)],
                           s.z[static_cast<std::size_t>(i + 1)]) -
                      p;
                len += s.len[static_cast<std::size_t>(i)];
            }
        }
        REQUIRE((n.m0 - m0).norm() <= 1e-12 * len);
        REQUIRE(std::abs(n.length - len) <= 1e-12 * len);
    }
}

TEST_CASE("gln farfield: the multipole of a node pair is within its bound of the exact sum", "[collide][gln]") {
    const ClosedCurve c1 = test::fourierCurve(5, 5, 400), c2 = test::fourierCurve(6, 5, 300);
    int checked = 0;
    for (Real shift : {2.0, 3.0, 5.0, 10.0}) {
        ClosedCurve b = c2;
        for (Vec3& p : b) p += Vec3(shift, 0.3 * shift, -0.2 * shift);
        const CurveSoA sa = toSoA(c1), sb = toSoA(b);
        const CurveBvh ta = buildCurveBvh(sa, 8), tb = buildCurveBvh(sb, 8);
        // Every node pair at depth <= 3 that is well separated (q < 0.9).
        for (std::size_t ia = 0; ia < std::min<std::size_t>(15, ta.nodes.size()); ++ia) {
            for (std::size_t ib = 0; ib < std::min<std::size_t>(15, tb.nodes.size()); ++ib) {
                const BvhNode &A = ta.nodes[ia], &B = tb.nodes[ib];
                const Real q = (A.radius + B.radius) / (A.centre - B.centre).norm();
                if (!(q < 0.9)) continue;
                const FarValue f = farFieldPair(A, B);
                const Real exact = exactPair(sa, A, sb, B);
                INFO("shift " << shift << " q " << q << " far " << f.value << " exact " << exact << " bound "
                              << f.bound);
                REQUIRE(std::abs(f.value - exact) <= f.bound);
                ++checked;
            }
        }
    }
    CHECK(checked > 50);
}

TEST_CASE("gln farfield: the bound shrinks like q^3 and the multipole is second order", "[collide][gln]") {
    // One straight-ish chain against another at growing distance D: the error of a second-order
    // multipole falls like (size/D)^3 relative to the leading term, i.e. like D^-5 absolutely.
    const ClosedCurve c1 = test::fourierCurve(8, 3, 200), c2 = test::fourierCurve(9, 3, 200);
    const CurveSoA sa = toSoA(c1);
    const CurveBvh ta = buildCurveBvh(sa, 256);
    Real prevErr = 0, prevD = 0;
    for (Real D : {16.0, 32.0, 64.0}) {
        ClosedCurve b = c2;
        // Only the first half of curve 2 (the root's left child): an open chain has a dipole term.
        for (Vec3& p : b) p += Vec3(D, 0, 0);
        const CurveSoA sb = toSoA(b);
        const CurveBvh tb = buildCurveBvh(sb, 100);
        const BvhNode& A = ta.nodes[0];
        const BvhNode& B = tb.nodes[static_cast<std::size_t>(tb.nodes[0].left)];
        const FarValue f = farFieldPair(A, B);
        const Real err = std::abs(f.value - exactPair(sa, A, sb, B));
        REQUIRE(err <= f.bound);
        if (prevD > 0) {
            // Halving q divides the error by ~2^5 = 32 for this D^-5 term; allow a factor 4 of
            // slack for the next orders and rounding of the small difference.
            INFO("D " << D << " err " << err << " prev " << prevErr);
            CHECK(err < prevErr / 8);
        }
        prevErr = err;
        prevD = D;
    }
}

TEST_CASE("gln farfield: certified integers of big links agree with the direct sum", "[collide][gln]") {
    // (2, 2k) torus links, 3000 + 3100 segments: more pairs than GlnSettings::directPairs, so the
    // far field decides; the direct sum (and Banchoff's count) must give the same integer.
    for (int k : {3, 6}) {
        const ClosedCurve a = test::torusCurve(2, 0.7, k, 0, 3000), b = test::torusCurve(2, 0.7, k, M_PI, 3100);
        const GlnResult r = linkingNumber(a, b);
        GlnSettings direct;
        direct.farField = false;
        const GlnResult d = linkingNumber(a, b, direct);
        INFO("k " << k << " method " << r.method << " raw " << r.raw << " bound " << r.bound);
        REQUIRE(r.status == GlnStatus::Certified);
        REQUIRE(d.status == GlnStatus::Certified);
        CHECK(r.theta > 0);  // decided by the far field
        CHECK(r.farPairs > 0);
        CHECK(r.linking == d.linking);
        CHECK(std::abs(r.linking) == k);
        CHECK(std::abs(r.raw - d.raw) <= r.bound + d.bound);
        CHECK(r.pairsExact < d.pairsExact);  // the far field replaced some exact pairs
    }
    // Dense random curves, tangled.
    const ClosedCurve a = test::fourierCurve(21, 8, 3000), b = test::fourierCurve(22, 8, 2900, Vec3(0.1, 0.2, 0));
    const GlnResult r = linkingNumber(a, b);
    REQUIRE(r.status == GlnStatus::Certified);
    CHECK(r.linking == test::banchoff(a, b, Vec3(0.37, 0.61, -0.7).normalized()));
}

TEST_CASE("gln farfield: the adaptive refinement certifies the direct sum's integer with fewer exact pairs",
          "[collide][gln]") {
    // Two tangled random curves (every far pair is close somewhere) and a torus link whose two
    // strands are apart except where they wind: the adaptive sum against the passes at uniform θ
    // and the direct sum, and the same bits for 1 and 3 threads.
    struct Case {
        ClosedCurve a, b;
    };
    std::vector<Case> cases;
    cases.push_back({test::fourierCurve(31, 8, 6000), test::fourierCurve(32, 8, 5800, Vec3(0.1, 0.2, 0))});
    cases.push_back({test::torusCurve(2, 0.7, 5, 0, 6000), test::torusCurve(2, 0.7, 5, M_PI, 6100)});
    for (const Case& c : cases) {
        GlnSettings uniform, direct;
        uniform.adaptive = false;
        direct.farField = false;
        const GlnResult r = linkingNumber(c.a, c.b), u = linkingNumber(c.a, c.b, uniform),
                        d = linkingNumber(c.a, c.b, direct);
        INFO("adaptive: " << r.method << " raw " << r.raw << " bound " << r.bound << " exact pairs " << r.pairsExact
                          << "; uniform: " << u.method << " exact pairs " << u.pairsExact);
        REQUIRE(r.status == GlnStatus::Certified);
        REQUIRE(d.status == GlnStatus::Certified);
        CHECK(r.linking == d.linking);
        CHECK(u.linking == d.linking);
        CHECK(std::abs(r.raw - d.raw) <= r.bound + d.bound);
        CHECK(r.bound < 0.5);
        CHECK(r.method.rfind("adaptive far field", 0) == 0);
        CHECK(r.pairsExact <= u.pairsExact);
        CHECK(r.pairsExact < d.pairsExact);
        GlnResult one, three;
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
            one = linkingNumber(c.a, c.b);
        }
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 3);
            three = linkingNumber(c.a, c.b);
        }
        CHECK(one.raw == r.raw);
        CHECK(three.raw == r.raw);
        CHECK(one.bound == r.bound);
        CHECK(three.pairsExact == r.pairsExact);
    }
}
