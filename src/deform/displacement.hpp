#pragma once
/// @file displacement.hpp
/// @brief The displacement representation of a deformation (seed eqs 35-39, 42-43, 62-63).
///
/// Conventions (docs/math.md, "Index placement of M"):
///  - eps: #P displacement coefficients eps^a (eq 36), dimensionless (lattice steps measured in
///    the rest tangent basis): X = x + sum_a eps^a x_a, with x_a the REST tangents.
///  - M:   #P deformation matrices, M(a, c) = M_a^c = delta_a^c + eps^c_{;a} (eq 39): row a is
///    the lower (derivative) index, column c the upper (component) index. Then
///      X_a = sum_c M(a, c) x_c           (eq 37/46; as frames: Xframe = xframe * M^T),
///      gbar = M g M^T                    (eq 38/42, g(a, b) = g_ab),
///      det gbar = det g (det M)^2        (eq 43).
///    The seed's sentence "M_ab = M_b^a" before eq 42 is the transpose of this and does not give
///    eq 42; we follow eq 38, which does.
/// Discrete covariant derivative (docs/math.md, "Discrete covariant derivatives"): eps^c_{;a} is
/// taken as x^c . d(sum_b eps^b x_b)/du_a, the world displacement differenced with the tangent
/// stencil of geom (central inside, one-sided at the boundary) and read back in the dual frame.
/// In the continuum this is eq 11 (d eps^c/du_a + sum_b eps^b Gamma^c_ba); on the lattice it
/// makes eqs 37-38 hold EXACTLY (X_a is then the tangent of X by the same stencil), where
/// d eps + Gamma eps by separate differences breaks the product rule at the boundary.

#include "base/types.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <vector>

namespace dgv {

/// eq 36 inverted: eps^a = x^a . (X - x), exact (the rest duals span space).
/// @param rest       geometric state of the rest (reference) configuration
/// @param positions  #P deformed positions X, world units
std::vector<Vec3> displacementCoefficients(const GeometricState& rest, const std::vector<Vec3>& positions);

/// eqs 35-36: X = x + sum_a eps^a x_a (world units), #P.
std::vector<Vec3> displacedPositions(const GeometricState& rest, const std::vector<Vec3>& eps);

/// eq 39: M(a, c) = delta_ac + eps^c_{;a} (the discrete covariant derivative above, with the
/// rest frames). Exact for affine maps of any rest state; X_a = sum_c M(a, c) x_c (the tangent
/// of the displaced positions by geom's stencil) to round-off at every point whose three axes
/// have neighbours. Along an axis with no neighbour, eps_{;a} = 0 (row a of M is e_a). #P.
std::vector<Mat3> deformationMatrices(const Lattice& lat, const GeometricState& rest, const std::vector<Vec3>& eps);

/// d field / du_axis at point p with the tangent stencil of geom/geometric_state.hpp (central
/// where both neighbours exist, else one-sided 2nd order, else 1st order); returns false (and
/// 0) when p has no neighbour along the axis.
bool latticeDerivative(const Lattice& lat, const std::vector<Vec3>& field, Index p, int axis, Vec3& derivative);

// ---- per-point kernels ----------------------------------------------------------------------

/// eq 37/46: deformed frame, columns X_a = sum_c M(a, c) x_c; `frame` has columns x_a.
inline Mat3 deformedFrame(const Mat3& frame, const Mat3& M) { return frame * M.transpose(); }

/// eq 38/42: gbar = M g M^T (world units^2 per lattice step^2).
inline Mat3 deformedMetric(const Mat3& M, const Mat3& metric) { return M * metric * M.transpose(); }

/// eq 62 strain, tau(a, b) = (eps^a_{;b} + eps^b_{;a}) / 2 = sym(M - 1), dimensionless, in
/// material coordinates with mixed indices as the seed writes it (not lowered by g).
inline Mat3 strain(const Mat3& M) {
    const Mat3 D = M - Mat3::Identity();
    return Real(0.5) * (D + D.transpose());
}

/// eq 63 pressure p = -(1/3) sum_a eps^a_{;a} = -tr(M - 1)/3, dimensionless (a diagnostic:
/// the linearised relative volume change is -3p).
inline Real pressure(const Mat3& M) { return -(M.trace() - Real(3)) / Real(3); }

}  // namespace dgv
