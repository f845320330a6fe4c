#pragma once
/// @file sl3.hpp
/// @brief Projections of a deformation matrix M onto SL(3) = {det M = 1} (seed eqs 44, 81, 82),
/// as pure per-matrix kernels.
///
/// M is the deformation matrix of displacement.hpp, M(a, c) = M_a^c = delta_a^c + eps^c_{;a}
/// (dimensionless). Nothing here depends on the row/column convention: det, the Frobenius
/// distance and all three projections commute with transposition.
///
/// Which projection (docs/math.md, "Projections onto SL(3)"): the default is the nearest
/// matrix (projectToSL3Nearest): it never fails for det M > 0 in the realistic range, moves M
/// least by construction, and costs ~1 us. eq 81 (uniform scaling) always works for det M > 0
/// but moves M further and changes rotations too; eq 82 (scaling the deformation D = M - 1) has
/// no real root for a large share of realistic matrices and its least-|f| root can invert M
/// (rates measured in tests/deform/test_sl3.cpp and tabled in docs/math.md).

#include "base/mat3.hpp"  // cofactor, which the projections' derivatives use
#include "base/types.hpp"

namespace dgv {

/// Why a projection failed.
enum class Sl3Failure {
    kNone = 0,
    kNonPositiveDet,  ///< det M <= 0 (an inverted or collapsed frame): nothing to project
    kNoRealRoot,      ///< eq 82: det(1 + f D) = 1 has no real root f != 0
    kInverts,         ///< eq 82: every real root passes through det = 0 on the way from M = 1
    kNotConverged,    ///< nearest: the iteration did not reach |det - 1| <= 1e-13
};

/// Outcome of one projection. `matrix` is the projected matrix when ok, else the input M.
struct [[nodiscard]] Sl3Result {
    Mat3 matrix = Mat3::Identity();
    bool ok = false;
    Sl3Failure reason = Sl3Failure::kNone;
    Real f = 1;          ///< eq 82: the scale f chosen; eq 81: det(M)^(-1/3)
    int iterations = 0;  ///< nearest: outer iterations used
};

/// eq 81: M / det(M)^(1/3). det(result) = 1 to ~1e-15 relative. Fails (kNonPositiveDet) for
/// det M <= 0, where the cube root would flip every axis.
Sl3Result projectToSL3Scale(const Mat3& M);

/// eq 82: 1 + f (M - 1) with f fixed by det = 1. With D = M - 1,
///   det(1 + f D) = 1 + f tr D + f^2 s2 + f^3 det D,  s2 = ((tr D)^2 - tr(D^2)) / 2,
/// so det = 1 <=> f = 0 or  det D f^2 + s2 f + tr D = 0  (the seed's "quadratic").
/// Among the real roots the one of least |f| is taken (as the seed advises) provided the path
/// 1 + t D, t between 0 and f, keeps det > 0 (no inversion); otherwise the next root; if none
/// is left, kInverts. No real root (including the degenerate case tr D != 0 = s2 = det D, e.g. a
/// pure uniaxial stretch diag(1+e, 1, 1)): kNoRealRoot. If |det M - 1| <= 1e-15 already, M is
/// returned with f = 1.
Sl3Result projectToSL3Deformation(const Mat3& M);

/// The real roots f != 0 of det(1 + f (M - 1)) = 1 (eq 82), in increasing |f|; count 0, 1 or 2.
struct Eq82Roots {
    int count = 0;
    Real f[2] = {0, 0};
};
Eq82Roots eq82Roots(const Mat3& M);

/// The nearest matrix of SL(3) in the Frobenius norm: argmin |X - M|_F subject to det X = 1.
/// The Lagrange condition X - M = lambda cof(X) makes X share M's singular vectors (M = U diag(s)
/// V^T, U and V rotations): X = U diag(t) V^T with t_i - s_i = lambda / t_i, i.e.
/// t_i = (s_i + sqrt(s_i^2 + 4 lambda)) / 2, and lambda is the root of sum_i ln t_i = 0
/// (increasing and concave in lambda: safeguarded Newton, 3-6 iterations to round-off). The
/// positive roots t_i are the global minimiser (the other sign choices give larger distances).
/// det(result) = 1 to 1e-13; `f` holds lambda, `iterations` the Newton steps. Fails
/// (kNonPositiveDet) for det M <= 0. Cost: one 3x3 SVD (~1 us).
Sl3Result projectToSL3Nearest(const Mat3& M);

/// The default projection (nearest; falls back to eq 81 when the nearest does not converge).
/// Requires det M > 0; otherwise returns M with ok = false, kNonPositiveDet.
Sl3Result projectToSL3(const Mat3& M);

}  // namespace dgv
