// dgv: the command line. Parses arguments (CLI11), sets up threads, progress and signals, runs
// one subcommand, and turns the two kinds of user-facing failure into one line and an exit code.

#include <optional>
#include "app/commands.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

/// Seconds a run has, after SIGINT/SIGTERM, to reach a cancellation point and exit by itself.
/// Code that never polls for cancellation (a library call such as an import that does not
/// return) is ended when it runs out; the frames already written stay complete either way.
constexpr unsigned kCancelGraceSeconds = 10;

/// The forced exit: only async-signal-safe calls.
[[noreturn]] void exitNow() {
    dgv::removePendingTemporaries();
    static const char kMessage[] = "dgv: interrupted; the files already written are complete\n";
    const ssize_t ignored = write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
    (void)ignored;
    _exit(dgv::kExitInterrupted);
}

extern "C" void onAlarm(int) { exitNow(); }

/// The first SIGINT/SIGTERM/SIGHUP asks the run to stop after its current step and starts the grace
/// timer; a second one ends the process at once.
extern "C" void onSignal(int) {
    static volatile std::sig_atomic_t received = 0;
    if (received) exitNow();
    received = 1;
    dgv::requestCancel();
    dgv::removePendingTemporaries();
    alarm(kCancelGraceSeconds);
}

/// SIGINT, SIGTERM and SIGHUP stop a run (onSignal); a closed pipe on stdout or stderr (`dgv
/// render x.json 2>&1 | head -1`) must not kill it: its writes then fail with EPIPE, and the
/// frames go on being written.
/// A parent that blocked these signals (the mask survives exec) would hold them pending for the
/// whole run: they are unblocked here, so one sent before dgv's own code ran is taken now.
void installSignalHandlers(int, char**, char**) {
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);
    std::signal(SIGHUP, onSignal);  // a farm's or a closed terminal's hang-up stops like SIGTERM
    std::signal(SIGALRM, onAlarm);
    std::signal(SIGPIPE, SIG_IGN);
    sigset_t stops;
    sigemptyset(&stops);
    for (int s : {SIGINT, SIGTERM, SIGHUP, SIGALRM}) sigaddset(&stops, s);
    sigprocmask(SIG_UNBLOCK, &stops, nullptr);
}

/// The handlers are installed from the executable's pre-initialisation array, which the dynamic
/// loader runs before any shared library's constructor: the first of dgv's own code to run.
/// Before it the loader relocates the libraries (about 90 ms, mostly libLLVM, which libOSMesa
/// pulls in; measured with perf), when a signal would have its default action: the launcher
/// (app/launcher.cpp, the `dgv` users run) holds the signals blocked across it.
__attribute__((section(".preinit_array"), used)) void (*const kInstallSignalHandlers)(int, char**, char**) =
    installSignalHandlers;

/// The line and exit code of a run stopped by a signal.
int interrupted() {
    std::fprintf(stderr, "dgv: interrupted; the files already written are complete\n");
    return dgv::kExitInterrupted;
}

/// A finite number > 0 (CLI::PositiveNumber prints DBL_MAX as its upper bound on failure).
const CLI::Validator kPositive(
    [](std::string& text) -> std::string {
        try {
            std::size_t pos = 0;
            const double v = std::stod(text, &pos);
            if (pos == text.size() && std::isfinite(v) && v > 0) return "";
        } catch (const std::logic_error&) {
        }
        return "expected a positive number, got " + text;
    },
    "POSITIVE");

/// An error message as one printable line: control characters (a newline in a JSON key, bytes
/// of a binary file echoed by a parser) become \xNN, so the error stays one line.
std::string oneLine(const char* message) {
    std::string out;
    for (const char* p = message; *p; ++p) {
        const unsigned char c = static_cast<unsigned char>(*p);
        if (c < 0x20 || c == 0x7f) {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", c);
            out += hex;
        } else {
            out += *p;
        }
    }
    return out;
}

