#pragma once
// A scene's dynamics as the render and simulate commands drive it: the Simulation of the
// scene's built objects, advanced frame by frame, with out/<scene>/stats.csv rewritten (atomically)
// after every frame and, when the scene asks for them, the frame's VDB and mesh caches.

#include "io/scene_build.hpp"
#include "io/mesh_cache.hpp"
#include "io/stats_csv.hpp"
#include "view/contact_highlight.hpp"
#include "sim/simulation.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace dgv::app {

/// Parses "A-B" or "N" (--frames) and checks it lies within the scene's frame range.
void parseFrameRange(const std::string& text, const SceneDesc& scene, int& first, int& last);

/// --solver: sets every object's material.solver ("chain" or "one"; CLI11 checked the word).
void overrideSolver(SceneDesc& scene, const std::string& solver);

class DynamicsRun {
public:
    /// @param writeVdb  write out/<scene>/vdb/<scene>.####.vdb per frame (builds the bodies even
    ///                  when nothing moves)
    DynamicsRun(const SceneDesc& scene, const std::vector<BuiltObject>& objects, bool writeVdb = false);
    ~DynamicsRun();

    /// Simulates up to `frame` (frames.start: the initial state), writing each new frame's
    /// stats row and VDB file. Frames must not go backwards.
    void advanceTo(int frame);
    /// State checkpoints (docs/robustness.md, "State checkpoints"); a moving scene writes one after
    /// each simulated frame after frames.start. restoreCheckpoint continues the simulation from the
    /// latest usable checkpoint of a frame in (last frame recorded, `frame`] and rewrites stats.csv
    /// from it: returns that frame, or -1 (nothing changed) when there is none. A checkpoint of
    /// another scene, lattice or dgv version, or a truncated or corrupt one, is skipped with a
    /// warning; with the VDB cache on, so is one whose frames' VDB files are not all on disk.
    int restoreCheckpoint(int frame);
    /// The last frame simulated or restored (-1: none yet).
    int done() const { return mDone; }
    /// The moving body of object i, or nullptr (render it at rest).
    const DeformableBody* body(std::size_t i) const;
    /// The embedding of object i's surface in its body's lattice now (the object's own until goo
    /// is re-parametrised: sim/simulation).
    const MeshEmbedding& embedding(std::size_t i) const;
    /// Object i's surface at rest on that lattice (its triangles change when goo is remapped).
    const TriangleMesh& surfaceMesh(std::size_t i) const;
    /// Object i's surface as the frames, the mesh cache and the VDB surface show it now (a moving
    /// body's lifted out of the static colliders: Simulation::drawnSurface), on surfaceMesh(i)'s
    /// triangles; the rest mesh for an object that does not move.
    void drawnSurface(std::size_t i, std::vector<Vec3>& vertices) const;
    bool active() const { return mSim->active(); }
    /// The most substeps a frame takes (Simulation::maxSubsteps).
    int maxSubsteps() const { return mSim->maxSubsteps(); }
    /// VDB frames before `frame` are simulated but not written (--frames A-B).
    void setFirstWrittenFrame(int frame) { mFirstWritten = frame; }
    /// A farm render task (app/cmd_farm.cpp): the state checkpoints are read, never written, and
    /// neither are stats.csv and the VDB and mesh caches, which the shot's simulation job owns; so
    /// tasks sharing one output folder never write the same file.
    void setReadOnly(bool readOnly) { mReadOnly = readOnly; }
    /// After the last frame of a run: with `output.mesh: "gltf"`, assembles the mesh cache's PLY
    /// frames (from the first written through done()) into <out>/mesh/<name>.glb (io/gltf_cache).
    /// Returns its path, or "" when the run writes none (another format, a farm render task).
    std::string finishCaches();
    const FrameStats& lastStats() const { return mLast; }
    /// Motion blur (render.motion_blur): from now on, each simulated frame keeps every moving
    /// object's deformed surface at its start and after each substep that the shutter (open over
    /// the last `shutterFrames` of the frame) or its neighbour needs.
    void recordMotion(Real shutterFrames);
    /// Object i's surface at frame time t ∈ [frame − 1, frame] of the frame just simulated, linear
    /// between the substeps either side (held before the first one kept). False, and nothing
    /// written, where there is none: the object does not move, or `frame` was restored from a
    /// checkpoint or is the first (draw the surface as it is).
    bool surfaceAt(std::size_t i, int frame, Real t, std::vector<Vec3>& vertices) const;
    /// Object i's per-point history of the contact set R (frames since each point was last in
    /// R), updated on every simulated frame; empty for objects that do not move.
    const ContactHistory& contactHistory(std::size_t i) const { return mContactHistory[i]; }

private:
    void record(const FrameStats& s);
    void writeVdb(int frame);
    void writeMeshes(int frame);
    void writeCheckpoint(int frame);
    void writeStats();
    std::filesystem::path gltfPath() const;

    const SceneDesc& mScene;
    const std::vector<BuiltObject>& mObjects;
    bool mVdb = false;
    bool mReadOnly = false;                         ///< setReadOnly: nothing but the frames is written
    MeshCacheFormat mMesh = MeshCacheFormat::None;  ///< output.mesh (io/mesh_cache.hpp)
    std::unique_ptr<Simulation> mSim;
    int mDone = -1;         ///< last frame recorded
    int mFirstWritten = 0;  ///< VDB frames before this one are simulated, not written
    StatsCsv mStats;
    FrameStats mLast;
    std::uint64_t mSceneKey = 0;  ///< what checkpoints must match (io/state_file.hpp)
    std::string mFrameKey;        ///< the VDB and mesh cache files' key (io/state_file.hpp, sceneFrameKey)
    std::vector<ContactHistory> mContactHistory;  ///< per object
    bool mMeshWritten = false;                    ///< a mesh frame was written by this run
    /// recordMotion: the surfaces of the frame mMotionFrame at frame times, ascending.
    struct MotionSample {
        Real time = 0;
        std::vector<std::vector<Vec3>> surfaces;  ///< per object; empty for one that does not move
    };
    Real mShutterFrames = 0;
    int mMotionFrame = -1;
    std::vector<MotionSample> mMotion;
};

}  // namespace dgv::app
