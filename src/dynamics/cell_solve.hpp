#pragma once
/// @file cell_solve.hpp
/// @brief One solve per substep (docs/math.md, "The one-solve step"): backward Euler written as a
/// minimisation over the lattice points' positions x, in which inertia, the shape memory,
/// viscosity, every cell's volume, the corners' orientation, contact with friction and pins meet.
///
///     E(x) = Σ_p m_p |x_p − x̃_p|² / (2δt²)                       inertia (x̃: the forces' prediction)
///          + Σ_c μ ∫_c |F P_c⁻¹ − R_c|² dV                        shape memory, corotated (R_c: polar of F_c P_c⁻¹)
///          + Σ_c (μ_v/δt) ∫_c |F − R̃_c F⁻|² dV                    viscosity: the step's non-rigid deformation
///          + Σ_c (κ_c C_c² / 2 + λ_c C_c),  C_c = V_c/V0_c − 1     each cell's volume (augmented Lagrangian)
///          + Σ_c Σ_k κ_b V0_c b(J_ck)                              no inverted corner (a barrier, J > 0)
///          + Σ_p contact_p(x_p)                                    colliders: a stiff penalty with lagged Coulomb friction
///
/// with F the trilinear cell's deformation gradient (integrated exactly at the 2×2×2 Gauss
/// points, so no hourglass mode is free), F⁻ the one at the substep's start, R̃_c the cell's
/// rotation over the step, and J_ck the Jacobian of the three edges at corner k relative to rest.
/// Pinned points are fixed. The minimisation is vertex block descent: Gauss–Seidel over the
/// lattice's 8 parity colours (no cell holds two points of one colour, so each colour is updated
/// in parallel and the result does not depend on the thread count), one 3×3 Newton step per
/// point with a step length that keeps every corner it moves right-handed, and the volume
/// multipliers λ updated after each sweep. A corotated cell with one rotation is exact for
/// ∫|F − R|²: the integral of F over a trilinear cell is its volume times the frame at its centre.
///
/// Units: world units, seconds, kg; μ, μ_v·δt⁻¹ and the penalties in Pa (N/m²).

#include "base/types.hpp"
#include "deform/volume.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <functional>
#include <vector>

