#include "render/camera.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace dgv {

namespace {
constexpr Real kPi = 3.14159265358979323846;
Real radians(Real degrees) { return degrees * kPi / 180.0; }
}  // namespace

Mat4 Camera::viewFromWorld() const {
    const Vec3 f = (target - eye).normalized();  // forward, camera -Z
    const Vec3 s = f.cross(up).normalized();     // right, camera +X
    const Vec3 u = s.cross(f);                   // true up, camera +Y
    Mat4 m = Mat4::Identity();
    m.block<1, 3>(0, 0) = s.transpose();
    m.block<1, 3>(1, 0) = u.transpose();
    m.block<1, 3>(2, 0) = -f.transpose();
    m(0, 3) = -s.dot(eye);
    m(1, 3) = -u.dot(eye);
    m(2, 3) = f.dot(eye);
    return m;
}

Mat4 Camera::clipFromView(Real aspect, Real nearZ, Real farZ) const {
    const Real t = 1.0 / std::tan(0.5 * radians(fovYDegrees));
    Mat4 m = Mat4::Zero();
    m(0, 0) = t / aspect;
    m(1, 1) = t;
    m(0, 2) = -m(0, 0) * lensShift.x();  // x_ndc = m00 (x/(−z) + shift)
    m(1, 2) = -m(1, 1) * lensShift.y();
    m(2, 2) = (farZ + nearZ) / (nearZ - farZ);
    m(2, 3) = 2.0 * farZ * nearZ / (nearZ - farZ);
    m(3, 2) = -1.0;
    return m;
}

Camera turntableCamera(const Box3& bounds, Real angleDegrees, Real elevationDegrees, Real fovYDegrees, Real aspect,
                       Real margin) {
    Vec3 centre = Vec3::Zero();
    Real radius = 1.0;
    if (!bounds.empty()) {
        centre = bounds.centre();
        radius = 0.5 * bounds.size().norm();
        if (!(radius > 0)) radius = 1.0;
    }
    // The bounding sphere fits a view cone of half-angle theta when distance = r / sin(theta);
    // theta is the smaller of the vertical and horizontal half-angles of the view.
    const Real halfV = 0.5 * radians(fovYDegrees);
    const Real halfH = std::atan(std::tan(halfV) * aspect);
    const Real theta = std::min(halfV, halfH);
    const Real distance = margin * radius / std::sin(theta);

    const Real a = radians(angleDegrees);
    const Real e = radians(elevationDegrees);
    const Vec3 dir(std::cos(e) * std::sin(a), std::sin(e), std::cos(e) * std::cos(a));
    Camera cam;
    cam.target = centre;
    cam.eye = centre + distance * dir;
    // The up vector tangent to the orbit's meridian: orthogonal to the view, valid at the poles.
    cam.up = Vec3(-std::sin(e) * std::sin(a), std::cos(e), -std::sin(e) * std::cos(a));
    cam.fovYDegrees = fovYDegrees;
    cam.nearClip = 0;  // chosen by the renderer from the scene (the ground reaches past the object)
    cam.farClip = 0;
    return cam;
}

}  // namespace dgv
