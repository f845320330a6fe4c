#pragma once
/// @file simulation.hpp
/// @brief The frame loop of a scene's dynamics: one DeformableBody per deformable object, the
/// scene's force field and colliders, `substeps` steps per frame, and each frame's figures
/// (the columns of out/<scene>/stats.csv).
///
/// Time: frame f's state is the state after (f − frames.start) frames of simulation; the field
/// is evaluated at the fractional frame at the start of each substep. δt = 1/(fps · substeps).

#include "base/types.hpp"
#include "collide/mesh_distance.hpp"
#include "collide/sampled_distance.hpp"
#include "dynamics/forces.hpp"
#include "dynamics/reparametrise.hpp"
#include "dynamics/stepper.hpp"
#include "geom/embedding.hpp"
#include "geom/lattice.hpp"
#include "geom/sdf_grid.hpp"
#include "geom/surface_check.hpp"
#include "geom/triangle_mesh.hpp"
#include "sim/scene.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace dgv {

/// One frame's figures, over all bodies (stats.csv; docs/math.md, "Never a torn frame" for the
/// surface check).
struct FrameStats {
    int frame = 0;
    Real time = 0;                ///< seconds since frames.start
    Real kineticEnergy = 0;       ///< J, at the end of the frame
    Real sumDeltaGamma2 = 0;      ///< Σ |δΓ|², at the end of the frame
    Real maxCellVolumeError = 0;  ///< max over bodies, cells and the frame's substeps
    Real totalVolumeDrift = 0;    ///< Σ V / Σ V0 − 1 over all bodies, end of the frame
    Index invertedCells = 0;      ///< max over the substeps
    Index contacts = 0;           ///< points in contact, end of the frame
    Index limitedPoints = 0;      ///< summed over the substeps
    double stepMs = 0;            ///< mean wall-clock time of one substep (all bodies), ms
    // Contacts against the truth (signed distance < 0 before the response; docs/gln.md):
    Real maxPenetration = 0;        ///< voxels: max over substeps, bodies, points of −φ/h after the step
                                    ///< (between bodies: at the end of the frame)
    Index contactSetSize = 0;       ///< Σ over substeps and bodies of |R|
    Index contactTruth = 0;         ///< Σ of |{φ < 0}|
    Index contactTruePositive = 0;  ///< Σ of |R ∩ {φ < 0}|
    /// |R ∩ T| / |R| and |R ∩ T| / |T| over the frame's substeps; NaN when the set is empty.
    Real contactPrecision() const;
    Real contactRecall() const;
    StepReport lastStep;  ///< the last substep's report of the first body (stage times)
    int substeps = 0;     ///< the substeps the frame was simulated at (0: not simulated)
    /// The embedded surfaces' check at the end of the frame (geom/surface_check), summed over
    /// the bodies with a surface: a frame where a body's surface fails it is never returned by
    /// advanceTo (folds on a few triangles pass: SurfaceCheck::ok).
    Index flippedTriangles = 0;
    Index tornEdges = 0;
    Real surfaceStretch = 0;  ///< worst edge stretch against its frames' (torn past kTearRatio)
    /// Bodies re-voxelised in their current shape at the frame's start (docs/math.md,
    /// "Re-parametrisation").
    Index reparametrisations = 0;
    /// StepSolver::One: the most iterations a substep's solve took over the frame's substeps and
    /// bodies, and how many of those solves stopped at the iteration cap (0 with the chain).
    int solveIterations = 0;
    Index solveUnconverged = 0;
};

class GlnNetwork;

class Simulation {
public:
    /// @param scene      the validated scene (forces, colliders, objects' materials)
    /// @param lattices   one per scene object, nullptr for objects that do not move (kept by
    ///                   reference: must outlive the simulation)
    /// Throws InputError for an impossible setting (e.g. a pin that holds no point is allowed,
    /// but a collider mesh that is not supported is not).
    /// @param always     build the bodies even when nothing moves (a VDB cache of a still scene)
    Simulation(const SceneDesc& scene, const std::vector<const Lattice*>& lattices, bool always = false);
    ~Simulation();

