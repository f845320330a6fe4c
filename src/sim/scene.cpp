#include "sim/scene.hpp"

#include <Eigen/Geometry>

#include <cmath>

namespace dgv {

Mat3 TransformDesc::linear() const {
    const Real d = M_PI / 180.0;
    Mat3 r = (Eigen::AngleAxis<Real>(rotateDegrees.z() * d, Vec3::UnitZ()) *
              Eigen::AngleAxis<Real>(rotateDegrees.y() * d, Vec3::UnitY()) *
              Eigen::AngleAxis<Real>(rotateDegrees.x() * d, Vec3::UnitX()))
                 .toRotationMatrix();
    return r * scale.asDiagonal();
}

Vec3 CurveDesc::offsetAt(Real frame) const {
    if (motion.empty()) return Vec3::Zero();
    if (frame <= motion.front().first) return motion.front().second;
    for (std::size_t i = 1; i < motion.size(); ++i) {
        if (frame <= motion[i].first) {
            const auto& [f0, v0] = motion[i - 1];
            const auto& [f1, v1] = motion[i];
            return v0 + (frame - f0) / (f1 - f0) * (v1 - v0);
        }
    }
    return motion.back().second;
}

}  // namespace dgv

namespace dgv {

bool sceneMoves(const SceneDesc& scene) {
    if (!scene.forces.empty()) return true;
    for (const ObjectDesc& o : scene.objects)
        if (o.deformable && (o.velocity.squaredNorm() > 0 || o.spinDegrees.squaredNorm() > 0)) return true;
    return false;
}

Real lensVerticalFovDegrees(const Lens& lens, Real aspect) {
    // tan(fov/2) = (sensor / 2) / focal along the sensor's side: the longer one.
    const Real along = lens.sensorMm / (2 * lens.focalLengthMm);
    const Real vertical = aspect > 1 ? along / aspect : along;
    return 2 * std::atan(vertical) * (180 / 3.141592653589793);
}

Real resolvedStiffness(const MaterialDesc& m, Real halfHeight) {
    constexpr Real kTwoPi = 6.283185307179586, kStandardGravity = 9.81;
    switch (m.stiffnessFrom) {
        case MaterialDesc::StiffnessFrom::Value:
            return m.stiffness;
        case MaterialDesc::StiffnessFrom::WobbleHz:
            return (kTwoPi * m.wobbleHz) * (kTwoPi * m.wobbleHz);
        case MaterialDesc::StiffnessFrom::Sag:
            break;
    }
    // scenes/README.md's rule, sag ≈ 5 g/(k r) of the radius r (measured on balls: the
    // trace-free part of the sag is about two thirds of it).
    return halfHeight > 0 ? 5 * kStandardGravity / (m.sag * halfHeight) : 0;
}

Real resolvedDamping(const MaterialDesc& m, Real stiffness) {
    if (!(m.wobbles > 0) || !(stiffness > 0)) return m.damping;
    // A wobble's amplitude decays as exp(−damping t/2) (the twist rate decays at `damping`):
    // a tenth after `wobbles` periods of 2π/√k.
    constexpr Real kPi = 3.141592653589793;
    return std::sqrt(stiffness) * std::log(10.0) / (kPi * m.wobbles);
}

bool PinDesc::contains(const Vec3& x) const {
    switch (kind) {
        case Kind::None:
            return false;
        case Kind::Box:
            return (x.array() >= min.array()).all() && (x.array() <= max.array()).all();
        case Kind::Ball:
            return (x - centre).norm() <= radius;
        case Kind::Group:
            return false;  // by vertices, not by position (sim/simulation.cpp)
    }
    return false;
}

}  // namespace dgv
