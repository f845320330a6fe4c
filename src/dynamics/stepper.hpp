#pragma once
/// @file stepper.hpp
/// @brief The dynamics step of one deformable body (seed section 4, "Computation Steps"), made to
/// work: body (eqs 66-67), flex (eq 68, repaired), twist (eq 76, repaired), reconstruction of the
/// positions from Γ + δΓ, collisions with static colliders, the per-cell volume projection and the
/// new geometric state. docs/math.md, "The dynamics step", gives every departure from the notes
/// and the evidence for it. In short:
///  - One reference for the three motions. With m the point masses and X̃ the rest positions
///    about the rest centre of mass, the motion splits exactly into its mass-weighted mean
///    (body: c), its best affine fit in material coordinates (flex: A, x ≈ c + A X̃) and the
///    remainder (twist, carried by Γ, which no affine map changes). Because the split is a linear
///    projection, each part obeys the projected Newton equation exactly: c̈ = ⟨F⟩ (eq 67) and
///    Ä = ⟨F X̃ᵀ⟩⟨X̃ X̃ᵀ⟩⁻¹ (the force's first moment; eq 68's averaged gradient leaves an O(1)
///    error for nonlinear fields and is kept only as an option). After the twist's
///    reconstruction the affine part of the result is replaced by A, so neither part drifts.
///  - Flex in SL(3): Störmer-Verlet for A, the new A brought back onto SL(3) along the
///    constraint's reaction A⁻ᵀS⁻¹ at the start of the step (SHAKE: no torque), so det A = 1
///    every step.
///  - Twist: eq 76 with W split, W = 2 F⁻¹ L F (F the frame [x_1 x_2 x_3], L the velocity
///    gradient of the frames over the last step). The rotation part of L is applied exactly
///    (eq 78 holds in the metric g, and literally when g ∝ 1: a rigidly spinning body); its
///    stretch part only where it damps (eigenvalues that would amplify δΓ are clamped to zero,
///    the measured cause of the blow-ups). Then the force term of eq 76, optional shape memory
///    (−δt² k Γ) and damping (× exp(−ζ δt)), the trace-free projection (volume, docs/math.md) and a
///    limiter on |δΓ| per point.
///  - Reconstruction of the CHANGE: the displacement that Γ + δΓ asks for relative to Γ, as the
///    least-squares fit (PoissonSolver::solveSteps) of the differences of the edge steps of the
///    two connections' frames (both integrated by the same tree from the same root frame). With
///    δΓ = 0 nothing moves; the reconstruction's own O(h²) error does not leak into the motion.
///  - The step is two halves, predict (forces to reconstruction) and finish (colliders to the
///    new state), so that bodies colliding with each other meet where both are going
///    (sim/simulation; docs/gln.md, "Objects colliding").
///  - Colliders push points out (friction on the tangential step); the volume projection then
///    runs with pinned and contact points held, so it neither moves pins nor pushes points back
///    into a collider. With pins or contacts the body and flex velocities are re-derived from the
///    resulting positions (position-based), with restitution on the normal part of the body
///    velocity.
///
/// Units: world units (metres), seconds. Deterministic for any thread count.

#include "base/errors.hpp"
#include "base/types.hpp"
#include "dynamics/collider.hpp"
#include "deform/volume.hpp"
#include "dynamics/body_state.hpp"
#include "dynamics/cell_solve.hpp"
#include "dynamics/forces.hpp"
#include "dynamics/load_modes.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace dgv {

class PoissonSolver;
struct ReconstructWork;

/// How flex is driven (docs/math.md, "Flex").
enum class FlexDrive {
    FirstMoment,       ///< Ä = ⟨F X̃ᵀ⟩⟨X̃X̃ᵀ⟩⁻¹ (default; exact projection of Newton's equation)
    AveragedGradient,  ///< Ä = ⟨∇F⟩ A, the seed's eq 68 literally (kept for comparison)
};