    /// Whether anything moves: some object is deformable and the scene has forces or an
    /// initial velocity.
    bool active() const { return mActive; }
    /// The most substeps a frame takes: the scene's max_substeps, raised to what the stiffest
    /// body needs when the scene does not set it (fitSubsteps).
    int maxSubsteps() const { return mMostSubsteps; }
    /// Simulates frame `frame` (must be the frame after the last one; the first call's frame
    /// must be frames.start + 1) at frameSubsteps() substeps. A frame that faults or whose
    /// surface fails the check (setSurface) is simulated again from the frame's start at twice
    /// the substeps, up to kRetrySubstepFactor × max_substeps (not when the count is fixed,
    /// max_substeps = substeps; docs/math.md, "Never a torn
    /// frame"). Throws NumericalError naming the frame, substep, object and fault when that still
    /// fails (the lattice folds, the affine part inverts, a position becomes non-finite, the
    /// surface flips or tears); the state is then the frame's start.
    FrameStats advanceTo(int frame);
    /// Called at a simulated frame's start (substep 0) and after each of its substeps k (1 ..
    /// substeps), with the bodies' states as the step left them; a frame simulated again starts
    /// again at 0. What motion blur samples between frames (app/dynamics_run).
    using SubstepObserver = std::function<void(int frame, int substep, int substeps)>;
    void setSubstepObserver(SubstepObserver observer) { mSubstepObserver = std::move(observer); }
    /// How far past max_substeps a failed frame is retried.
    static constexpr int kRetrySubstepFactor = 2;
    /// The surface object i renders: its rest mesh and embedding (kept by reference: must
    /// outlive the simulation), checked at the end of every frame.
    void setSurface(std::size_t object, const TriangleMesh* restMesh, const MeshEmbedding* embedding);
    /// Figures of the current state without stepping (for frames.start).
    FrameStats currentStats(int frame) const;

    int frame() const { return mFrame; }
    /// State checkpoints (docs/robustness.md): one entry per scene object, `present` false for
    /// objects without a body. restoreState makes `frame` the current frame; the states must fit
    /// the bodies (stateFits), which the caller checks first.
    struct ObjectState {
        bool present = false;
        DeformableBodyState body;
        /// The body's lattice when it has been re-parametrised (remaps > 0), and its surface's
        /// rest vertices on it (empty without a surface): the state lives on that lattice.
        int remaps = 0;
        Vec3 latticeOrigin = Vec3::Zero();
        Real latticeSpacing = 0;
        Vec3i latticeDims = Vec3i::Zero();
        std::vector<Vec3i> latticeCoords;
        std::vector<Vec3> surfaceVertices;
        std::vector<std::array<int, 3>> surfaceTriangles;
    };
    std::vector<ObjectState> saveState() const;
    bool stateFits(const std::vector<ObjectState>& states) const;
    void restoreState(int frame, std::vector<ObjectState> states);
    /// The body of scene object i, or nullptr.
    const DeformableBody* body(std::size_t object) const;
    /// The surface object i renders now, on its body's lattice: the rest mesh and embedding set
    /// by setSurface until the body is re-parametrised, then the surface as it was at the last
    /// remap, embedded in the new lattice (nullptr: no surface).
    const TriangleMesh* surfaceMesh(std::size_t object) const;
    /// Object `object`'s surface as drawn and cached: its embedded vertices in the body's state,
    /// each one inside a static collider moved out onto that collider's surface (docs/math.md,
    /// "The drawn surface stays out of the colliders"). Empty without a body or a surface.
    void drawnSurface(std::size_t object, std::vector<Vec3>& vertices) const;
    const MeshEmbedding* surfaceEmbedding(std::size_t object) const;
    /// How often object i's body has been re-voxelised in its current shape (docs/math.md,
    /// "Re-parametrisation"). Goo (no stiffness, no pins) is, when its lattice distorts past
    /// `reparametriseBound()`; other bodies never are.
    int reparametrisations(std::size_t object) const;
    const ReparametriseBound& reparametriseBound() const { return mRemapBound; }
    void setReparametriseBound(const ReparametriseBound& b) { mRemapBound = b; }

