#pragma once
/// @file light.hpp
/// @brief A light of a render's rig (scene render.lights, RenderSettings::lights; docs/rendering.md,
/// "Lighting model").

#include "base/types.hpp"

namespace dgv {

/// The most lights a rig holds (shaders/lighting.glsl, DGV_MAX_LIGHTS).
constexpr int kMaxLights = 8;

struct Light {
    enum class Type { Directional, Point } type = Type::Directional;
    /// Directional: the direction towards the light; point: its position. In world space, or with
    /// cameraRelative in the camera's level frame: x to the right of the view, y up, z back
    /// towards the camera (turned with the camera's azimuth, not tilted with its pitch), a point
    /// light's position then relative to the eye.
    Vec3 vector = Vec3::UnitY();
    /// Linear RGB times the intensity: a directional light's irradiance on a surface facing it; a
    /// point light's at 1 unit of distance (falling off as 1/d²).
    Vec3 colour = Vec3::Ones();
    bool cameraRelative = false;
    bool shadows = false;  ///< casts the shadow map's shadows (a directional light, one at most)
    Real shininess = 0;    ///< the specular highlight's exponent (0: none)
    bool floor = true;     ///< lights the studio floor (false: light linking's "exclude the floor")
};

}  // namespace dgv