/// How the stretch part of W enters eq 76 (docs/math.md, "Twist").
enum class TwistStretch {
    DampOnly,  ///< default: the part of the frame stretch that damps δΓ, never the part that amplifies it
    None,      ///< rotation only
    Full,      ///< eq 76 as written (unstable in long runs; for comparison)
};

/// How a substep is solved (docs/math.md, "The one-solve step").
enum class StepSolver {
    Chain,  ///< the notes' stages in turn: predict, colliders, volume projection, landing rules (default)
    One,    ///< one minimisation in which inertia, memory, viscosity, volumes, corners, contact and pins meet
};

/// StepSolver::One with plasticity: the most a cell's rest shape stretches or shrinks along any
/// axis (a rest shape far from the cube its corners' barrier and stiffness are scaled for).
constexpr Real kMaxRestStretch = 2.5;

/// Material and integration settings of a body. Defaults: goo (no memory of its rest shape),
/// damped at 1/s.
struct DynamicsSettings {
    Real density = 1000;  ///< kg/m^3
    StepSolver solver = StepSolver::Chain;
    /// StepSolver::One: the cells' shear modulus per unit density, stiffness and mean second
    /// moment per unit mass, μ/(ρ k s): what makes a ball's squash wobble at √k/2π (measured:
    /// docs/math.md, "The one-solve step").
    Real modulusPerStiffness = 0.7;
    Real damping = 1;     ///< ζ, 1/s: twist δΓ decays as exp(−ζ t); flex stretch rate too.
                          ///< Goo with 0 flows forever after a push and folds (docs/math.md)
    /// ν, m²/s: kinematic viscosity (docs/math.md, "Viscosity: the viscous stress at every
    /// scale"). On the non-affine motion, which the twist carries, the viscous term ν ∇²v as an
    /// implicit diffusion of δΓ over the lattice each step (the lattice-scale part damped most);
    /// on the affine motion, the strain rate's dissipation 2μ|D|², which decays the flex's
    /// strain rate at 2ν/s (s the body's mean second moment). Implicit, so stable at any ν; a
    /// rigid turn has no strain rate and keeps its spin. 0: none (the notes' goo).
    Real viscosity = 0;
    Real shapeStiffness = 0;  ///< k, 1/s^2: restoring term toward the rest shape (jelly);
                              ///< wobble frequency sqrt(k)/(2π) Hz
    /// Plasticity (docs/math.md, "Plasticity: the rest shape yields"), with shape memory only: the
    /// largest elastic strain the body holds, a logarithmic strain (0.2: about 22 % stretch).
    /// Beyond it the rest shape follows the body (putty, clay: a squash or a dent stays, the
    /// rest springs back): the flex's rest stretch P (memory toward R P) and the twist's rest
    /// connection Γ_p (memory toward Γ_p), each returned to within the yield every step. 0: off.
    Real yieldStrain = 0;
    FlexDrive flexDrive = FlexDrive::FirstMoment;
    TwistStretch twistStretch = TwistStretch::DampOnly;
    /// Turn δΓ by the frames' rotation over the step, R(−2θ) in eq 76's exp(−δt W) (true: the
    /// notes, eq 78), or leave its lattice components as they are (false, the default): Γ's
    /// lattice components do not change under a rigid motion (docs/math.md, "Twist"; the
    /// pumping once measured with the rotation was the tree's frames, see frameSweeps).
    bool twistRotation = false;
    Real maxDeltaGamma = 0.05;  ///< limiter: |δΓ| (Frobenius over the 18 components, per
                                ///< lattice step) per point per step
    /// Carry the connection change that happened (Γ_new − Γ_old, after every constraint) as the
    /// next step's δΓ (true), or the one eq 76 asked for (false, the default). Measured: true
    /// turns a collider's one-step squash into a lasting rate and folds the body (docs/math.md).
    bool realizedRate = false;
    /// Anti-windup of the twist in contact (docs/math.md, "Twist anti-windup in contact"): in a
    /// step with contacts, the next δΓ at each point keeps only the realised fraction of this
    /// step's, f = clamp(⟨Γ_new − Γ_old, δΓ⟩ / ⟨δΓ, δΓ⟩, 0, 1) — what the collider and the volume
    /// projection refused does not accumulate (a jelly resting on the ground wound up until it
    /// folded), and, unlike `realizedRate`, the collider's own push never enters δΓ. Free
    /// flight is untouched. false: for comparison.
    bool antiWindup = true;
    /// A free body's contacts push its body and flex first (the least-kinetic-energy change of
    /// centre and affine part, volume-keeping, that lifts the contact points out; docs/math.md,
    /// "Contact: body and flex take the collider's push first"), then single points. false: only
    /// single points move (measured: the bottom layer is crushed and folds; for comparison).
    bool affineContact = true;
    /// A jelly (shape memory, no yield) lands elastically: after a static collider's push the
    /// centre keeps the normal velocity the push leaves it and the flex the squash rate the push
    /// gave it, so the impact goes into the squash and the memory throws it back (docs/math.md,
    /// "Velocities after contact"). The inelastic rule of goo and putty (the centre's approach
    /// stops, the flex may not lift the patch) takes over in proportion as the flex's strain goes
    /// from `maxLandingStrain` to 1.5 times it (what the memory cannot store without folding the
    /// lattice is lost, as in a splat), and a slow approach (resting, set down) loses its velocity
    /// into the collider. false: every body lands inelastically (a dead thud; for comparison).
    bool elasticLanding = true;
    Real maxLandingStrain = 0.7;  ///< the flex's logarithmic strain where a landing starts to be inelastic
    /// A pinned body takes the uniform load its pins refuse through three smooth volume-keeping
    /// modes (dynamics/load_modes.hpp; docs/math.md, "A pinned body under a uniform load"): it
    /// sags under gravity. false: the notes' step alone (a uniform field does not move it).
    bool pinnedLoad = true;
    /// The load modes' largest cell strain (their amplitudes stop there): a linear mode
    /// strained further folds the lattice where it meets the twist's own strain (measured: a
    /// box held by its bottom face at stiffness 100 folded after 4 s at 0.5 and runs at 0.3;
    /// `jelly_stretch`'s attractor folded it at 0.3 and runs at 0.2).
    Real maxLoadStrain = 0.2;
    bool traceFree = true;        ///< the trace-free projection of δΓ (volume); off only for tests of eq 78
    Real volumeTolerance = 1e-5;  ///< volume projection: max_c |V/V0 − 1| after each step
    bool projectVolume = true;
    Real reconstructTolerance = 1e-6;  ///< relative residual of the displacement solve
    /// Red-black Gauss-Seidel sweeps over the reconstruction's frames after the tree integration
    /// (connectionChangeSteps; docs/math.md, "Frames that do not depend on the tree"), clear of
    /// colliders: a body keeps the tree's frames until it has been clear of every collider for
    /// `frameSweepsAfter` seconds. Frames integrated along the spanning tree alone depend on the
    /// path, and a stiff jelly grew its twist from round-off through them until it shook apart
    /// (8 voxels spinning, k = 1000/s², ζ = 2/s: Σ|δΓ|² 2e-4 at frame 480; with 4 sweeps 2e-24;
    /// the shipped jelly_cantilever, pinned, at rest: 2e-5 at frame 1440, with the sweeps ≤ 5.5e-12).
    /// 0: the tree's frames (for comparison).
    int frameSweeps = 4;
    /// Seconds clear of every collider before the frame sweeps run (a resting putty that lost its
    /// contact for a substep and switched to swept frames was kicked up: 0.19 J).
    Real frameSweepsAfter = 0.5;
    /// Problems by field name; empty when valid.
    std::vector<std::string> validate() const;
};