/// Edit distance between a and b (insertions, deletions, substitutions and swaps of neighbours,
/// each 1): "rendr" is 1 from "render", "ifno" 1 from "info".
std::size_t editDistance(const std::string& a, const std::string& b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i)
        for (std::size_t j = 1; j <= b.size(); ++j) {
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1])});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    return d[a.size()][b.size()];
}

/// The first word on the command line that is neither an option nor a global option's value,
/// when it names no subcommand: the command the user mistyped; empty otherwise.
std::string unknownCommand(CLI::App& cli, int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg.size() > 1 && arg[0] == '-') {
            const CLI::Option* opt = cli.get_option_no_throw(arg);
            if (opt && opt->get_items_expected_min() > 0) ++i;  // "--threads 2", not "--threads=2"
            continue;
        }
        return cli.get_subcommands([&](CLI::App* sub) { return sub->check_name(arg); }).empty() ? arg : "";
    }
    return "";
}

/// "unknown command 'rendr' (did you mean 'render'?)", or the list of commands when none is
/// close: within a third of the command's length (at least 1).
std::string unknownCommandMessage(CLI::App& cli, const std::string& word) {
    std::string best, all;
    std::size_t bestDistance = std::string::npos;
    for (const CLI::App* sub : cli.get_subcommands([](CLI::App*) { return true; })) {
        const std::string& name = sub->get_name();
        all += (all.empty() ? "" : ", ") + name;
        const std::size_t d = editDistance(word, name);
        if (d <= std::max<std::size_t>(1, name.size() / 3) && d < bestDistance) {
            best = name;
            bestDistance = d;
        }
    }
    if (!best.empty()) return "unknown command '" + word + "' (did you mean '" + best + "'?)";
    return "unknown command '" + word + "' (commands: " + all + "; see dgv --help)";
}

const char* kExitCodes = "Exit codes: 0 success, 1 run-time failure (I/O, GL), 2 bad input or usage, 130 interrupted.";
const char* kSubcommandFooter =
    "Global options, before or after the subcommand: --threads N (worker threads, 0: all cores), -q/--quiet (no "
    "progress output), --progress auto|bar|log.\n"
    "Exit codes: 0 success, 1 run-time failure (I/O, GL), 2 bad input or usage, 130 interrupted.";

/// The deepest subcommand parsed ("farm submit"), or the app itself.
CLI::App* parsedCommand(CLI::App& cli) {
    CLI::App* app = &cli;
    while (!app->get_subcommands().empty()) app = app->get_subcommands().front();
    return app;
}

/// "unknown option '--widht' for 'render' (did you mean '--width'?)" for the first option on the
/// command line that neither `command` nor the global options know; empty when there is none.
std::string unknownOptionMessage(CLI::App& cli, CLI::App& command, int argc, char** argv) {
    std::vector<std::string> names;
    for (CLI::App* app : {&command, &cli})
        for (const CLI::Option* opt : app->get_options()) {
            for (const std::string& l : opt->get_lnames()) names.push_back("--" + l);
            for (const std::string& s : opt->get_snames()) names.push_back("-" + s);
        }
    for (int i = 1; i < argc; ++i) {
        std::string arg = argv[i];
        if (arg == "--") break;
        if (arg.size() < 2 || arg[0] != '-' || (arg[1] >= '0' && arg[1] <= '9') || arg[1] == '.') continue;
        arg = arg.substr(0, arg.find('='));
        if (std::find(names.begin(), names.end(), arg) != names.end()) continue;
        std::string best;
        std::size_t bestDistance = std::string::npos;
        for (const std::string& name : names) {
            const std::size_t d = editDistance(arg, name);
            if (d <= std::max<std::size_t>(1, name.size() / 3) && d < bestDistance) {
                best = name;
                bestDistance = d;
            }
        }
        const std::string where = command.get_parent() ? " for '" + command.get_name() + "'" : "";
        return "unknown option '" + arg + "'" + where +
               (best.empty()
                    ? " (see dgv " + (command.get_parent() ? command.get_name() + " " : std::string()) + "--help)"
                    : " (did you mean '" + best + "'?)");
    }
    return "";
}

}  // namespace

