// liftOutOfColliders (dynamics/collider.hpp): points inside a static collider end on its surface,
// points outside stay where they are, another body's surface is left alone, against the closed
// forms of a plane, a sphere and a distance function.

#include "dynamics/collider.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace dgv;

TEST_CASE("collider: points inside a static collider are lifted onto its surface, the rest stay",
          "[dynamics][collider]") {
    Collider ground;  // y >= 0
    Collider ball;
    ball.kind = Collider::Kind::Sphere;
    ball.point = Vec3(2, 0, 0);
    ball.radius = 0.5;
    // A distance with a gradient of length 2 (not unit): the box |x − (−2, 0, 0)|∞ ≤ 0.5 scaled.
    Collider scaled;
    scaled.kind = Collider::Kind::Distance;
    scaled.distance = [](const Vec3& x, Vec3* g) {
        const Vec3 d = x - Vec3(-2, 1, 0);
        if (g) *g = 2 * d.normalized();
        return 2 * (d.norm() - 0.5);
    };
    std::vector<Vec3> points = {Vec3(0.3, -0.02, 0.1), Vec3(0, 0.5, 0),    Vec3(2.1, 0.2, 0.3),
                                Vec3(-2, 0.8, 0.1),    Vec3(2, 0.7, 0),    Vec3(1.7, -0.05, 0)};
    const std::vector<Vec3> before = points;
    const Real deepest = liftOutOfColliders({ground, ball, scaled}, points);
    // below the ground: straight up onto it
    CHECK(points[0].isApprox(Vec3(0.3, 0, 0.1)));
    // outside everything: unchanged, bit for bit
    CHECK(points[1] == before[1]);
    CHECK(points[4] == before[4]);
    // inside the ball: along its radius onto the sphere
    CHECK((points[2] - ball.point).norm() == Approx(0.5).epsilon(1e-12));
    CHECK((points[2] - ball.point).normalized().isApprox((before[2] - ball.point).normalized()));
    // inside the scaled distance's ball: onto its zero set whatever the gradient's length
    CHECK((points[3] - Vec3(-2, 1, 0)).norm() == Approx(0.5).epsilon(1e-12));
    // inside the ground and the ball at once: out of both
    CHECK(points[5].y() >= -1e-12);
    CHECK((points[5] - ball.point).norm() >= 0.5 - 1e-12);
    // the deepest point moved, in world units (φ over its gradient's length): the one in the
    // scaled ball, 0.5 − |(0, −0.2, 0.1)|
    CHECK(deepest == Approx(0.5 - std::sqrt(0.05)).epsilon(1e-12));

    SECTION("another body's surface is not a static collider") {
        Collider other = ground;
        other.object = true;
        std::vector<Vec3> p = {Vec3(0, -1, 0)};
        CHECK(liftOutOfColliders({other}, p) == 0);
        CHECK(p[0] == Vec3(0, -1, 0));
    }
}
