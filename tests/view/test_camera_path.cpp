// The scene's camera at a frame (view/camera_path): each kind against its closed form.

#include "view/camera_path.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace dgv;

namespace {
SceneDesc sceneFrames(int start, int end) {
    SceneDesc s;
    s.frameStart = start;
    s.frameEnd = end;
    return s;
}
Box3 unitBox() {
    Box3 b;
    b.extend(Vec3(-1, -1, -1));
    b.extend(Vec3(1, 1, 1));
    return b;
}
}  // namespace

TEST_CASE("camera path: a turntable turns its degrees over the range and comes back after the last frame",
          "[view][camera]") {
    SceneDesc s = sceneFrames(1, 24);
    s.camera.type = CameraType::Turntable;
    s.camera.degrees = 360;
    s.camera.startDegrees = 30;
    s.camera.elevationDegrees = 0;
    const Box3 b = unitBox();
    // angle = start + degrees (frame − start) / frames: frame 7 is a quarter turn on
    const Camera first = frameCamera(s, b, 1, 1.5), quarter = frameCamera(s, b, 7, 1.5);
    const Real a0 = std::atan2(first.eye.x(), first.eye.z()) * 180 / M_PI;
    const Real a1 = std::atan2(quarter.eye.x(), quarter.eye.z()) * 180 / M_PI;
    CHECK(a0 == Approx(30).margin(1e-9));
    CHECK(a1 == Approx(120).margin(1e-9));
    CHECK(first.eye.norm() == Approx(quarter.eye.norm()).epsilon(1e-12));  // same orbit
    CHECK(first.target.norm() == Approx(0).margin(1e-12));                  // the bounds' centre
    // the frame after the last is the first again (a loop without a repeated frame)
    const Camera after = frameCamera(s, b, 25, 1.5);
    CHECK((after.eye - first.eye).norm() == Approx(0).margin(1e-9));
}

TEST_CASE("camera path: a keyframed camera interpolates linearly between its keys and holds outside them",
          "[view][camera]") {
    SceneDesc s = sceneFrames(1, 48);
    s.camera.type = CameraType::Keyframed;
    CameraKey k1, k2;
    k1.frame = 10;
    k1.eye = Vec3(0, 1, 10);
    k1.target = Vec3::Zero();
    k1.fovDegrees = 30;
    k2.frame = 20;
    k2.eye = Vec3(10, 3, 0);
    k2.target = Vec3(1, 0, 0);
    k2.fovDegrees = 50;
    s.camera.keys = {k1, k2};
    const Camera mid = frameCamera(s, unitBox(), 15, 16.0 / 9);
    CHECK((mid.eye - Vec3(5, 2, 5)).norm() == Approx(0).margin(1e-12));
    CHECK((mid.target - Vec3(0.5, 0, 0)).norm() == Approx(0).margin(1e-12));
    CHECK(mid.fovYDegrees == Approx(40).epsilon(1e-12));
    CHECK((frameCamera(s, unitBox(), 1, 1).eye - k1.eye).norm() == 0);   // held before the first
    CHECK((frameCamera(s, unitBox(), 48, 1).eye - k2.eye).norm() == 0);  // and after the last
}

TEST_CASE("camera path: a look-at camera is the scene's at every frame, its lens read at the image's aspect",
          "[view][camera]") {
    SceneDesc s = sceneFrames(1, 10);
    s.camera.type = CameraType::LookAt;
    s.camera.eye = Vec3(2, 3, 4);
    s.camera.target = Vec3(0, 1, 0);
    s.camera.lens = Lens{50, 36};
    for (int f : {1, 5, 10}) {
        const Camera c = frameCamera(s, unitBox(), f, 16.0 / 9);
        CHECK((c.eye - s.camera.eye).norm() == 0);
        CHECK((c.target - s.camera.target).norm() == 0);
        // 50 mm on a 36 mm sensor across the longer side: 2 atan(18 / 50 · 9/16) vertically
        CHECK(c.fovYDegrees == Approx(2 * std::atan(18.0 / 50 * 9 / 16) * 180 / M_PI).epsilon(1e-12));
    }
}
