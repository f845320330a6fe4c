// The signed distance sampled block by block on demand (src/collide/sampled_distance.hpp): its
// samples are the exact distance clamped at the band, between them it is SdfGrid's trilinear
// rule on the same samples (bit for bit, whatever the order of the queries or the threads), it
// fills only the blocks near the queries, and against a sphere it is the closed form to within
// what trilinear interpolation of a distance allows.
#include <catch2/catch.hpp>

#include "collide/mesh_distance.hpp"
#include "collide/sampled_distance.hpp"
#include "geom/primitives.hpp"
#include "geom/sdf_grid.hpp"

#include <cmath>
#include <random>
#include <thread>

using namespace dgv;

namespace {

/// Every sample of `s` computed eagerly, by MeshDistance, into an SdfGrid of the same lattice (with
/// the same query: beyond the band from the mesh's box its lower bound, which the clamp replaces;
/// on the surface two triangles may give distances a rounding apart).
SdfGrid eagerGrid(const TriangleMesh& mesh, const SampledDistance& s, Real band) {
    const MeshDistance exact(mesh);
    SdfGrid g;
    g.origin = s.origin();
    g.spacing = s.spacing();
    g.dims = s.dims();
    g.values.resize(static_cast<std::size_t>(g.dims.prod()));
    for (int k = 0; k < g.dims.z(); ++k)
        for (int j = 0; j < g.dims.y(); ++j)
            for (int i = 0; i < g.dims.x(); ++i) {
                const Vec3 x = g.origin + g.spacing * Vec3(i, j, k);
                g.values[static_cast<std::size_t>(i + g.dims.x() * (j + g.dims.y() * k))] =
                    static_cast<float>(std::min(exact.signedDistance(x, nullptr, band), band));
            }
    return g;
}

}  // namespace

TEST_CASE("sampled distance: the samples are the exact distance clamped at the band, trilinear between",
          "[collide][distance]") {
    const TriangleMesh ball = makeSphere(0.5, 24, 12);
    const Real voxel = 0.05;
    const int band = 4;
    const SampledDistance s(ball, voxel, band);
    // The samples lie on the world lattice voxel · (i, j, k) and cover the ball and the band.
    const Vec3 o = s.origin() / voxel;
    CHECK((o - o.array().round().matrix()).norm() < 1e-9);
    CHECK((s.origin().array() <= -0.5 - band * voxel).all());
    CHECK((s.origin() + voxel * (s.dims().cast<Real>() - Vec3::Ones())).minCoeff() >= 0.5 + band * voxel);
    const SdfGrid eager = eagerGrid(ball, s, band * voxel);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<Real> u(-0.9, 0.9);
    int differ = 0;
    for (int n = 0; n < 3000; ++n) {
        // Anywhere in and around the box, also beyond it, where both grow like a distance.
        const Vec3 x(u(rng), u(rng), u(rng));
        Vec3 g;
        const Real d = s.distance(x, &g);
        if (d != eager.distance(x) || g != eager.gradient(x)) ++differ;
    }
    CHECK(differ == 0);
    // At a sample the value is the sample: the exact distance (to float), or the clamp.
    const MeshDistance exact(ball);
    for (const Vec3& node : {Vec3(0.5, 0, 0), Vec3(0.1, -0.2, 0.3), Vec3(0, 0, 0), Vec3(0.55, 0.55, 0.55)}) {
        INFO(node.transpose());
        CHECK(s.distance(node) == Approx(std::min(exact.signedDistance(node), band * voxel)).margin(1e-7));
    }
}

TEST_CASE("sampled distance: the same values in any order and on any number of threads", "[collide][distance]") {
    const TriangleMesh torus = makeTorus(0.5, 0.2, 32, 16);
    const SampledDistance forward(torus, 0.04, 3), backward(torus, 0.04, 3), threaded(torus, 0.04, 3);
    std::vector<Vec3> xs;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<Real> u(-0.8, 0.8);
    for (int n = 0; n < 4000; ++n) xs.emplace_back(u(rng), 0.4 * u(rng), u(rng));
    std::vector<Real> a(xs.size()), b(xs.size()), c(xs.size());
    for (std::size_t n = 0; n < xs.size(); ++n) a[n] = forward.distance(xs[n]);
    for (std::size_t n = xs.size(); n-- > 0;) b[n] = backward.distance(xs[n]);
    {
        // Four threads, each over all the points from its own start, so that they race for blocks.
        std::vector<std::thread> pool;
        std::vector<std::vector<Real>> each(4, std::vector<Real>(xs.size()));
        for (std::size_t t = 0; t < 4; ++t)
            pool.emplace_back([&, t] {
                for (std::size_t m = 0; m < xs.size(); ++m) {
                    const std::size_t n = (m + t * xs.size() / 4) % xs.size();
                    each[t][n] = threaded.distance(xs[n]);
                }
            });
        for (auto& th : pool) th.join();
        for (std::size_t t = 1; t < 4; ++t) CHECK(each[t] == each[0]);
        c = each[0];
    }
    CHECK(a == b);
    CHECK(a == c);
    CHECK(forward.blocksFilled() == threaded.blocksFilled());
}