namespace dgv {

struct Collider;
class CellSolver;

/// What the solve minimises and when it stops.
struct CellSolveSettings {
    Real shearModulus = 0;  ///< μ, Pa: the shape memory (0: goo)
    Real viscosity = 0;     ///< μ_v = ρ ν, Pa·s
    /// The volume term's stiffness per cell, κ_c = volumeStiffness · (μ + μ_v/δt + ρ h²/δt²) · V0_c
    /// (a bulk modulus that many times the stiffest of the other terms at the lattice scale); the
    /// multipliers carry the rest of the way to C = 0.
    Real volumeStiffness = 1;
    Real cornerFloor = 0.25;  ///< the corner barrier acts below this Jacobian relative to rest
    Real cornerStiffness = 1;  ///< κ_b = cornerStiffness · (μ + μ_v/δt + ρ h²/δt²), Pa
    /// The contact penalty per point, contactStiffness · m_p / δt² (N/m): a point's weight held at
    /// a depth of g δt² / contactStiffness.
    Real contactStiffness = 1e3;
    Real tolerance = 1e-3;       ///< stop when no point moved more than tolerance · h in a sweep ...
    /// ... and every cell is within this of its rest volume (the exact projection takes the rest).
    Real volumeTolerance = 1e-3;
    int maxIterations = 200;
    Real density = 1000;  ///< ρ, kg/m³ (the inertia's scale in κ_c)
};

/// What a solve did.
struct CellSolveReport {
    int iterations = 0;
    bool converged = false;
    Real lastMove = 0;         ///< the last sweep's largest point move / h
    Real maxVolumeError = 0;   ///< max_c |C_c| at the end
    Real minCornerJacobian = 1;
    Index contacts = 0;        ///< points held by a collider or another body at the end
    Index colliderContacts = 0;  ///< of those, the points a collider holds that is not a body's surface
};

/// The per-step inputs of CellSolver::solve.
struct CellSolveInput {
    /// x⁻ (#P): the positions the step's velocity is measured from, v = (x − x⁻)/δt: the substep's
    /// start (backward Euler), or BDF2's extrapolation (4 x_n − x_(n−1))/3 with δt the step × 2/3.
    const std::vector<Vec3>* start = nullptr;
    /// #P: positions with every corner right-handed (the substep's start), the first guess where
    /// x̃ turns a corner over; null: `start`.
    const std::vector<Vec3>* feasible = nullptr;
    const std::vector<Vec3>* inertial = nullptr;  ///< x̃: the inertial prediction (#P)
    Real dt = 0;
    const std::vector<Real>* restVolumes = nullptr;  ///< V0_c (#C)
    const std::vector<Mat3>* restStretch = nullptr;  ///< P_c (#C) or null: the cube
    const std::vector<Collider>* colliders = nullptr;
    /// Per collider (or empty: none), per point, the depth the point may stay at (another body's
    /// surface: the share of the overlap the other body takes; #P each, or empty for 0).
    const std::vector<std::vector<Real>>* allowedDepth = nullptr;
    /// Per collider (or null: 0), how far outside its surface the points are held (world units).
    const std::vector<Real>* margins = nullptr;
};

/// A contact between two bodies solved together: point p of member a is held at least `margin`
/// outside member b's surface, whose nearest point is Σ_j w_j x_(q_j) with outward normal n,
/// both taken where the contact was found. The energy is that of a collider's penalty,
/// ½ k d², d = margin − n · (x_p − Σ_j w_j x_(q_j)), with lagged Coulomb friction on the
/// tangential motion of p relative to that surface point: one energy of both bodies' points,
/// so the forces on the two sides balance (momentum is exchanged, not made).
struct BodyContact {
    int a = 0;  ///< the member whose point it is
    Index p = 0;
    int b = 0;  ///< the member whose surface it meets
    std::array<Index, 3> q{};
    Vec3 w = Vec3::Zero();
    Vec3 normal = Vec3::UnitY();
    Real margin = 0;
    Real friction = 0;
    Real stiffness = 0;  ///< k, N/m (set by the solve: member a's contactStiffness · m_p / δt²)
};

/// One body's part of a solve (CellSolver::solve's arguments).
struct CellSolveMember {
    const CellSolver* solver = nullptr;
    CellSolveInput in;
    CellSolveSettings settings;
    std::vector<Vec3>* x = nullptr;
    std::vector<Real>* lambda = nullptr;
    std::vector<unsigned char>* contact = nullptr;
    std::vector<Real>* depth = nullptr;
    CellSolveReport report;  ///< out
};

/// Finds the contacts between the members at positions x (one per member): called at the start
/// of a solve and every few sweeps after (dynamics cannot include collide; sim supplies it).
using BodyContactFinder =
    std::function<void(const std::vector<const std::vector<Vec3>*>& x, std::vector<BodyContact>& out)>;

/// Minimises the sum of the members' energies (file comment) and of the contacts between them
/// that `find` reports, sweep by sweep over all of them (each member's colours in turn): bodies
/// in contact solved as one system. Stops when every member has converged (or at the largest
/// maxIterations). With one member and no finder, CellSolver::solve.
void solveTogether(std::vector<CellSolveMember>& members, const BodyContactFinder& find);

/// A lattice's cells prepared for the solve: the per-point cell lists and the 8 colours.
class CellSolver {
public:
    CellSolver() = default;
    /// @param mass    #P point masses (a point with no cell moves ballistically, to x̃)
    /// @param pinned  #P flags: fixed at their start positions
    CellSolver(const Lattice& lat, const LatticeCells& cells, std::vector<Real> mass, std::vector<unsigned char> pinned);

    /// Minimises E (file comment) from x (in: the first guess, out: the result). lambda: the
    /// volume multipliers (#C; in: the warm start, resized to zeros when it does not fit).
    /// contact, depth: #P, the points a collider holds at the end and how deep they were at x̃.
    CellSolveReport solve(const CellSolveInput& in, const CellSolveSettings& settings, std::vector<Vec3>& x,
                          std::vector<Real>& lambda, std::vector<unsigned char>& contact,
                          std::vector<Real>& depth) const;

    /// The trilinear cell's frame at its centre, F_c = (1/4h) Σ_k x_k s_kᵀ (s_k the corner's signs).
    static Mat3 centreFrame(const std::array<Vec3, 8>& x, Real h);
    /// The smallest corner Jacobian of a cell relative to rest (h³).
    static Real minCornerJacobian(const std::array<Vec3, 8>& x, Real h);

private:
    friend void solveTogether(std::vector<CellSolveMember>& members, const BodyContactFinder& find);
    struct Run;         // one member's state over a solve (cell_solve.cpp)
    struct ContactSet;  // the contacts between the members (cell_solve.cpp)
    struct Slot {
        Index cell;
        int corner;
    };
    const LatticeCells* mCells = nullptr;
    Real mH = 1;
    std::vector<Real> mMass;
    std::vector<unsigned char> mPinned;
    std::vector<std::array<Slot, 8>> mSlots;  ///< per point: its cells and its corner in each (cell −1: none)
    std::array<std::vector<Index>, 8> mColour;  ///< the free points of each parity colour
    std::vector<Index> mLoose;                  ///< free points with no cell
};

/// The polar rotation of M (M = R S, S symmetric positive semi-definite), by SVD with the sign
/// of the smallest singular direction flipped where det M < 0 (so R is a rotation).
Mat3 polarRotationOf(const Mat3& m);

}  // namespace dgv
