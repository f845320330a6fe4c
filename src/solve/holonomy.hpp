#pragma once
/// @file holonomy.hpp
/// @brief Holonomies of the connection along lattice paths (seed eqs 12-19) and the per-edge
/// transports every reconstruction method is built from (docs/math.md, "Holonomy and
/// reconstruction").
///
/// Conventions (derived in docs/math.md; Γ as stored by geom/geometric_state.hpp):
///  - Connection matrix along axis b at a point: (G_b)_{ca} = Γ^c_ab, i.e. the seed's A of
///    eq 15 for the path direction dγ/dλ = e_b, with matrix rows the upper index (A_{ca} = A^c_a).
///  - A lattice edge p -> q = p + s e_b (s = ±1) is one step Δλ = 1. Its generator is the
///    midpoint value S_pq = s (G_b(p) + G_b(q)) / 2 (second order; exp(s G_b(p)) is only first).
///  - Holonomy (eq 18), ordered with later steps on the LEFT:
///        H(γ_n, γ_0) = exp(-S_n) ... exp(-S_2) exp(-S_1),   S_k = S_{γ_{k-1} γ_k}.
///    It carries vector coefficients f^b with f_{;a} = 0 (a world vector held fixed):
///    f(γ_n) = H(γ_n, γ_0) f(γ_0). H(γ_0, γ_n) (the reversed path) = H(γ_n, γ_0)^-1.
///  - Frames F = [x_1 x_2 x_3] (columns x_a) obey dF/du_b = F G_b (eq 7), so
///        F(γ_n) = F(γ_0) H(γ_0, γ_n) = F(γ_0) exp(S_1) exp(S_2) ... exp(S_n).
///  - Positions across an edge, if Γ is constant along it: x(q) - x(p) = F(p) φ1(S_pq) s e_b,
///    φ1(S) = Σ_k S^k/(k+1)! (exact for frames F(p) exp(λ S), λ in [0,1]).
/// Every quantity is dimensionless (per lattice step) except frames and positions (world units).

#include "base/types.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <vector>