/// One point's twist update (eq 76, repaired; file comment), in place on dGamma.
/// @param F        the frame [x_1 x_2 x_3] now (world units per lattice step)
/// @param Fi       its inverse (rows: the duals x^a)
/// @param step     the frames' step over the last time step, F F_prev⁻¹ (1 + δt L)
/// @param hessian  ∇∇F at the point (forces.hpp convention)
/// @param gamma    Γ now (for the shape memory)
/// @return whether the limiter scaled δΓ down
bool twistUpdate(const Mat3& F, const Mat3& Fi, const Mat3& step, const std::array<Mat3, 3>& hessian,
                 const std::array<Mat3, 3>& gamma, Real dt, const DynamicsSettings& settings,
                 std::array<Mat3, 3>& dGamma);

/// The viscous step of the twist rate (docs/math.md, "Viscosity: the viscous stress at every scale"): solves (1 + α L)
/// y = δΓ for each of the 27 components, L the lattice's graph Laplacian (Σ over a point's neighbours of y_p − y_q; no
/// flux across the boundary) and α = ν δt / h², by Jacobi-preconditioned conjugate gradients to a relative residual of
/// 1e-8, in place. Σ_p δΓ_p is kept (L's columns sum to 0) and no point's |δΓ| grows past the largest before (y is a
/// weighted mean of δΓ). Deterministic.
/// @return the CG iterations taken
int viscousTwistStep(const Lattice& lat, Real alpha, std::array<std::vector<Mat3>, 3>& dGamma);

