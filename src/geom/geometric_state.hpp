#pragma once
/// @file geometric_state.hpp
/// @brief The geometric state of a voxel-parametrised volume (seed eqs 1-11 and the list in
/// section 4, "Geometric State"), stored structure-of-arrays over the lattice points.
///
/// Derivatives are with respect to the integer material coordinates u_a, so at rest
/// x_a = h e_a and g_ab = h^2 delta_ab, and Gamma^c_ab is dimensionless (it scales like h for
/// a fixed smooth shape sampled at spacing h). Finite differences (docs/math.md, "Finite
/// differences on the lattice"), per point and axis a:
///  - x_a:  central (x[+a] - x[-a])/2 where both neighbours exist; otherwise one-sided,
///          (-3x + 4x[s] - x[2s])/2 * s when two points exist on side s, else (x[s] - x) * s.
///  - x_aa: x[+a] - 2x + x[-a]; one-sided 2x - 5x[s] + 4x[2s] - x[3s] (2nd order) when three
///          points exist on side s, x - 2x[s] + x[2s] (1st order) when two, else 0.
///  - x_ab (a != b): the mean, over the quadrants (s,t) in {-1,+1}^2 whose points u+s e_a,
///          u+t e_b, u+s e_a+t e_b all exist, of s t (x[sa+tb] - x[sa] - x[tb] + x). With all
///          four quadrants this is the 2nd-order cross stencil (x[++] - x[+-] - x[-+] + x[--])/4;
///          with fewer it is one-sided (1st order); with none, 0.
///  - Axes with no neighbour on either side (a tip of a curved boundary, one-voxel-thin sheets
///          and rods, isolated points): x_c is the mean of x_c at those 6-neighbours that have
///          a difference along c (exact for affine maps); where none has, completeFrame() below
///          (exact for rigid motions only). x_cc and x_ac are 0 there.
/// Every stencil is exact for affine maps, so Gamma = 0 (to round-off) for any affine image of
/// the lattice and Gamma is unchanged by x -> A x + b (except at points whose frame comes from
/// completeFrame, whose made-up tangents follow only rigid motions). Interior (all 18 points
/// of the 3x3x3 neighbourhood except the corners present): 2nd order; boundary: 1st order or
/// better (measured orders in docs/math.md).

#include "base/types.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <vector>

namespace dgv {

/// Symmetric index pairs (a,b) of second derivatives, in storage order.
inline constexpr std::array<std::array<int, 2>, 6> kSymmetricPairs = {{{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}}};

struct GeometricState {
    std::vector<Vec3> position;                ///< x, world units
    std::array<std::vector<Vec3>, 3> tangent;  ///< x_a = dx/du_a (eq 1)
    std::vector<Mat3> metric;                  ///< g_ab = x_a . x_b (eq 2)
    std::vector<Mat3> metricInv;               ///< g^ab (eq 3)
    std::array<std::vector<Vec3>, 3> dual;     ///< x^a = g^ab x_b (eq 5); x^a . x_b = delta
    std::array<std::vector<Vec3>, 6> second;   ///< x_ab by kSymmetricPairs (eq 7)
    /// christoffel[c][p](a,b) = Gamma^c_ab = x^c . x_ab (eq 8), symmetric in (a,b).
    std::array<std::vector<Mat3>, 3> christoffel;

    Index size() const { return static_cast<Index>(position.size()); }
};

/// The second-derivative stencils of boundary points (docs/math.md, "Finite differences on the
/// lattice"; interior points use the central ones either way).
enum class BoundaryStencils {
    /// Second order where the points exist (x_aa by 2x − 5x[s] + 4x[2s] − x[3s]; x_ab by the mean
    /// of the quadrant stencils): the geometry's, the diagnostics' and the renderer's default.
    Accurate,
    /// What the reconstruction's edge transports integrate back: x_aa by x − 2x[s] + x[2s] (with
    /// the one-sided second-order x_a, the trapezoid rule of the edge generators then telescopes
    /// exactly along the axis) and x_ab by ½ (∂_b x_a + ∂_a x_b) from first differences of the
    /// tangent field. First order at the boundary; the dynamics' state (docs/math.md, "Boundary
    /// stencils the reconstruction can realise"): with the Accurate ones, the reconstruction
    /// realised some boundary changes backwards and a jelly's shape memory grew them.
    Realisable,
};

/// Computes every field of `state` from positions x(u) (#P, world units, one per lattice point),
/// in parallel; bit-identical for any thread count. `state` is resized to #P (its storage is
/// reused when it already has that size). Never produces NaN or infinity: near-singular
/// frames get a pseudo-inverse metric (invertMetric).
void computeGeometricState(const Lattice& lat, const std::vector<Vec3>& positions, GeometricState& state,
                           BoundaryStencils stencils = BoundaryStencils::Accurate);

/// Covariant derivative (eq 11) of the contravariant field f^b (#P Vec3s of coefficients, one
/// per point): result[p](b, a) = f^b_{;a} = d f^b / du_a + sum_c f^c Gamma^b_ca. d/du_a uses the
/// x_a stencil above (central inside, one-sided at the boundary, 0 along axes with no
/// neighbour). Requires state computed on `lat`.
std::vector<Mat3> covariantDerivative(const Lattice& lat, const GeometricState& state, const std::vector<Vec3>& f);

// ---- per-point kernels (pure; used by computeGeometricState, exposed for tests) ------------

/// Completes a tangent frame along axes that neither the point nor any of its neighbours can
/// difference (one-voxel-thin sheets and rods, isolated points).
/// @param[in,out] tangent  x_a, world units per lattice step; entries with present[a] false
///                         are overwritten.
/// @param[in]     present  whether x_a came from a finite difference
/// @param[in]     spacing  h, world units (the rest length of a tangent)
/// Rule: missing tangents are orthogonal to the present ones, right-handed, with lengths that
/// keep det(x_1, x_2, x_3) = h^3 (the rest volume):
///  - one missing (c): x_c = h^3 (x_a x x_b) / |x_a x x_b|^2, (a,b,c) cyclic; rest direction
///    h e_c if x_a x x_b is (near) zero. Exact for rigid motions of a thin sheet.
///  - two missing: the rest directions h e_b, h e_c carried by the smallest rotation that takes
///    e_a to x_a / |x_a|, scaled by sqrt(h / |x_a|).
///  - all missing (isolated point): x_a = h e_a.
void completeFrame(std::array<Vec3, 3>& tangent, const std::array<bool, 3>& present, Real spacing);

/// g^-1 of a symmetric positive semi-definite metric (eq 3). Returns true for a regular metric
/// (adjugate / det). When det g <= 1e-14 (tr g / 3)^3 it returns false and writes the
/// Moore-Penrose pseudo-inverse (eigenvalues below 1e-12 of the largest dropped; 0 for g = 0).
bool invertMetric(const Mat3& metric, Mat3& metricInv);

}  // namespace dgv
