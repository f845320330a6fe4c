#pragma once
/// @file camera.hpp
/// @brief Pinhole cameras in world space (right-handed, Y up) and the turntable framing.

#include "base/types.hpp"

namespace dgv {

struct Camera {
    Vec3 eye = Vec3(0, 1, 5);
    Vec3 target = Vec3::Zero();
    Vec3 up = Vec3::UnitY();
    Real fovYDegrees = 35;  ///< vertical field of view
    Real nearClip = 0;      ///< 0: chosen from the scene bounds
    Real farClip = 0;       ///< 0: chosen from the scene bounds
    /// Off-axis projection: added to the tangents x/(−z), y/(−z) of the view (a lens sample of
    /// depth of field keeps its focus plane in place by it); 0: a centred view.
    Vec2 lensShift = Vec2::Zero();

    /// World -> camera (view) matrix, looking down -Z in camera space.
    Mat4 viewFromWorld() const;
    /// OpenGL clip-from-view projection for the given aspect (width / height).
    Mat4 clipFromView(Real aspect, Real nearZ, Real farZ) const;
};

/// A camera orbiting `bounds` about the vertical axis through its centre: `angleDegrees` around
/// Y (0 looks from +Z), `elevationDegrees` above the horizon, at a distance that fits the whole
/// bounding sphere in the view with `margin` (1.1 = 10% room) for the given aspect.
Camera turntableCamera(const Box3& bounds, Real angleDegrees, Real elevationDegrees, Real fovYDegrees, Real aspect,
                       Real margin = 1.1);

}  // namespace dgv
