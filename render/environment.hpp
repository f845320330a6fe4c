#pragma once
/// @file environment.hpp
/// @brief Ambient light from every direction (render.environment; docs/rendering.md,
/// "Environment light"): an environment's diffuse irradiance as nine spherical-harmonic
/// coefficients, the order-2 fit of the cosine-weighted sphere (exact for any environment made of
/// l <= 1 terms, such as a uniform colour or a sky over a ground).

#include "base/types.hpp"

#include <array>
#include <vector>

namespace dgv {

struct Environment {
    /// c_lm = (Â_l / π) L_lm for the real basis Y_00, Y_1-1, Y_10, Y_11, Y_2-2 .. Y_22 with
    /// y up (Â_0 = π, Â_1 = 2π/3, Â_2 = π/4): ambient(n) = Σ c_lm Y_lm(n), linear RGB.
    std::array<Vec3, 9> coefficients;
    Environment() { coefficients.fill(Vec3::Zero()); }  // Eigen's vectors start uninitialised
};

/// A uniform environment of linear colour c: ambient(n) = c for every n.
Environment uniformEnvironment(const Vec3& colour);

/// A sky of radiance `sky` above the horizon and `ground` below: ambient(n) = sky (1 + n_y)/2 +
/// ground (1 − n_y)/2, exactly.
Environment skyEnvironment(const Vec3& sky, const Vec3& ground);

/// An equirectangular image (linear RGB, `width` x `height`, rows from the top: the zenith; the
/// image's centre column looks along −z, u growing towards +x), turned `rotationDegrees` about
/// the vertical, projected on the nine coefficients (each pixel by its solid angle).
Environment equirectEnvironment(const std::vector<Vec3>& pixels, int width, int height, Real rotationDegrees = 0);

/// The ambient light (irradiance / π) a surface of normal n receives, linear RGB.
Vec3 ambientAt(const Environment& e, const Vec3& n);

}  // namespace dgv
