#pragma once
/// @file geometric_state.hpp
/// @brief The geometric state of a voxel-parametrised volume (seed eqs 1-11 and the list in
/// section 4, "Geometric State"), stored structure-of-arrays over the lattice points.
///
/// Derivatives are with respect to the integer material coordinates u_a, so at rest
/// x_a = h e_a and g_ab = h^2 delta_ab. Finite differences: central where both neighbours
/// exist, one-sided at the boundary (docs/math.md, "Finite differences").

#include "base/types.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <vector>

namespace dgv {

/// Symmetric index pairs (a,b) of second derivatives, in storage order.
inline constexpr std::array<std::array<int, 2>, 6> kSymmetricPairs = {{{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}}};

struct GeometricState {
    std::vector<Vec3> position;                 ///< x, world units
    std::array<std::vector<Vec3>, 3> tangent;   ///< x_a = dx/du_a (eq 1)
    std::vector<Mat3> metric;                   ///< g_ab = x_a . x_b (eq 2)
    std::vector<Mat3> metricInv;                ///< g^ab (eq 3)
    std::array<std::vector<Vec3>, 3> dual;      ///< x^a = g^ab x_b (eq 5); x^a . x_b = delta
    std::array<std::vector<Vec3>, 6> second;    ///< x_ab by kSymmetricPairs (eq 7)
    /// christoffel[c][p](a,b) = Gamma^c_ab = x^c . x_ab (eq 8), symmetric in (a,b).
    std::array<std::vector<Mat3>, 3> christoffel;

    Index size() const { return static_cast<Index>(position.size()); }
};

/// Computes every field of `state` from positions x(u) (one per lattice point), in parallel.
void computeGeometricState(const Lattice& lat, const std::vector<Vec3>& positions,
                           GeometricState& state);

/// Covariant derivative (eq 11) of the contravariant field f^b (one Vec3 of coefficients per
/// point): result[p](b, a) = f^b_{;a} = d f^b / du_a + sum_c f^c Gamma^b_ca.
std::vector<Mat3> covariantDerivative(const Lattice& lat, const GeometricState& state,
                                      const std::vector<Vec3>& f);

}  // namespace dgv
