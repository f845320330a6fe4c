#pragma once
/// @file simulation.hpp
/// @brief The frame loop of a scene's dynamics: one DeformableBody per deformable object, the
/// scene's force field and colliders, `substeps` steps per frame, and each frame's figures
/// (the columns of out/<scene>/stats.csv).
///
/// Time: frame f's state is the state after (f − frames.start) frames of simulation; the field
/// is evaluated at the fractional frame at the start of each substep. δt = 1/(fps · substeps).

#include "base/types.hpp"
#include "dynamics/forces.hpp"
#include "dynamics/stepper.hpp"
#include "geom/lattice.hpp"
#include "geom/sdf_grid.hpp"
#include "geom/triangle_mesh.hpp"
#include "sim/scene.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace dgv {

/// One frame's figures, over all bodies (stats.csv; docs/dynamics.md).
struct FrameStats {
    int frame = 0;
    Real time = 0;                 ///< seconds since frames.start
    Real kineticEnergy = 0;        ///< J, at the end of the frame
    Real sumDeltaGamma2 = 0;       ///< Σ |δΓ|², at the end of the frame
    Real maxCellVolumeError = 0;   ///< max over bodies, cells and the frame's substeps
    Real totalVolumeDrift = 0;     ///< Σ V / Σ V0 − 1 over all bodies, end of the frame
    Index invertedCells = 0;       ///< max over the substeps
    Index contacts = 0;            ///< points in contact, end of the frame
    Index limitedPoints = 0;       ///< summed over the substeps
    double stepMs = 0;             ///< mean wall-clock time of one substep (all bodies), ms
    // Contacts against the truth (signed distance < 0 before the response; docs/gln.md):
    Real maxPenetration = 0;       ///< voxels: max over substeps, bodies, points of −φ/h after the step
                                   ///< (between bodies: at the end of the frame)
    Index contactSetSize = 0;      ///< Σ over substeps and bodies of |R|
    Index contactTruth = 0;        ///< Σ of |{φ < 0}|
    Index contactTruePositive = 0; ///< Σ of |R ∩ {φ < 0}|
    /// |R ∩ T| / |R| and |R ∩ T| / |T| over the frame's substeps; NaN when the set is empty.
    Real contactPrecision() const;
    Real contactRecall() const;
    StepReport lastStep;           ///< the last substep's report of the first body (stage times)
    int substeps = 0;              ///< the substeps the frame was simulated at (0: not simulated)
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
    /// Simulates frame `frame` (must be the frame after the last one; the first call's frame
    /// must be frames.start + 1) at frameSubsteps() substeps. Throws RuntimeError naming the
    /// frame, substep, object and fault on numerical trouble (the lattice folds, the affine part
    /// inverts, a position becomes non-finite).
    FrameStats advanceTo(int frame);
    /// Figures of the current state without stepping (for frames.start).
    FrameStats currentStats(int frame) const;

    int frame() const { return mFrame; }
    /// State checkpoints (docs/robustness.md): one entry per scene object, `present` false for
    /// objects without a body. restoreState makes `frame` the current frame; the states must fit
    /// the bodies (stateFits), which the caller checks first.
    struct ObjectState {
        bool present = false;
        DeformableBodyState body;
    };
    std::vector<ObjectState> saveState() const;
    bool stateFits(const std::vector<ObjectState>& states) const;
    void restoreState(int frame, std::vector<ObjectState> states);
    /// The body of scene object i, or nullptr.
    const DeformableBody* body(std::size_t object) const;

    /// Turns a closed triangle mesh into a signed-distance grid (world units, negative inside)
    /// of voxel `voxelSize`, exact `bandVoxels` voxels out and filled inside: the app passes
    /// io's meshLevelSet (the core has no OpenVDB). Objects collide with each other
    /// (collision.objects) only when it is set.
    using SurfaceDistance = std::function<SdfGrid(const TriangleMesh& mesh, Real voxelSize, int bandVoxels)>;
    void setSurfaceDistance(SurfaceDistance f) { mSurfaceDistance = std::move(f); }

private:
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
    using PairFn = std::function<void(std::size_t i, std::size_t j, Real margin,
                                      const std::shared_ptr<const SdfGrid>& distance)>;
    void forClosePairs(bool predicted, const PairFn& f) const;
    /// Max over bodies and points of how deep (voxels of the point's body) a point is inside
    /// another body's surface less the margin, at the current positions.
    Real objectPenetration() const;
    /// After every body's finish: a group of bodies touching only each other keeps its momentum
    /// (one velocity shift for the whole group; simulation.cpp).
    void keepPairMomentum(const std::vector<std::vector<Collider>>& colliders,
                          const std::vector<unsigned char>& staticContact);
    SurfaceDistance mSurfaceDistance;
    bool mObjectContact = false;  ///< collision.objects and at least two bodies
    const SceneDesc& mScene;
    ForceField mField;
    std::vector<Collider> mColliders;
    std::vector<std::unique_ptr<DeformableBody>> mBodies;  ///< per object (null: static)
    std::vector<std::unique_ptr<GlnNetwork>> mNetworks;     ///< per object, collision.detect = gln
    bool mActive = false;
    int mFrame = 0;
};

/// stats.csv's header line (no newline) and one frame's row.
std::string statsCsvHeader();
std::string statsCsvRow(const FrameStats& s);

}  // namespace dgv