/// One contact point of the affine contact response: its rest offset X̃ about the rest centre
/// of mass, the collider's unit normal there and how deep the point is inside (> 0).
struct AffineContact {
    Vec3 rest;
    Vec3 normal;
    Real depth;
};

/// The collider's push taken by body and flex (docs/math.md, "Contact: body and flex take the
/// collider's push first"): non-negative impulses λ_k at the contact points, each changing the
/// centre by λ n and the affine part by λ n X̃ᵀ S⁻¹ (S the rest second moment per unit mass, the
/// affine model's inertia) less the part that changes det A to first order (tr(A⁻¹δA), removed
/// in the kinetic metric), until every contact point is lifted out: n·(δc + δA X̃) ≥ depth.
/// Projected Gauss-Seidel over the contacts in their order (deterministic), to 1e-3 of the
/// deepest depth or 64 sweeps. One contact at the pole X̃ = −r n of a body with S = s·1 and
/// A = 1: λ = d / (1 + 2r²/(3s)), δc = λ n, δA = −(λ r / s)(n nᵀ − 1/3) (a ball: 3/13 of the push
/// moves the centre, 10/13 squash it).
/// With viscosity the strain resists as added inertia (docs/math.md, "Viscosity: the viscous stress at every scale"):
/// the flex's metric becomes tr(δA S δAᵀ) + c |sym(δA A⁻¹)|², c = 2ν δt, so a viscous body takes more of the push into
/// its centre and less into a squash (at the pole, s → s + c in the closed form).
/// @param a              the affine part A the correction applies to (det A = 1)
/// @param secondMoment   S = ⟨X̃X̃ᵀ⟩ per unit mass
/// @param viscousMoment  c = 2ν δt (m²); 0: the kinetic metric alone
void affineContactCorrection(const std::vector<AffineContact>& contacts, const Mat3& a, const Mat3& secondMoment,
                             Vec3& dc, Mat3& dA, Real viscousMoment = 0);