namespace {

using namespace dgv;

/// The subcommands' options and the CLI11 handles that say which was given.
struct Commands {
    app::RenderOptions render;
    app::SimulateOptions simulate;
    app::GlnOptions gln;
    app::ImgdiffOptions diff;
    app::InfoOptions info;
    app::BenchCommandOptions bench;
    app::FarmOptions farm;
    CLI::App *cRender = nullptr, *cSim = nullptr, *cGln = nullptr, *cDiff = nullptr, *cInfo = nullptr,
             *cBench = nullptr, *cFarm = nullptr, *cFarmSubmit = nullptr, *cFarmStatus = nullptr,
             *cFarmResubmit = nullptr;
};

void addRender(CLI::App& cli, Commands& c) {
    c.cRender = cli.add_subcommand("render", "Render a scene to an image sequence <out>/<name>.####.png (or .exr)");
    c.cRender->add_option("scene", c.render.scene, "Scene file (JSON, see scenes/README.md)")->required();
    c.cRender->add_option("--frames", c.render.frames, "Frame range A-B (or one frame N), within the scene's range");
    c.cRender->add_option("--out", c.render.outDir, "Output folder (default: the scene's output.dir)");
    c.cRender
        ->add_option("--mesh", c.render.mesh,
                     "Also write each object's deformed surface per frame: ply or obj (<out>/mesh/<object>.####.ply); "
                     "gltf also assembles the shot into one animated <out>/mesh/<name>.glb")
        ->check(CLI::IsMember({"ply", "obj", "gltf"}));
    c.cRender->add_option("--width", c.render.width, "Image width in pixels")->check(CLI::Range(16, 16384));
    c.cRender->add_option("--height", c.render.height, "Image height in pixels")->check(CLI::Range(16, 16384));
    c.cRender->add_option("--resolution", c.render.resolution, "Image size WxH, e.g. 1920x1080 (overrides the scene)");
    c.cRender->add_option("--gl-backend", c.render.glBackend, "OpenGL context: auto (OSMesa, else EGL), egl or osmesa")
        ->check(CLI::IsMember({"auto", "egl", "osmesa"}));
    c.cRender
        ->add_option("--format", c.render.format,
                     "Frame files: png (sRGB) or exr (linear half float RGBA with Z and contact channels, for "
                     "compositing); overrides the scene's c.render.format")
        ->check(CLI::IsMember({"png", "exr"}));
    c.cRender->add_option("--solver", c.render.solver, "Every object's material.solver: chain or one (docs/math.md)")
        ->check(CLI::IsMember({"chain", "one"}));
    c.cRender
        ->add_option("--motion-blur", c.render.motionBlur,
                     "on or off: motion blur (render.motion_blur; on keeps the scene's shutter and samples), e.g. off "
                     "for a quick preview")
        ->check(CLI::IsMember({"on", "off"}));
    c.cRender->add_flag("--contact-sheet", c.render.contactSheet, "Also write <name>.contact.png, the frames in a grid");
    c.cRender->add_flag("--movie", c.render.movie,
                      "Also write <name>.mp4 with ffmpeg (H.264 preview; ffmpeg must be on PATH)");
    c.cRender->add_flag("--resume", c.render.resume,
                      "Keep frames already complete on disk (a readable PNG of that frame); render the rest, "
                      "the simulation restarting from its last valid state checkpoint");
    c.cRender->add_flag("--farm-task", c.render.farmTask,
                      "One task of a farm shot (dgv farm): restart from the state checkpoints without writing them, "
                      "stats.csv or the caches; only the frames are written");
    c.cRender->footer(kExitCodes);

}

void addSimulate(CLI::App& cli, Commands& c) {
    c.cSim = cli.add_subcommand(
        "simulate", "Simulate a scene: <out>/stats.csv, and with --vdb the VDB cache <out>/vdb/<name>.####.vdb");
    c.cSim->add_option("scene", c.simulate.scene, "Scene file (JSON, see scenes/README.md)")->required();
    c.cSim->add_option("--frames", c.simulate.frames, "Last frame N, or A-B (frames before A are simulated, not written)");
    c.cSim->add_option("--out", c.simulate.outDir, "Output folder (default: the scene's output.dir)");
    c.cSim->add_option("--solver", c.simulate.solver, "Every object's material.solver: chain or one (docs/math.md)")
        ->check(CLI::IsMember({"chain", "one"}));
    c.cSim->add_flag("--vdb", c.simulate.vdb, "Write the VDB cache (also on when the scene sets output.vdb)");
    c.cSim->add_option("--mesh", c.simulate.mesh,
                     "Write each object's deformed surface per frame: ply or obj (<out>/mesh/<object>.####.ply); "
                     "gltf also assembles the shot into one animated <out>/mesh/<name>.glb")
        ->check(CLI::IsMember({"ply", "obj", "gltf"}));
    c.cSim->add_flag("--resume", c.simulate.resume,
                   "Continue from the last valid state checkpoint (<out>/state/<name>.####.dgvstate)");
    c.cSim->footer(kExitCodes);

}

void addGln(CLI::App& cli, Commands& c) {
    c.cGln = cli.add_subcommand("gln", "Gauss linking number of two closed curves");
    c.cGln->add_option("curve_a", c.gln.curveA, "First closed curve: one 'x y z' vertex per line")->required();
    c.cGln->add_option("curve_b", c.gln.curveB, "Second closed curve")->required();
    c.cGln->add_option("--method", c.gln.method, "exact or seed")
        ->capture_default_str()
        ->check(CLI::IsMember({"exact", "seed"}));
    c.cGln->add_option("--tolerance", c.gln.tolerance, "Seed method's sampling tolerance")
        ->capture_default_str()
        ->check(kPositive);

}

void addImgdiff(CLI::App& cli, Commands& c) {
    c.cDiff =
        cli.add_subcommand("imgdiff", "Compare two images by the golden-image rule; exit 0 if they match, 1 if not");
    c.cDiff->add_option("reference", c.diff.reference, "Reference PNG")->required();
    c.cDiff->add_option("candidate", c.diff.candidate, "Candidate PNG")->required();
    c.cDiff->add_option("--threshold", c.diff.threshold, "Per-pixel tolerance in 8-bit code values (max over channels)")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 255.0));
    c.cDiff->add_option("--max-fraction", c.diff.maxFraction, "Fraction of pixels allowed over the threshold")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1.0));
    c.cDiff->add_option("--hard", c.diff.hard, "Fail if any pixel differs by more than this (default off)")
        ->check(CLI::Range(0.0, 255.0));
    c.cDiff->add_option("--diff-out", c.diff.diffDir, "On failure write <name>.new.png and <name>.diff.png here");

}