namespace dgv {

/// The connection of one point as stored in GeometricState::christoffel:
/// gamma[c](a, b) = Γ^c_ab.
using PointConnection = std::array<Mat3, 3>;

/// Connection matrix along axis b (0..2): result(c, a) = Γ^c_ab (seed eq 15 with dγ = e_b).
Mat3 connectionMatrix(const PointConnection& gamma, int axis);

/// Midpoint generator of the edge p -> p + sign e_axis: sign (G_axis(p) + G_axis(q)) / 2.
Mat3 edgeGenerator(const PointConnection& gammaP, const PointConnection& gammaQ, int axis, int sign);

/// exp(S) and φ1(S) = Σ_k S^k/(k+1)! together: degree-13 Taylor of φ1 after scaling S to
/// 1-norm <= 1/4, exp(S) = 1 + S φ1(S), then squaring back (φ1(2X) = φ1(X)(exp(X) + 1)/2).
/// Agrees with Eigen's Padé exponential to ~1e-15 relative (tested); ~10x faster.
void expPhi1(const Mat3& S, Mat3& expS, Mat3& phi1);

/// expPhi1 of `count` (<= 4) generators at once, each result the same bits as alone: the same
/// arithmetic per matrix, interleaved so that the independent products overlap (a Horner step
/// waits on the one before it; measured about 1.3-1.5x faster for three at a time).
void expPhi1Batch(const Mat3* S, Mat3* expS, Mat3* phi1, int count);

/// Transport across one edge with generator S: frame factor exp(S) and step vector
/// φ1(S) e_axis (see the file comment), by expPhi1.
void edgeTransport(const Mat3& generator, int axis, Mat3& expS, Vec3& step);

/// The two step vectors of an edge with generator S without its transport matrix:
/// from = φ1(S) e_axis and to = φ1(−S) e_axis (EdgeTransports::stepFrom, stepTo). For
/// |S|_1 <= 1/4 by the powers S^j e_axis (the even and odd parts of one Taylor sum, degree as in
/// expPhi1: about a third of expPhi1's work); larger S by expPhi1 of S and of −S.
void edgeSteps(const Mat3& S, int axis, Vec3& from, Vec3& to);

/// Holonomy H(γ_n, γ_0) of eq 18 along a lattice path (consecutive points must be
/// 6-neighbours; checked). `christoffel` is GeometricState::christoffel (3 x #P).
/// A path of one point gives the identity.
Mat3 pathHolonomy(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel,
                  const std::vector<Index>& path);

/// Exact solution (eq 19) of f^b_{;a} = G^b_a (eq 12) along a lattice path: returns f at every
/// path point, starting from f(γ_0) = `start`. Per edge: f_k = exp(-S_k) f_{k-1} plus the
/// trapezoid rule of ∫ H(λ_k, λ') G(λ') dλ' (G^b = s G^b_{axis}, eq 16), second order.
/// @param driving  #P matrices, driving[p](b, a) = G^b_a (the layout of covariantDerivative)
std::vector<Vec3> solveAlongPath(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel,
                                 const std::vector<Mat3>& driving, const std::vector<Index>& path, const Vec3& start);

/// The transports of every lattice edge, stored once per edge on its lower point: for point p
/// and axis b with q = p + e_b present (slot 2b+1), with S = S_pq:
///   forward[b][p] = exp(S)      F(q) = F(p) exp(S)
///   backward[b][p] = exp(-S)    F(p) = F(q) exp(-S)
///   stepFrom[b][p] = φ1(S) e_b  x(q) - x(p) = F(p) stepFrom
///   stepTo[b][p] = φ1(-S) e_b   x(q) - x(p) = F(q) stepTo
/// Entries of absent edges are zero. 576 bytes per point.
struct EdgeTransports {
    std::array<std::vector<Mat3>, 3> forward, backward;
    std::array<std::vector<Vec3>, 3> stepFrom, stepTo;
    Index size() const { return static_cast<Index>(forward[0].size()); }
};

/// All edge transports from the connection (parallel over points; bit-identical for any
/// thread count).
EdgeTransports computeEdgeTransports(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel);

/// Frame transport along the directed edge (p, slot): F(q) ≈ F(p) * result.
inline const Mat3& frameTransport(const Lattice& lat, const EdgeTransports& e, Index p, int slot) {
    const int axis = slot / 2;
    if (slot & 1) return e.forward[static_cast<std::size_t>(axis)][static_cast<std::size_t>(p)];
    const Index q = lat.neighbours[static_cast<std::size_t>(p)][static_cast<std::size_t>(slot)];
    return e.backward[static_cast<std::size_t>(axis)][static_cast<std::size_t>(q)];
}

/// Position step along the directed edge (p, slot) from the frames at both ends:
/// x(q) - x(p) ≈ (F(p) φ1(S_pq) + F(q) φ1(-S_pq)) s e_b / 2, antisymmetric in (p, q) and exact
/// when the frames are exact and Γ is constant along the edge.
inline Vec3 positionStep(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames, Index p,
                         int slot) {
    const std::size_t axis = static_cast<std::size_t>(slot / 2);
    const Index q = lat.neighbours[static_cast<std::size_t>(p)][static_cast<std::size_t>(slot)];
    const Mat3& fp = frames[static_cast<std::size_t>(p)];
    const Mat3& fq = frames[static_cast<std::size_t>(q)];
    if (slot & 1) {
        const std::size_t lo = static_cast<std::size_t>(p);
        return Real(0.5) * (fp * e.stepFrom[axis][lo] + fq * e.stepTo[axis][lo]);
    }
    const std::size_t lo = static_cast<std::size_t>(q);
    return Real(-0.5) * (fq * e.stepFrom[axis][lo] + fp * e.stepTo[axis][lo]);
}

}  // namespace dgv
