// The scene's camera at a frame (camera_path.hpp).

#include "view/camera_path.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace dgv {

/// The keyframed camera at `frame`: eye, target and fov interpolated linearly between the keys
/// around it, held before the first and after the last.
namespace {

Camera keyframedCamera(const CameraDesc& c, Real frame, Real aspect) {
    Camera cam;
    cam.up = c.up;
    const std::vector<CameraKey>& k = c.keys;
    std::size_t i = 0;
    while (i + 1 < k.size() && k[i + 1].frame <= frame) ++i;
    const CameraKey& a = k[i];
    const CameraKey& b = k[std::min(i + 1, k.size() - 1)];
    const Real t = (b.frame > a.frame) ? std::clamp((frame - a.frame) / (b.frame - a.frame), Real(0), Real(1)) : 0;
    cam.eye = (1 - t) * a.eye + t * b.eye;
    cam.target = (1 - t) * a.target + t * b.target;
    cam.fovYDegrees = (1 - t) * a.vertical(aspect) + t * b.vertical(aspect);
    return cam;
}

}  // namespace

Camera frameCamera(const SceneDesc& scene, const Box3& bounds, Real frame, Real aspect) {
    const CameraDesc& c = scene.camera;
    if (c.type == CameraType::Keyframed) return keyframedCamera(c, frame, aspect);
    if (c.type == CameraType::LookAt) {
        Camera cam;
        cam.eye = c.eye;
        cam.target = c.target;
        cam.up = c.up;
        cam.fovYDegrees = c.vertical(aspect);
        return cam;
    }
    // A full turn over the range comes back to the start on the frame after the last, so the
    // sequence loops without a repeated frame.
    const Real frames = scene.frameEnd - scene.frameStart + 1;
    const Real angle = c.startDegrees + c.degrees * (frame - scene.frameStart) / frames;
    return turntableCamera(bounds, angle, c.elevationDegrees, c.vertical(aspect), aspect, c.margin);
}

Camera lensSample(const Camera& camera, const CameraDesc& desc, Real aspect, int k, int n) {
    constexpr Real kPi = 3.14159265358979323846;
    const Real sensor = (desc.lens ? desc.lens->sensorMm : 36) / 1000;
    const Real tanLong = std::tan(camera.fovYDegrees * kPi / 360) * std::max(aspect, Real(1));
    const Real focal = sensor / 2 / tanLong;
    const Real aperture = focal / (2 * desc.fStop);
    const Vec3 view = camera.target - camera.eye;
    const Real focus = desc.focusDistance > 0 ? desc.focusDistance : view.norm();
    const Vec3 forward = view.normalized();
    const Vec3 right = forward.cross(camera.up).normalized();
    const Vec3 up = right.cross(forward);
    // Vogel's spiral: radius √((k + ½)/n), turning by the golden angle.
    const Real r = aperture * std::sqrt((k + 0.5) / n);
    const Real a = k * kPi * (3 - std::sqrt(Real(5)));
    const Vec2 d(r * std::cos(a), r * std::sin(a));
    Camera sample = camera;
    const Vec3 move = d.x() * right + d.y() * up;
    sample.eye += move;
    sample.target += move;
    sample.lensShift = camera.lensShift + d / focus;
    return sample;
}

}  // namespace dgv