void addInfo(CLI::App& cli, Commands& c) {
    c.cInfo = cli.add_subcommand("info", "What import and voxelisation make of a mesh");
    c.cInfo->add_option("mesh", c.info.mesh, "Mesh file (any format assimp reads)")->required();
    c.cInfo->add_option("--mesh-name", c.info.meshName, "Only the mesh or node of this name");
    auto* oSize = c.cInfo->add_option("--voxel-size", c.info.voxelSize, "Voxel size in world units")->check(kPositive);
    auto* oRes =
        c.cInfo->add_option("--resolution", c.info.resolution, "Lattice points along the longest side (default 64)")
            ->check(CLI::Range(2, 2048));
    oSize->excludes(oRes);

}

void addBench(CLI::App& cli, Commands& c) {
    c.cBench = cli.add_subcommand("bench", "Benchmarks; print 'name: value unit' lines");
    c.cBench->add_option(
        "names", c.bench.names,
        "geometry, voxelise, render, gln, reconstruct, volume, vdb, step, reparametrise, contact (default: all)");
    c.cBench->add_option("--repeats", c.bench.repeats, "Timed repetitions")
        ->capture_default_str()
        ->check(CLI::Range(1, 100));
    c.cBench->add_flag("--quick", c.bench.quick, "Small problem sizes");

}

