#pragma once
/// @file connection_delta.hpp
/// @brief The connection representation of a deformation and its link to the displacement
/// representation (seed eqs 45-52), and the volume-conserving (trace-free) projection of a
/// connection change (eqs 60-61; docs/math.md, "Which part of δΓ conserves volume").
///
/// Storage as in geom: field[c][p](a, b) = Gamma^c_ab (dimensionless, per lattice step),
/// symmetric in (a, b). A single point's connection is std::array<Mat3, 3>, [c](a, b).

#include "base/types.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <vector>

namespace dgv {

/// #P connection values per upper index c: field[c][p](a, b) = Gamma^c_ab.
using ConnectionField = std::array<std::vector<Mat3>, 3>;
/// One point's connection: [c](a, b) = Gamma^c_ab.
using PointConnection = std::array<Mat3, 3>;

/// eqs 46-52: the deformed connection Gammabar^c_ab = sum_d Q(d, c) M^d_{a;b}, Q = M^-1 (eq 51),
/// with the covariant derivative of eq 48 discretised as for eps (displacement.hpp): the world
/// tangents X_a = sum_c M(a, c) x_c (eq 46, REST frames) are differenced along b with geom's
/// tangent stencil, X_ab, and Gammabar^c_ab = X^c . X_ab (eq 49) with X^c = sum_d Q(d, c) x^d
/// (eq 50). M is the eq 39 matrix, M(a, c) = M_a^c. The result is symmetrised in (a, b) (the
/// continuum value is symmetric; the lattice one is symmetric to 2nd order inside). With M from
/// deformationMatrices, X_a are the deformed positions' tangents and the only difference from
/// the connection computed from the deformed positions is d(d x/du_a)/du_b against geom's
/// second-difference stencils: 2nd order inside, 1st order at the boundary, on curved rest
/// states too (tests/deform/test_connection_delta.cpp; docs/math.md). Axes with no neighbour:
/// 0, as in geom. Points with |det M| <= 1e-12 (collapsed) get Gammabar = Gamma (no change).
ConnectionField deformedConnection(const Lattice& lat, const GeometricState& rest, const std::vector<Mat3>& M);

/// eq 45: dGamma = Gammabar - Gamma from eps via M (deformedConnection minus rest).
ConnectionField connectionDelta(const Lattice& lat, const GeometricState& rest, const std::vector<Mat3>& M);

/// tau_a = sum_b dGamma^b_ab: the trace that decides volume. Along a path with tangent v,
/// tr dA = tau . v (eq 55), and det M changes by exp(-integral tr dA) (eqs 57, 60-61); for a
/// Christoffel connection sum_b Gamma^b_ab = d_a ln det(frame).
Vec3 connectionTrace(const PointConnection& gamma);

/// The trace-free projection that makes exp(integral dA) an SL(3) matrix (eq 61) on every
/// path: dGamma^c_ab -= (delta^c_a tau_b + delta^c_b tau_a) / 4. It is the orthogonal
/// (Frobenius) projection of symmetric tensors onto the symmetric ones with tau = 0: keeps
/// the symmetry in (a, b), zero trace after, idempotent. 15 of the 18 components survive.
void projectTraceFree(PointConnection& dGamma);

/// projectTraceFree at every point of a field, in parallel.
void projectTraceFree(ConnectionField& dGamma);

}  // namespace dgv