    /// Turns a closed triangle mesh into a signed-distance grid (world units, negative inside)
    /// of voxel `voxelSize`, exact `bandVoxels` voxels out and filled inside: the app passes
    /// io's meshLevelSet (the core has no OpenVDB). Used for a re-parametrised body's surface
    /// (volumeSurface); contact between objects needs no callback (collide/mesh_distance,
    /// collide/sampled_distance).
    using SurfaceDistance = std::function<SdfGrid(const TriangleMesh& mesh, Real voxelSize, int bandVoxels)>;
    void setSurfaceDistance(SurfaceDistance f) { mSurfaceDistance = std::move(f); }
    /// Meshes the zero isosurface of a signed-distance grid: the app passes io's levelSetMesh.
    /// With it and the surface distance set, a re-parametrised body's surface is taken from its
    /// volume at each remap (volumeSurface) instead of carrying the old mesh on.
    using LevelSetMesher = std::function<TriangleMesh(const SdfGrid& grid)>;
    void setLevelSetMesher(LevelSetMesher f) { mLevelSetMesher = std::move(f); }
    /// The surface of body i's material from its volume (docs/math.md, "The surface from the
    /// volume"): the deformed lattice's outer cell faces as a level set on its spacing, moved
    /// out by the half voxel the material reaches beyond its lattice points, meshed and smoothed.
    /// Empty without the two callbacks.
    TriangleMesh volumeSurface(std::size_t i) const;
    /// Objects that collide with each other (collision.objects) must not start inside each
    /// other: throws InputError naming the scene, both objects and the overlap depth when some
    /// lattice point of one lies more than kStartOverlapVoxels of its voxels inside the other's
    /// contact margin (docs/math.md, "Overlapping starts"). Call before anything is written.
    void checkStartOverlap() const;
    static constexpr Real kStartOverlapVoxels = 1;

private:
    /// Raises mMostSubsteps, the scene's, to what the stiffest chain-step body's shape
    /// memory needs when the scene leaves max_substeps unset; InputError naming the key to
    /// change when the most accepted (or the scene's max_substeps) is too few.
    void fitSubsteps();
    /// Frame `frame` at `sub` substeps.
    FrameStats simulateFrame(int frame, int sub);
    /// The substeps of the next frame: adaptive between substeps and max_substeps (simulation.cpp).
    int frameSubsteps(int frame) const;
    /// The colliders each body meets this substep: the scene's, then the surfaces of the other
    /// bodies near it, built from their predicted positions (after every body's predict).
    std::vector<std::vector<Collider>> substepColliders() const;
    /// Calls f(i, j, margin, distance) for each ordered pair of bodies close enough to touch at
    /// the predicted (or current) positions, with the signed distance of j's lattice surface
    /// there (built once per j) and the margin i's points keep from it.
    struct PairSurface {
        std::shared_ptr<const MeshDistance> exact;       ///< collision.distance "exact"
        std::shared_ptr<const SampledDistance> sampled;  ///< collision.distance "grid"
        Real beyond = 0;  ///< exact: farther than this from the surface's box, the box's distance
        Real distance(const Vec3& x, Vec3* gradient = nullptr) const;
    };
    using PairFn = std::function<void(std::size_t i, std::size_t j, Real margin,
                                      const std::shared_ptr<const PairSurface>& distance)>;
    void forClosePairs(bool predicted, const PairFn& f) const;
    /// Objects collide: collision.objects and at least two bodies.
    bool objectContact() const;
    /// Max over bodies and points of how deep (voxels of the point's body) a point is inside
    /// another body's surface less the margin, at the current positions.
    Real objectPenetration() const;
    /// After every body's finish: a group of bodies touching only each other keeps its momentum
    /// (one velocity shift for the whole group; simulation.cpp).
    /// Per body, the one-solve bodies solved with it this substep (itself included; empty for
    /// a body of the chain): those joined by object colliders, transitively.
    std::vector<std::vector<std::size_t>> solveGroups(const std::vector<std::vector<Collider>>& colliders) const;
    /// Finishes the substep of a group's bodies with one solve (reports[i], done[i] = 1 each).
    void solveGroup(const std::vector<std::size_t>& group, const std::vector<std::vector<Collider>>& colliders,
                    std::vector<StepReport>& reports, std::vector<unsigned char>& done);
    void keepPairMomentum(const std::vector<std::vector<Collider>>& colliders,
                          const std::vector<unsigned char>& staticContact);
    /// The surfaces' check of the current state: its figures summed over the bodies with a
    /// surface into s; whether every surface passed, the first failing object's index in *failed
    /// (or -1) and its own figures in *failedCheck.
    bool checkSurfaces(FrameStats& s, int* failed, SurfaceCheck* failedCheck) const;
    /// What a fault of body i should add to say how to avoid it (empty: nothing known).
    std::string faultHint(std::size_t i) const;
    struct Surface {
        const TriangleMesh* mesh = nullptr;
        const MeshEmbedding* embedding = nullptr;
        SurfaceCheckSetup setup;
    };
    std::vector<Surface> mSurfaces;     ///< per object: what is checked and rendered now
    std::vector<Surface> mOwnSurfaces;  ///< per object: setSurface's, on the object's own lattice
    /// A re-parametrised object: its lattice and its surface on it.
    struct Remapped {
        int count = 0;
        std::unique_ptr<Lattice> lattice;
        TriangleMesh mesh;
        MeshEmbedding embedding;
    };
    std::vector<Remapped> mRemapped;           ///< per object (count 0: on its own lattice)
    std::vector<const Lattice*> mLattices;     ///< per object: its own lattice
    std::vector<unsigned char> mRemapAllowed;  ///< per object: goo or putty without pins (material.reparametrise)
    std::vector<std::string> mRemapRefused;    ///< per object: the last refusal logged
    ReparametriseBound mRemapBound;
    /// Re-voxelises the bodies whose lattices passed the bound; returns how many.
    Index reparametriseDistorted(int frame);
    /// Re-voxelises body i (`why` goes into the log line); false (logged once) when refused.
    bool reparametriseBody(std::size_t i, int frame, const std::string& why);
    int mFaultBody = -1;  ///< the body the last NumericalError of simulateFrame names
    /// Puts body i on `lattice` with `state` (remaps > 0) or back on its own lattice (remaps 0),
    /// with `surface` (its rest shape on the new lattice) as what it renders.
    void installLattice(std::size_t i, Lattice lattice, DeformableBodyState state, TriangleMesh surface, int remaps);
    /// Whether state o lives on body i's lattice now (else restoring it builds the body again).
    bool onCurrentLattice(std::size_t i, const ObjectState& o) const;
    /// Object i's GLN contact detector on its body's current lattice (collision.detect = gln).
    void attachNetwork(std::size_t i);
    bool mGlnDetect = false;
    SurfaceDistance mSurfaceDistance;
    LevelSetMesher mLevelSetMesher;
    bool mObjectContact = false;  ///< collision.objects and at least two bodies
    const SceneDesc& mScene;
    int mMostSubsteps = 1;  ///< the most substeps a frame takes (maxSubsteps())
    SubstepObserver mSubstepObserver;
    ForceField mField;
    std::vector<Collider> mColliders;
    std::vector<std::unique_ptr<DeformableBody>> mBodies;  ///< per object (null: static)
    std::vector<std::unique_ptr<GlnNetwork>> mNetworks;    ///< per object, collision.detect = gln
    bool mActive = false;
    int mFrame = 0;
};

}  // namespace dgv