void addFarm(CLI::App& cli, Commands& c) {
    c.cFarm = cli.add_subcommand("farm", "Run a shot on a Slurm cluster: submit, status, resubmit (docs/farm.md)");
    c.cFarm->require_subcommand(1, 1);
    c.cFarmSubmit =
        c.cFarm->add_subcommand("submit", "Write the shot's Slurm batch scripts into the output folder and sbatch them");
    c.cFarmSubmit->add_option("scene", c.farm.scene, "Scene file (JSON, see scenes/README.md)")->required();
    c.cFarmSubmit->add_option("--chunk", c.farm.chunk, "Frames per render task")->required();
    c.cFarmSubmit->add_option("--partition", c.farm.partition, "Slurm partition (default: the cluster's)");
    c.cFarmSubmit->add_option("--out", c.farm.dir, "Output folder on shared storage (default: the scene's output.dir)");
    c.cFarmSubmit->add_flag("--dry-run", c.farm.dryRun, "Print the scripts; write and submit nothing");
    c.cFarmSubmit->add_flag("--vdb", c.farm.vdb, "The simulation job also writes the VDB cache");
    c.cFarmSubmit->add_option("--mesh", c.farm.mesh, "The simulation job also writes the mesh cache: ply, obj or gltf")
        ->check(CLI::IsMember({"ply", "obj", "gltf"}));
    c.cFarmSubmit->add_flag("--contact-sheet", c.farm.contactSheet, "The check job also writes <name>.contact.png");
    c.cFarmSubmit->add_flag("--movie", c.farm.movie, "The check job also writes <name>.mp4 (ffmpeg on the node)");
    c.cFarmStatus = c.cFarm->add_subcommand("status", "What of a submitted shot is done, running or failed");
    c.cFarmStatus->add_option("dir", c.farm.dir, "The shot's output folder")->required();
    c.cFarmStatus->add_flag("--check", c.farm.check, "Exit 1 unless every frame is complete");
    c.cFarmResubmit = c.cFarm->add_subcommand("resubmit", "Submit again the render tasks whose frames are missing");
    c.cFarmResubmit->add_option("dir", c.farm.dir, "The shot's output folder")->required();
    c.cFarmResubmit->add_flag("--dry-run", c.farm.dryRun, "Print what would be submitted");

}

/// Parses the command line; an exit code where it is not a command to run (help, version, a
/// bad option: one line), else nothing.
std::optional<int> parseCommandLine(CLI::App& cli, int argc, char** argv) {
    // Each subcommand's --help names the global options it takes too.
    std::vector<CLI::App*> pending = cli.get_subcommands([](CLI::App*) { return true; });
    while (!pending.empty()) {
        CLI::App* sub = pending.back();
        pending.pop_back();
        sub->footer(kSubcommandFooter);
        for (CLI::App* child : sub->get_subcommands([](CLI::App*) { return true; })) pending.push_back(child);
    }
    try {
        cli.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return cli.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return cli.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return cli.exit(e);
    } catch (const CLI::ExtrasError& e) {
        const std::string word = cli.get_subcommands().empty() ? unknownCommand(cli, argc, argv) : "";
        const std::string option = word.empty() ? unknownOptionMessage(cli, *parsedCommand(cli), argc, argv) : "";
        if (!word.empty())
            std::fprintf(stderr, "dgv: error: %s\n", oneLine(unknownCommandMessage(cli, word).c_str()).c_str());
        else if (!option.empty())
            std::fprintf(stderr, "dgv: error: %s\n", oneLine(option.c_str()).c_str());
        else
            std::fprintf(stderr, "dgv: %s (see dgv --help)\n", oneLine(e.what()).c_str());
        return kExitBadInput;
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "dgv: %s (see dgv --help)\n", oneLine(e.what()).c_str());
        return kExitBadInput;
    }

    return std::nullopt;
}

