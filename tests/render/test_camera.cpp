// Camera matrices and the turntable framing.

#include "render/camera.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <cmath>

using namespace dgv;

namespace {
Vec3 ndc(const Mat4& clipFromWorld, const Vec3& p) {
    const Vec4 c = clipFromWorld * p.homogeneous();
    return c.head<3>() / c.w();
}
}  // namespace

TEST_CASE("camera: the view centre maps to NDC 0 and the view looks down -Z", "[render]") {
    Camera cam;
    cam.eye = Vec3(3, 2, 4);
    cam.target = Vec3(-1, 0.5, 0.25);
    const Mat4 view = cam.viewFromWorld();
    const Vec4 t = view * cam.target.homogeneous();
    CHECK(std::abs(t.x()) < 1e-12);
    CHECK(std::abs(t.y()) < 1e-12);
    CHECK(t.z() == Approx(-(cam.target - cam.eye).norm()).epsilon(1e-12));
    const Vec4 e = view * cam.eye.homogeneous();
    CHECK(e.head<3>().norm() < 1e-12);
    // Rigid: the rotation block is orthonormal with determinant 1.
    const Mat3 r = view.block<3, 3>(0, 0);
    CHECK((r * r.transpose() - Mat3::Identity()).norm() < 1e-12);
    CHECK(r.determinant() == Approx(1.0).epsilon(1e-12));

    const Mat4 clip = cam.clipFromView(1.5, 0.5, 50) * view;
    const Vec3 c = ndc(clip, cam.target);
    CHECK(std::abs(c.x()) < 1e-12);
    CHECK(std::abs(c.y()) < 1e-12);
}

TEST_CASE("camera: projection of known points", "[render]") {
    Camera cam;
    cam.eye = Vec3(0, 0, 10);
    cam.target = Vec3::Zero();
    cam.fovYDegrees = 90;  // tan(45 deg) = 1: a point at height d in front of the camera hits the top edge
    const Real aspect = 2.0;
    const Mat4 clip = cam.clipFromView(aspect, 1, 100) * cam.viewFromWorld();
    CHECK(ndc(clip, Vec3(0, 4, 6)).y() == Approx(1.0).epsilon(1e-12));     // depth 4, height 4
    CHECK(ndc(clip, Vec3(8, 0, 6)).x() == Approx(1.0).epsilon(1e-12));     // width = aspect * depth
    CHECK(ndc(clip, Vec3(-2, -1, 8)).x() == Approx(-0.5).epsilon(1e-12));  // depth 2
    CHECK(ndc(clip, Vec3(-2, -1, 8)).y() == Approx(-0.5).epsilon(1e-12));
    // Near and far planes map to -1 and +1.
    CHECK(ndc(clip, Vec3(0, 0, 9)).z() == Approx(-1.0).epsilon(1e-12));
    CHECK(ndc(clip, Vec3(0, 0, -90)).z() == Approx(1.0).epsilon(1e-12));
}

TEST_CASE("camera: the turntable keeps the bounding sphere inside the view", "[render]") {
    const Box3 bounds{Vec3(-1, 0, -0.5), Vec3(2, 3, 0.5)};
    const Vec3 centre = bounds.centre();
    const Real radius = 0.5 * bounds.size().norm();
    const Real pi = 3.14159265358979323846;
    for (Real aspect : {0.5, 1.0, 16.0 / 9.0, 2.4}) {
        for (Real angle : {0.0, 45.0, 137.0, 270.0}) {
            for (Real elevation : {-30.0, 0.0, 20.0, 89.0, 90.0}) {
                const Real margin = 1.1;
                const Camera cam = turntableCamera(bounds, angle, elevation, 35, aspect, margin);
                INFO("aspect " << aspect << " angle " << angle << " elevation " << elevation);
                CHECK((cam.eye - centre).norm() > radius);
                const Mat4 clip = cam.clipFromView(aspect, 0.01, 1000) * cam.viewFromWorld();
                CHECK(ndc(clip, centre).head<2>().norm() < 1e-9);
                Real extent = 0;
                for (int i = 0; i <= 40; ++i) {
                    for (int j = 0; j < 80; ++j) {
                        const Real t = pi * i / 40, p = 2 * pi * j / 80;
                        const Vec3 q =
                            centre + radius * Vec3(std::sin(t) * std::cos(p), std::cos(t), std::sin(t) * std::sin(p));
                        const Vec3 n = ndc(clip, q);
                        extent = std::max({extent, std::abs(n.x()), std::abs(n.y())});
                    }
                }
                CHECK(extent <= 1.0);
                CHECK(extent > 0.75);  // fills the frame, not a speck
            }
        }
    }
    // Angle 0 looks from +Z, 90 from +X.
    CHECK(turntableCamera(bounds, 0, 0, 35, 1).eye.z() > centre.z() + radius);
    CHECK(turntableCamera(bounds, 90, 0, 35, 1).eye.x() > centre.x() + radius);
}