/// Per-step figures (also summed into a frame's stats by the caller).
struct StepReport {
    Real kineticEnergy = 0;       ///< ½ Σ m |v|², v = (x_new − x_old)/δt, J
    Real sumDeltaGamma2 = 0;      ///< Σ_p Σ_cab (δΓ^c_ab)²
    Real maxCellVolumeError = 0;  ///< max_c |V_c/V0_c − 1| after the step
    Real totalVolumeDrift = 0;    ///< Σ V / Σ V0 − 1 after the step
    Index invertedCells = 0;      ///< cells with V <= 0
    Index contacts = 0;           ///< points in contact with a collider this step
    bool staticContact = false;   ///< some of them with a collider that is not another body
    // Contact detection against the truth (signed distance before the response; docs/gln.md):
    Index contactTruth = 0;         ///< points with φ < 0 for some collider before the response
    Index contactTruePositive = 0;  ///< of which in the contact set R
    Real maxPenetration = 0;        ///< max over points and colliders of −φ after the step (world units; 0 if none)
    Index limitedPoints = 0;        ///< points whose δΓ the limiter scaled down
    int reconstructIterations = 0;  ///< CG iterations of the displacement solve
    int volumeIterations = 0;       ///< Gauss-Newton iterations of the volume projection
    int solveIterations = 0;        ///< StepSolver::One: the solve's sweeps (cell_solve.hpp)
    bool solveConverged = true;     ///< ... and whether it reached its tolerance within its cap
    bool volumeConverged = true;
    std::string fault;                      ///< numerical trouble ("stage: what"); empty when none
    FaultKind faultKind = FaultKind::None;  ///< which trouble; None exactly when fault is empty
    // wall-clock seconds of each stage
    double forcesSeconds = 0, bodyFlexSeconds = 0, twistSeconds = 0, reconstructSeconds = 0, collideSeconds = 0,
           volumeSeconds = 0, stateSeconds = 0, totalSeconds = 0;
    // parts of reconstructSeconds: the edge transports of both connections, the frames along the
    // tree and the sweeps, and the least-squares solve (solve/reconstruct, connectionChangeSteps)
    double reconstructEdgeSeconds = 0, reconstructFrameSeconds = 0, reconstructSolveSeconds = 0;
};

/// One deformable body and its dynamic state.
class DeformableBody {
public:
    /// @param lattice   the material lattice (kept by reference: must outlive the body)
    /// @param positions #P initial world positions (usually restPositions(lattice))
    /// @param pinned    #P flags (1: the point never moves), or empty
    DeformableBody(const Lattice& lattice, std::vector<Vec3> positions, const DynamicsSettings& settings,
                   std::vector<unsigned char> pinned = {});
    ~DeformableBody();
    DeformableBody(const DeformableBody&) = delete;
    DeformableBody& operator=(const DeformableBody&) = delete;

    /// Sets the initial velocity: an affine motion v(x) = velocity + L (x − c), L in 1/s.
    void setAffineVelocity(const Vec3& velocity, const Mat3& gradient);
    /// Sets the initial velocity: a rigid motion v(x) = velocity + ω × (x − c). ω in rad/s.
    void setRigidVelocity(const Vec3& velocity, const Vec3& angularVelocity);

    /// Advances by dt seconds in the field at scene frame `frame` (the field's time at the start
    /// of the step): predict, then finish.
    StepReport step(const ForceField& field, Real frame, Real dt, const std::vector<Collider>& colliders);
    /// The step's first half: forces, body, flex, twist and the reconstruction, up to the
    /// predicted positions (no constraint applied yet). Bodies that collide with each other are
    /// all predicted first, so each meets the others where they are going (sim/simulation).
    /// A report with a fault ends the step (finish must not be called).
    StepReport predict(const ForceField& field, Real frame, Real dt);
    /// The step's second half, after predict: colliders, the volume projection, the velocities
    /// and the new state.
    StepReport finish(const std::vector<Collider>& colliders);
    /// The one-solve step (StepSolver::One) of bodies in contact with each other, solved as one
    /// system (sim/simulation): after predict, beginSolve sets up this body's part with its
    /// colliders (not the bodies solved with it); the caller solves the parts together
    /// (solveTogether, with the contacts between them), then each body's endSolve finishes its
    /// step as finish does. finish is beginSolve, a solve of the body alone, and endSolve.
    CellSolveMember beginSolve(const std::vector<Collider>& colliders);
    StepReport endSolve(const CellSolveMember& member);
    const std::vector<Vec3>& predictedPositions() const { return mXPred; }  ///< after predict
    const Vec3& predictedCentreVelocity() const { return mVcPred; }         ///< after predict
    /// Adds dv to the centre velocity and to every point's velocity over the last step (the
    /// momentum correction of bodies in contact with each other; sim/simulation).
    void shiftVelocity(const Vec3& dv);

