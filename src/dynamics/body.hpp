#pragma once
/// @file body.hpp
/// @brief Body motion (seed eqs 66-67): masses of the material points, the centre of mass and
/// the mass-averaged force, integrated by velocity Verlet; and the force moments about the centre
/// of mass that drive flex (eq 68): the averaged force gradient the seed uses, and the force's
/// first moment, whose affine fit does not leave the O(1) affine error of the averaged gradient
/// for nonlinear fields (docs/math.md, "Body motion (eqs 66-67) and the force moments behind flex").
///
/// Units: masses in density units × world units³ (kg for kg/m³ and metres); accelerations in
/// world units/s²; times in seconds. The field is evaluated at a scene frame (forces.hpp); the
/// caller maps its time to frames (frame = start + t·fps).
///
/// Mass. The seed's eq 66 integrates over material coordinates, x_Body = (1/V)∫d³u x(u). dgv
/// discretises ∫d³u by the lattice cells (the trilinear hexahedra between 2×2×2 blocks of material
/// points: the cells whose volume the dynamics conserves) and gives each point the share of the
/// cells it is a corner of: m_p = ρ h³ · (cells containing p)/8 (MassRule::CellShare). Then the
/// centre of mass is the exact centroid of the union of the cells for any affine image of the
/// lattice, and mass is conserved exactly when cell volumes are. Points in no complete cell
/// (one-voxel-thin features) get no mass under that rule; MassRule::Voxel (ρ h³ per point, the
/// voxelisation's volume) is the alternative.

#include "base/types.hpp"
#include "dynamics/forces.hpp"
#include "geom/lattice.hpp"

#include <functional>
#include <vector>

namespace dgv {

/// How the mass of a material point is counted (file comment).
enum class MassRule { CellShare, Voxel };

/// Mass of every material point, in point order: ρ h³ · (complete lattice cells containing the
/// point)/8 (CellShare) or ρ h³ (Voxel). Requires density > 0 (InputError otherwise).
std::vector<Real> pointMasses(const Lattice& lat, Real density, MassRule rule = MassRule::CellShare);

/// Mass-weighted moments of the force over the body, about its centre of mass. ỹ = x − centre.
struct ForceMoments {
    Real mass = 0;                     ///< M = Σ m
    Vec3 centre = Vec3::Zero();        ///< x_Body = Σ m x / M (eq 66)
    Vec3 meanForce = Vec3::Zero();     ///< ẍ_Body = Σ m F / M (eq 67), m/s²
    Mat3 meanGradient = Mat3::Zero();  ///< Σ m ∇F / M: the seed's R of eq 68 (filled when asked for), 1/s²
    Mat3 firstMoment = Mat3::Zero();   ///< Σ m F ỹᵀ / M, m²/s²
    Mat3 secondMoment = Mat3::Zero();  ///< Σ m ỹ ỹᵀ / M, m² (the mass covariance; the rigid-body
                                       ///< inertia tensor is tr(S)·1 − S times M)

    /// firstMoment · secondMoment⁻¹: the gradient G of the affine field a + G ỹ that fits F best
    /// in the mass-weighted least-squares sense (a = meanForce). Equals ∇F for a linear field.
    /// Requires an invertible second moment (a body that is not flat).
    Mat3 momentGradient() const;
};

/// Centre of mass of `positions` (#P, world units) with `masses` (#P). Deterministic parallel
/// reduction, bit-identical for any thread count. Requires Σ m > 0.
Vec3 centreOfMass(const std::vector<Real>& masses, const std::vector<Vec3>& positions);

/// The moments above at scene frame `frame`; the mean gradient only when `withGradient`.
/// Two deterministic parallel passes (centre, then moments about it), bit-identical for any
/// thread count.
ForceMoments forceMoments(const ForceField& field, const std::vector<Real>& masses, const std::vector<Vec3>& positions,
                          Real frame, bool withGradient = true);

/// The centre of mass moving as one particle (eq 67).
struct BodyState {
    Vec3 centre = Vec3::Zero();        ///< x_Body, world units
    Vec3 velocity = Vec3::Zero();      ///< ẋ_Body, world units/s
    Vec3 acceleration = Vec3::Zero();  ///< ẍ_Body at the current time (eq 67), world units/s²
};

/// One step of velocity Verlet (kick, drift, kick): v += a dt/2; x += v dt; a = a(new);
/// v += a dt/2. Symplectic, second order in dt, exact for a constant acceleration (free fall).
/// @param[in,out] body                state at t; on return at t + dt
/// @param[in]     dt                  seconds, > 0
/// @param[in]     accelerationAfter   eq 67's acceleration at t + dt of the body displaced by
///                                    the argument (the drift), e.g. forceMoments(field, masses,
///                                    positions + shift, frame(t + dt)).meanForce
/// @return the displacement δx_Body of eq 65
Vec3 stepBody(BodyState& body, Real dt, const std::function<Vec3(const Vec3& displacement)>& accelerationAfter);

}  // namespace dgv
