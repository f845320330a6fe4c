// Closest approach of segments and closed polylines (collide/curve_distance.hpp): against brute
// force sampling with its grid bound, and on the rings of the seed's figures.

#include "collide/curve_distance.hpp"
#include "tests/collide/curves.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace dgv;

TEST_CASE("curve distance: segment pairs against dense sampling", "[collide][gln]") {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<Real> d(-1, 1);
    const int N = 400;
    for (int trial = 0; trial < 200; ++trial) {
        const Vec3 p0(d(rng), d(rng), d(rng)), q0(d(rng), d(rng), d(rng));
        Vec3 p1(d(rng), d(rng), d(rng)), q1(d(rng), d(rng), d(rng));
        if (trial % 10 == 1) p1 = p0;                    // a point
        if (trial % 10 == 2) q1 = q0 + 0.7 * (p1 - p0);  // parallel
        const Real dist = segmentDistance(p0, p1, q0, q1);
        Real sampled = HUGE_VAL;
        for (int i = 0; i <= N; ++i)
            for (int j = 0; j <= N; ++j)
                sampled = std::min(sampled, ((p0 + (p1 - p0) * i / N) - (q0 + (q1 - q0) * j / N)).norm());
        // Every sample is a pair of points on the segments: dist ≤ sampled. The closest pair lies
        // within half a grid step of a sample on each segment: sampled ≤ dist + (L1 + L2) / 2N.
        const Real grid = ((p1 - p0).norm() + (q1 - q0).norm()) / (2 * N);
        INFO("trial " << trial);
        REQUIRE(dist <= sampled + 1e-15);
        REQUIRE(sampled <= dist + grid + 1e-15);
    }
    // Crossing segments: 0; skew perpendicular lines 1 apart.
    CHECK(segmentDistance({-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}) == 0);
    CHECK(segmentDistance({-1, 0, 0}, {1, 0, 0}, {0, -1, 1}, {0, 1, 1}) == 1);
}

TEST_CASE("curve distance: two rings, and the culling changes nothing", "[collide][gln]") {
    const ClosedCurve a = test::ring(Vec3::Zero(), Vec3::UnitX(), Vec3::UnitY(), 1, 128);
    for (Real c : {4.0, 2.5, 2.0, 1.5}) {
        const ClosedCurve b = test::ring(Vec3(c, 0, 0), Vec3::UnitX(), Vec3::UnitZ(), 1, 96);
        Real brute = HUGE_VAL;
        for (std::size_t i = 0; i < a.size(); ++i)
            for (std::size_t j = 0; j < b.size(); ++j)
                brute = std::min(brute, segmentDistance(a[i], a[(i + 1) % a.size()], b[j], b[(j + 1) % b.size()]));
        const Real dist = curveDistance(a, b);
        INFO("c " << c);
        CHECK(dist == brute);
        // Unlinked side: the closest points are the vertices (1,0,0) and (c−1,0,0), exactly.
        if (c >= 2) CHECK(dist == c - 2);
    }
}