    /// Contact detection other than "φ < 0" (sim wires the GLN network of collide/gln_network
    /// here; dynamics cannot include collide): called per collider with the positions before the
    /// response, it sets R (#P flags, cleared by the caller) to the contact set for that collider.
    /// Points in R are pushed out where φ < 0 and held by the volume projection. Empty: the
    /// signed-distance test.
    using ContactDetector =
        std::function<void(const std::vector<Vec3>& x, const Collider& collider, std::vector<unsigned char>& R)>;
    void setContactDetector(ContactDetector detector) { mDetector = std::move(detector); }

    const Lattice& lattice() const { return mLat; }
    const std::vector<Vec3>& positions() const { return mX; }
    const std::vector<Vec3>& velocities() const { return mV; }  ///< over the last step, world units/s
    const GeometricState& state() const { return mState; }
    const std::vector<unsigned char>& contact() const { return mContact; }  ///< #P, last step
    /// #P, last step: how deep each contact point was inside its collider before the response
    /// (−φ, world units; 0 where not in contact). Drives the renderer's penetration ramp.
    const std::vector<Real>& contactDepth() const { return mContactDepth; }
    const std::vector<unsigned char>& pinned() const { return mPinned; }
    const LatticeCells& cells() const { return mCells; }
    const std::vector<Real>& restVolumes() const { return mRestVolumes; }
    const std::vector<Real>& masses() const { return mMass; }
    Real totalMass() const { return mTotalMass; }
    bool anyPinned() const { return mAnyPinned; }
    /// The connection change δΓ (field[c][p](a, b)), for tests and diagnostics; settable to
    /// give a body an initial non-affine motion.
    std::array<std::vector<Mat3>, 3>& deltaGamma() { return mDGamma; }
    const std::array<std::vector<Mat3>, 3>& deltaGamma() const { return mDGamma; }
    Real lastStepLength() const { return mDtLast; }  ///< s, the last finished step's (0: none yet)
    Real freeFlight() const { return mFreeFlight; }  ///< s since the body last touched a collider
    bool halfStep() const { return mHalfStep; }      ///< centre and flex velocities are half-step ones
    const DynamicsSettings& settings() const { return mSet; }
    const Vec3& centre() const { return mC; }
    const Vec3& centreVelocity() const { return mVc; }  ///< at the last half step
    const Mat3& flex() const { return mA; }             ///< A, det 1
    const Mat3& flexVelocity() const { return mAdot; }  ///< Ȧ at the last half step
    /// Plasticity: the flex's rest stretch P (identity when off or not yielded) and the twist's
    /// rest connection Γ_p (empty when off).
    const Mat3& plasticFlex() const { return mPlasticFlex; }
    /// StepSolver::One with plasticity: each cell's rest stretch P (#C; empty otherwise).
    const std::vector<Mat3>& cellRest() const { return mCellRest; }
    const std::array<std::vector<Mat3>, 3>& plasticGamma() const { return mPlasticGamma; }
    Real gammaYield() const { return mGammaYield; }  ///< the yield of |Γ − Γ_p| per lattice step (0: off)
    /// The pinned body's load modes (empty when none) and their amplitudes q (m) and rates q̇.
    const LoadModes& loadModes() const { return mLoad; }
    const Vec3& loadAmplitude() const { return mQ; }
    const Vec3& loadRate() const { return mQdot; }
    /// Σ_p Σ_cab (δΓ^c_ab)² now.
    Real sumDeltaGamma2() const;
    /// Volume figures of the current positions.
    void volumeFigures(Real& maxCellError, Real& totalDrift, Index& inverted) const;

