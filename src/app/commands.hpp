#pragma once
// The subcommands of `dgv`. Each returns the process exit code (base/errors.hpp: 0 ok,
// 1 run-time failure, 2 bad input or usage, 130 interrupted); bad input is thrown as
// InputError and turned into one line and exit 2 by main.

#include <string>
#include <vector>

namespace dgv::app {

struct RenderOptions {
    std::string scene;               ///< scene file
    std::string frames;              ///< "A-B" or "N"; empty: the scene's range
    std::string outDir;              ///< empty: the scene's output.dir
    int width = 0, height = 0;       ///< 0: the scene's
    std::string resolution;          ///< "WxH" (overrides width/height); empty: the scene's
    std::string solver;              ///< "chain" or "one": every object's material.solver; empty: the scene's
    std::string glBackend = "auto";  ///< auto | egl | osmesa
    std::string format;              ///< png | exr: the frames' files (render.format); empty: the scene's
    std::string motionBlur;          ///< on | off: render.motion_blur; empty: the scene's
    bool contactSheet = false;       ///< also <out>/<name>.contact.png: the frames in a grid
    bool movie = false;              ///< also <out>/<name>.mp4 through ffmpeg (must be on PATH)
    bool resume = false;             ///< skip frames whose PNG is already complete (app/resume.hpp)
    std::string mesh;                ///< --mesh ply|obj: the mesh cache (overrides output.mesh)
    bool farmTask = false;           ///< one task of a farm shot: reads the state checkpoints, writes only its frames
};
int runRender(const RenderOptions& options);

struct SimulateOptions {
    std::string scene;
    std::string frames;  ///< "A-B" or "N"; empty: the scene's range
    std::string outDir;
    bool vdb = false;
    bool resume = false;  ///< continue from the last valid state checkpoint (docs/robustness.md)
    std::string mesh;     ///< --mesh ply|obj: the mesh cache (overrides output.mesh)
    std::string solver;   ///< --solver chain|one: every object's material.solver; empty: the scene's
};
int runSimulate(const SimulateOptions& options);

struct InfoOptions {
    std::string mesh;
    std::string meshName;
    double voxelSize = 0;
    int resolution = 0;
};
int runInfo(const InfoOptions& options);

struct ImgdiffOptions {
    std::string reference, candidate;
    double threshold = 4, maxFraction = 0.005, hard = -1;
    std::string diffDir;  ///< where .new.png and .diff.png go on failure; empty: none
};
int runImgdiff(const ImgdiffOptions& options);

struct GlnOptions {
    std::string curveA, curveB;    ///< curve files: one "x y z" vertex per line, '#' comments
    std::string method = "exact";  ///< exact | seed
    double tolerance = 1.0;        ///< seed method's sampling tolerance (eqs 84-89)
};
int runGln(const GlnOptions& options);

struct BenchCommandOptions {
    std::vector<std::string> names;
    int repeats = 3;
    bool quick = false;
};
int runBench(const BenchCommandOptions& options);

struct FarmOptions {
    std::string action;     ///< submit | status | resubmit
    std::string scene;      ///< submit: the scene file
    std::string dir;        ///< submit: --out (default: the scene's output.dir); status, resubmit: the shot's folder
    int chunk = 0;          ///< submit: frames per render task
    std::string partition;  ///< submit: Slurm partition; empty: the cluster's default
    bool dryRun = false;    ///< print the scripts, write and submit nothing
    bool contactSheet = false, movie = false;  ///< the check job also writes these
    bool vdb = false;                          ///< the simulation job also writes the VDB cache
    std::string mesh;                          ///< the simulation job also writes the mesh cache: ply | obj
    bool check = false;                        ///< status: exit 1 unless every frame is complete
};
int runFarm(const FarmOptions& options);

/// The default scene: scenes/default.json under the working directory, else in the source
/// tree dgv was built from, else <exe dir>/../share/dgv/scenes.
std::string defaultScenePath();

}  // namespace dgv::app
