// Tests of src/geom/primitives.hpp: closed, manifold, outward, volumes converge.
#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "geom/primitives.hpp"

#include <cmath>

using namespace dgv;

namespace {
constexpr Real kPi = 3.14159265358979323846;

void requireClosedManifold(const TriangleMesh& m) {
    const MeshReport r = analyseMesh(m);
    CHECK(r.closed);
    CHECK(r.manifold);
    CHECK(r.boundaryEdges == 0);
    CHECK(r.nonManifoldEdges == 0);
    CHECK(r.signedVolume > 0);  // outward
    TriangleMesh copy = m;
    CHECK(dropDegenerateTriangles(copy) == 0);
}
}  // namespace

TEST_CASE("primitives: every primitive is closed, manifold and outward", "[geom]") {
    requireClosedManifold(makeSphere(1.0));
    requireClosedManifold(makeSphere(0.3, 3, 2));
    requireClosedManifold(makeBox(Vec3(1, 2, 3)));
    requireClosedManifold(makeBox(Vec3(1, 2, 3), 5));
    requireClosedManifold(makeTorus(1.0, 0.25));
    requireClosedManifold(makeTorus(1.0, 0.25, 3, 3));
    requireClosedManifold(makeCapsule(0.5, 1.0));
    requireClosedManifold(makeCapsule(0.5, 0.0, 8, 1));
}

TEST_CASE("primitives: box volume is exact and its bounds are the size", "[geom]") {
    for (int d = 1; d <= 4; ++d) {
        const TriangleMesh m = makeBox(Vec3(1.5, 2, 0.25), d);
        CHECK(std::abs(meshSignedVolume(m) - 0.75) < 1e-14);
        CHECK(m.triangleCount() == std::size_t(12 * d * d));
        CHECK(m.vertexCount() == std::size_t(6 * d * d + 2));  // Euler: V = T/2 + 2
        const Box3 b = meshBounds(m);
        CHECK((b.min - Vec3(-0.75, -1, -0.125)).norm() < 1e-15);
        CHECK((b.max - Vec3(0.75, 1, 0.125)).norm() < 1e-15);
    }
}

TEST_CASE("primitives: volumes converge to the analytic ones at second order", "[geom]") {
    const Real r = 0.8, R = 1.5, rt = 0.4, hc = 1.2;
    const Real sphere = 4.0 / 3 * kPi * r * r * r;
    const Real torus = 2 * kPi * kPi * R * rt * rt;
    const Real capsule = kPi * r * r * hc + sphere;
    Real prev[3] = {0, 0, 0};
    for (int n : {16, 32, 64, 128}) {
        const Real e[3] = {std::abs(meshSignedVolume(makeSphere(r, n, n / 2)) / sphere - 1),
                           std::abs(meshSignedVolume(makeTorus(R, rt, n, n)) / torus - 1),
                           std::abs(meshSignedVolume(makeCapsule(r, hc, n, n / 4)) / capsule - 1)};
        for (int s = 0; s < 3; ++s) {
            CHECK(e[s] < 40.0 / (n * n));             // O(1/n^2), with the constant of the inscribed polygon
            if (n > 16) CHECK(e[s] < prev[s] / 3.5);  // halving the segment angle: ~1/4
            prev[s] = e[s];
        }
    }
}

TEST_CASE("primitives: invalid parameters are input errors", "[geom]") {
    CHECK_THROWS_AS(makeSphere(-1), InputError);
    CHECK_THROWS_AS(makeSphere(std::nan("")), InputError);
    CHECK_THROWS_AS(makeSphere(1, 2, 8), InputError);
    CHECK_THROWS_AS(makeBox(Vec3(1, 0, 1)), InputError);
    CHECK_THROWS_AS(makeBox(Vec3(1, 1, 1), 0), InputError);
    CHECK_THROWS_AS(makeTorus(1, 1), InputError);
    CHECK_THROWS_AS(makeCapsule(1, -1), InputError);
}