    /// Checkpoints (body_state.hpp, body_state.cpp): everything that changes from step to step;
    /// restoring it (sizes must fit: stateFits) continues bit-identically.
    DeformableBodyState saveState() const;
    bool stateFits(const DeformableBodyState& state) const;
    void restoreState(DeformableBodyState state);

private:
    // StepSolver::One (stepper_one.cpp).
    StepReport predictOne(const ForceField& field, Real frame, Real dt);
    StepReport finishOne(const std::vector<Collider>& colliders);
    void yieldCells();  ///< each cell's rest stretch P returned to within the yield
    /// A free body: the solve's result x put right so that the momenta the exact minimiser keeps
    /// are kept to round-off (a translation and a small turn about the centre of mass).
    void keepMomenta(const std::vector<Vec3>& inertial, std::vector<Vec3>& x) const;
    CellSolver mCellSolver;
    // Between beginSolve and endSolve: what the solve's member points at.
    std::chrono::steady_clock::time_point mSolveStart;
    std::vector<Vec3> mSolveInertial, mSolveX;
    std::vector<Vec3> mXGuess;  ///< the solve's first guess (empty: x̃)
    std::vector<Collider> mSolveColliders;
    std::vector<std::vector<Real>> mSolveAllowed;
    std::vector<Real> mSolveMargins;
    std::vector<Mat3> mCellRest;  ///< #C: each cell's rest stretch P (putty; empty when no yield)
    Real mShear = 0;              ///< μ, Pa
    // BDF2 (x̃ from the last two steps; docs/math.md, "The one-solve step"): the step before's
    // positions and velocities (empty: the next step is backward Euler), and between predict and
    // finish the extrapolated start x̂ and the step's factor β (2/3, or 1 for backward Euler).
    std::vector<Vec3> mXBefore, mVBefore;
    std::vector<Vec3> mXHat;
    Real mBeta = 1;

    // The chain step's prediction, stage by stage (predict; stepper.cpp).
    struct BodyFlexStep {
        Vec3 accel = Vec3::Zero();               ///< Σ m F / M
        Mat3 firstMoment = Mat3::Zero();         ///< Σ m F X̃ᵀ / M
        Mat3 L0 = Mat3::Zero();                  ///< the affine velocity gradient before the step
        Vec3 vcBefore = Vec3::Zero(), cNew = Vec3::Zero();
        Mat3 aNew = Mat3::Identity();
    };
    BodyFlexStep predictBodyAndFlex(const ForceSamples& fs, Real dt, StepReport& report);
    Vec3 stepLoadModes(const Vec3& accel, const Mat3& firstMoment, Real dt);
    void predictTwist(const ForceSamples& fs, const Mat3& L0, Real dt, StepReport& report);
    bool connectionFolded(const std::array<std::vector<Mat3>, 3>& gammaBar, StepReport& report) const;
    bool reconstructStep(StepReport& report);
    void applyGauge(const Vec3& cNew, const Mat3& aNew, const Vec3& dq, std::vector<Vec3>& xNew) const;
    // The chain step's stages after the prediction (finish; stepper.cpp).
    struct Responders;
    Responders findResponders(const std::vector<Collider>& colliders, const std::vector<Vec3>& x) const;
    void pushBodyAndFlex(const std::vector<Collider>& colliders, const Responders& r, const Vec3& cNew,
                         const Mat3& aNew, Real dt, std::vector<Vec3>& x);
    void respondPoints(const std::vector<Collider>& colliders, const Responders& r, const Vec3& vcBefore, Real dt,
                       std::vector<Vec3>& x);
    void projectChainVolumes(const std::vector<Collider>& colliders, const Responders& r, std::vector<Vec3>& x,
                             StepReport& report);
    void landOnColliders(const std::vector<Collider>& colliders, const std::vector<Vec3>& x, const Mat3& A1,
                         const Vec3& vcBefore, Real inelastic, bool jellyLanding);
    void carryRate(bool antiWindup, const std::array<std::vector<Mat3>, 3>& gammaOld);
    void fitAffine(const std::vector<Vec3>& x, Vec3& centre, Mat3& affine) const;
    /// The viscosity's implicit decay of the flex's strain rate over a leapfrog kick (stepper.cpp).
    void viscousFlexKick(Real kick);
    VolumeProjectionSettings volumeSettings();  ///< the volume projection's settings (body_state.cpp)