TEST_CASE("sampled distance: only the blocks near the queries are computed", "[collide][distance]") {
    const TriangleMesh ball = makeSphere(1.0, 48, 24);
    const Real voxel = 0.02;  // 100 samples across the ball: about 15³ blocks of 8³
    const SampledDistance s(ball, voxel, 3);
    const Vec3i blocks = (s.dims() + Vec3i::Constant(7)) / 8;
    const std::size_t total = static_cast<std::size_t>(blocks.prod());
    REQUIRE(total > 2000);
    CHECK(s.blocksFilled() == 0);
    // A contact patch: points within a few voxels of the pole touch at most the 2³ blocks around
    // each, all near each other.
    for (int n = 0; n < 50; ++n) {
        const Vec3 x(0.01 * std::sin(n), 1.0 + 0.002 * n - 0.05, 0.01 * std::cos(n));
        CHECK(s.distance(x) == Approx(x.norm() - 1.0).margin(2e-3));
    }
    CHECK(s.blocksFilled() >= 1);
    CHECK(s.blocksFilled() <= 8);
}

TEST_CASE("sampled distance: a sphere's distance and gradient to within trilinear interpolation",
          "[collide][distance]") {
    const Real r = 0.6, voxel = 0.03;
    const TriangleMesh ball = makeSphere(r, 128, 64);
    const SampledDistance s(ball, voxel, 3);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<Real> u(-1, 1);
    Real worst = 0, worstAngle = 0, farthest = 0;
    for (int n = 0; n < 2000; ++n) {
        // Within the band around the surface, where contact needs the field: every sample of
        // the cell around x (at most √3 voxels from it) inside the 3 voxels of the clamp.
        Vec3 dir(u(rng), u(rng), u(rng));
        if (dir.norm() < 1e-3) continue;
        dir.normalize();
        const Real rad = r + 1.2 * voxel * u(rng);
        const Vec3 x = rad * dir;
        Vec3 g;
        const Real d = s.distance(x, &g);
        worst = std::max(worst, std::abs(d - (rad - r)));
        worstAngle = std::max(worstAngle, std::acos(std::min(Real(1), g.normalized().dot(dir))));
        farthest = std::max(farthest, std::abs(g.norm() - 1));
    }
    INFO("worst distance error " << worst << ", gradient angle " << worstAngle << " rad, |g| - 1 " << farthest);
    // The mesh (128 × 64 facets) lies within r (1 − cos(π/64)) ≈ 7e-4 inside the sphere, and
    // trilinear interpolation of f = |x| − r errs by at most h²/8 · Σ_a |∂²f/∂x_a²| ≤ h²/(4 |x|).
    const Real bound = r * (1 - std::cos(M_PI / 64)) + voxel * voxel / (4 * (r - 1.2 * voxel));
    CHECK(worst < bound);
    // Its gradient errs by at most h · max |∂²f| = h / (r − 1.2 h) ≈ 0.053 (measured 0.034 in
    // angle and 0.030 in length).
    const Real slope = voxel / (r - 1.2 * voxel);
    CHECK(worstAngle < slope);
    CHECK(farthest < slope);
    // Beyond the band the value is the clamp, and beyond the box it grows like a distance.
    CHECK(s.distance(Vec3(0, r + 3.5 * voxel, 0)) == Approx(3 * voxel).margin(1e-6));
    const Vec3 far(3, 0, 0);
    const Real hiX = s.origin().x() + voxel * (s.dims().x() - 1);
    CHECK(s.distance(far) == Approx(3 * voxel + (3 - hiX)).margin(1e-6));
}