/// Runs the command given (no subcommand: the default scene's render).
int runCommand(Commands& c) {
    if (*c.cRender) return app::runRender(c.render);
    if (*c.cInfo) return app::runInfo(c.info);
    if (*c.cDiff) return app::runImgdiff(c.diff);
    if (*c.cBench) return app::runBench(c.bench);
    if (*c.cSim) return app::runSimulate(c.simulate);
    if (*c.cGln) return app::runGln(c.gln);
    if (*c.cFarm) {
        c.farm.action = *c.cFarmSubmit ? "submit" : *c.cFarmStatus ? "status" : "resubmit";
        return app::runFarm(c.farm);
    }
    app::RenderOptions def;
    def.scene = app::defaultScenePath();
    return app::runRender(def);
}

/// Runs the command, turning what it throws into one line and an exit code.
int runReportingErrors(Commands& c) {
    try {
        const int rc = runCommand(c);
        return cancelRequested() && rc != kExitInterrupted ? interrupted() : rc;
    } catch (const InputError& e) {
        std::fprintf(stderr, "dgv: error: %s\n", oneLine(e.what()).c_str());
        return kExitBadInput;
    } catch (const RuntimeError& e) {
        // SIGINT/SIGTERM removes the temporary being written, which fails that write: an
        // interruption, not an I/O error.
        if (cancelRequested()) return interrupted();
        std::fprintf(stderr, "dgv: error: %s\n", oneLine(e.what()).c_str());
        return kExitFailure;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "dgv: error: out of memory\n");
        return kExitFailure;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "dgv: error: %s\n", oneLine(e.what()).c_str());
        return kExitFailure;
    }
}
}  // namespace

int main(int argc, char** argv) {
    using namespace dgv;
    CLI::App cli{
        "dgv: deforming geometric volumes, rendered offscreen.\n"
        "With no subcommand, renders the default scene (scenes/default.json) into out/."};
    cli.footer(kExitCodes);
    cli.set_version_flag("--version", std::string("dgv ") + DGV_VERSION_STRING);
    int threads = 0;
    bool quiet = false;
    std::string progress = "auto";
    cli.add_option("--threads", threads, "Worker threads (0: all cores)")->check(CLI::Range(0, 1024));
    cli.add_flag("-q,--quiet", quiet, "No progress output");
    cli.add_option("--progress", progress, "Progress display: auto, bar or log")
        ->check(CLI::IsMember({"auto", "bar", "log"}));
    cli.require_subcommand(0, 1);
    // The global options are also taken after the subcommand ("dgv render x.json --threads 1"):
    // what a subcommand does not know falls through to here. Subcommands inherit the setting.
    cli.fallthrough();

    Commands c;
    addRender(cli, c);
    addSimulate(cli, c);
    addGln(cli, c);
    addImgdiff(cli, c);
    addInfo(cli, c);
    addBench(cli, c);
    addFarm(cli, c);
    if (const std::optional<int> rc = parseCommandLine(cli, argc, argv)) return *rc;

    Progress::setQuiet(quiet);
    Progress::setMode(progress == "bar" ? 1 : progress == "log" ? 2 : 0);
    std::unique_ptr<tbb::global_control> threadLimit;
    if (threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                            static_cast<std::size_t>(threads));
    // A signal at any time, even before the command starts or as it returns, ends the run as
    // interrupted (the handlers are in place from the start: installSignalHandlers).
    if (cancelRequested()) return interrupted();
    return runReportingErrors(c);
}