    const Lattice& mLat;
    DynamicsSettings mSet;
    LatticeCells mCells;
    std::vector<Real> mRestVolumes;
    Real mRestTotal = 0;
    std::vector<Real> mMass;
    Real mTotalMass = 0;
    std::vector<Real> mVolumeWeight;  ///< the volume projection's weights: heaviest mass / mass
    std::vector<Vec3> mRestRel;       ///< X̃: rest position about the rest centre of mass
    Mat3 mS0inv = Mat3::Identity();
    std::vector<unsigned char> mPinned;
    bool mAnyPinned = false;
    std::vector<Vec3> mPinnedPositions;

    std::vector<Vec3> mX, mV;
    GeometricState mState;
    std::array<std::vector<Vec3>, 3> mTangentPrev;
    bool mHavePrev = false;
    std::array<std::vector<Mat3>, 3> mDGamma;
    std::vector<unsigned char> mContact;
    std::vector<Real> mContactDepth;
    ContactDetector mDetector;

    Vec3 mC = Vec3::Zero(), mVc = Vec3::Zero();
    Mat3 mA = Mat3::Identity(), mAdot = Mat3::Zero();
    bool mHalfStep = false;  ///< mVc/mAdot are half-step velocities (after the first step)
    // Plasticity (DynamicsSettings::yieldStrain > 0):
    Mat3 mPlasticFlex = Mat3::Identity();            ///< P: the flex's rest shape is R P (det 1)
    std::array<std::vector<Mat3>, 3> mPlasticGamma;  ///< Γ_p per point (#P each; empty when off)
    Real mGammaYield = 0;  ///< the yield of |Γ − Γ_p| per lattice step: yieldStrain / the radius of gyration in steps
    void yieldRestShape();  ///< returns P and Γ_p to within the yield (end of finish)

    // A pinned body's load modes (DynamicsSettings::pinnedLoad): shapes, amplitudes, rates.
    LoadModes mLoad;
    Vec3 mQ = Vec3::Zero(), mQdot = Vec3::Zero();
    std::array<std::vector<Mat3>, 3> mLoadGamma;  ///< Γ of the rest shape displaced by Σ q_i w_i (work)
    Vec3 mQTarget = Vec3::Zero();                 ///< the q mLoadGamma was computed for

    std::vector<Index> mSolverFixed;  ///< the reconstruction's reference points (pins, or a centre point per component)
    std::unique_ptr<PoissonSolver> mSolver;
    std::unique_ptr<ReconstructWork> mRecWork;  ///< the solver's spanning tree and work arrays (stepper.cpp)
    std::vector<Vec3> mDisplacement;            ///< last step's twist displacement (warm start)
    std::vector<Vec3> mDisplacementPrev;        ///< the one before (the warm start extrapolates)
    std::vector<Real> mVolumeLambda;            ///< #C: the last step's volume multipliers (the next step's prediction)
    std::vector<Real> mVolumeLambdaPrev;        ///< the step's before (the prediction extrapolates)
    // Between predict and finish:
    bool mPredicted = false;
    std::vector<Vec3> mXPred;                            ///< the predicted positions
    Vec3 mCPred = Vec3::Zero(), mVcPred = Vec3::Zero();  ///< centre and its velocity after the kick
    Mat3 mAPred = Mat3::Identity();                      ///< A after the step, in SL(3)
    Real mDtPred = 0;
    Real mFreeFlight = 0;          ///< s since the body last touched a collider (frameSweeps)
    Real mDtLast = 0;              ///< the last finished step's length (0: none yet)
    void rescaleStep(Real ratio);  ///< the per-step state for a step `ratio` times as long
    StepReport mPredReport;
    VolumeProjectionCache mVolumeCache;  ///< the volume projection's multigrid, kept between steps
};

}  // namespace dgv
