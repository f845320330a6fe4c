// dgv simulate: scene -> objects -> per frame: the dynamics, stats.csv and (with --vdb) the
// VDB cache. No GL.

#include "app/commands.hpp"
#include "app/dynamics_run.hpp"
#include "app/resume.hpp"
#include "io/scene_build.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/scene_json.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>

namespace dgv::app {
namespace fs = std::filesystem;

int runSimulate(const SimulateOptions& options) {
    SceneDesc scene = loadScene(options.scene);
    if (!options.solver.empty()) overrideSolver(scene, options.solver);
    if (!scene.curves.empty())
        throw InputError(scene.path, "curves", "a curve scene has no dynamics to simulate; use 'dgv render'");
    int first = scene.frameStart, last = scene.frameEnd;
    if (!options.frames.empty()) parseFrameRange(options.frames, scene, first, last);
    if (options.frames.find('-', 1) == std::string::npos && !options.frames.empty()) first = scene.frameStart;
    if (!options.outDir.empty()) scene.output.dir = fs::absolute(options.outDir).lexically_normal().string();
    checkOutputFolder(scene.output.dir, options.outDir.empty() ? scene.path : "--out",
                      options.outDir.empty() ? "output.dir" : "");
    const bool vdb = options.vdb || scene.output.vdb;
    if (!options.mesh.empty()) scene.output.mesh = options.mesh;

    resolvePinGroups(scene);
    std::vector<BuiltObject> objects = buildObjects(scene, vdb);
    DynamicsRun dynamics(scene, objects, vdb);
    dynamics.setFirstWrittenFrame(first);
    if (!dynamics.active())
        logWarning(scene.path + ": nothing moves (no forces and no initial velocity); the frames are the rest state");
    ensureDirectory(scene.output.dir);
    removeStaleOutputTemporaries(scene.output.dir);
    logInfo("simulating frames " + std::to_string(scene.frameStart) + "-" + std::to_string(last) + " of '" +
            scene.name + "' (" +
            (dynamics.maxSubsteps() > scene.substeps
                 ? std::to_string(scene.substeps) + "-" + std::to_string(dynamics.maxSubsteps()) +
                       " substeps per frame, adaptive"
                 : std::to_string(scene.substeps) + " substeps per frame") +
            ") into " + scene.output.dir + (vdb ? " with the VDB cache" : ""));
    // State checkpoints (docs/robustness.md): --resume continues from the latest one up to the
    // last frame; --frames A-B starts from the latest one up to A (frames before it are skipped).
    int from = scene.frameStart;
    if (options.resume || first > scene.frameStart) {
        const int restored = dynamics.restoreCheckpoint(options.resume ? last : first);
        if (restored >= 0) from = restored + 1;
    }
    if (options.resume)
        logInfo("resume: " +
                (from > scene.frameStart ? "frames " + std::to_string(scene.frameStart) + "-" +
                                               std::to_string(from - 1) + " restored from the checkpoint"
                                         : std::string("no usable checkpoint")) +
                ", simulating " + std::to_string(std::max(0, last - from + 1)) + " frames");
    Progress progress("simulate", last - from + 1, "frames");
    for (int frame = from; frame <= last; ++frame) {
        if (cancelRequested()) {
            progress.finish();
            std::fprintf(stderr, "dgv: interrupted before frame %d; the files written are complete\n", frame);
            return kExitInterrupted;
        }
        dynamics.advanceTo(frame);
        const FrameStats& s = dynamics.lastStats();
        char line[160];
        std::snprintf(line, sizeof line, "frame %d: max cell volume error %.2e, drift %.2e, %d substeps, %.1f ms/step",
                      frame, s.maxCellVolumeError, s.totalVolumeDrift, s.substeps, s.stepMs);
        progress.step(line);
    }
    progress.finish();
    const std::string glb = dynamics.finishCaches();
    logInfo("wrote " + (fs::path(scene.output.dir) / "stats.csv").string() +
            (vdb ? " and " + (fs::path(scene.output.dir) / "vdb").string() + "/" + scene.name + ".####.vdb" : "") +
            (scene.output.mesh.empty()
                 ? ""
                 : " and " + (fs::path(scene.output.dir) / "mesh").string() + "/<object>.####." +
                       meshCacheExtension(meshCacheFormatFromName(scene.output.mesh, "output.mesh"))) +
            (glb.empty() ? "" : " and " + glb));
    return kExitOk;
}

}  // namespace dgv::app
