// dgv farm: a shot on a Slurm cluster (docs/farm.md). `submit` writes three batch scripts into
// <out>/farm/ and hands them to sbatch: the simulation (state checkpoints, caches), a job array of
// render tasks of --chunk frames each that depends on it, and a check job that depends on the
// array. dgv schedules nothing itself: Slurm runs the scripts; `status` reads what they left in
// the folder (frames, exit markers) and asks squeue when it is on PATH; `resubmit` submits again
// the tasks whose frames are missing.

#include "app/commands.hpp"
#include "app/resume.hpp"
#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/scene_json.hpp"
#include "io/state_file.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

extern char** environ;

namespace dgv::app {

namespace fs = std::filesystem;

namespace {

/// What submit records in <out>/farm/shot.txt: status and resubmit work from it alone.
struct Shot {
    std::string scene;  ///< absolute path of the scene file
    std::string name;   ///< the scene's name (frame files <name>.####.png)
    std::string dir;    ///< absolute output folder
    int first = 1, last = 1, chunk = 1;
    bool simulate = false;  ///< a simulation job was submitted
    std::string partition;
    std::string simJob, renderJob, checkJob;  ///< Slurm job ids ("" when not submitted)
    // From the scene file as it is now (loadShot): what a complete frame of it looks like.
    int width = 0, height = 0;
    std::string key;  ///< the scene's frame key (io/state_file.hpp)
    std::string extension = "png";  ///< the frames' files: png or exr (render.format)

    int tasks() const { return (last - first + chunk) / chunk; }
    int taskFirst(int t) const { return first + t * chunk; }
    int taskLast(int t) const { return std::min(last, taskFirst(t) + chunk - 1); }
};

fs::path farmDir(const std::string& dir) { return fs::path(dir) / "farm"; }

std::string shotText(const Shot& s) {
    std::ostringstream o;
    o << "scene=" << s.scene << "\nname=" << s.name << "\ndir=" << s.dir << "\nfirst=" << s.first << "\nlast=" << s.last
      << "\nchunk=" << s.chunk << "\nsimulate=" << (s.simulate ? 1 : 0) << "\npartition=" << s.partition
      << "\nsim_job=" << s.simJob << "\nrender_job=" << s.renderJob << "\ncheck_job=" << s.checkJob << "\n";
    return o.str();
}

/// Reads <dir>/farm/shot.txt; false when there is none. InputError when it is unreadable.
bool readShot(const std::string& dir, Shot& s) {
    const fs::path path = farmDir(dir) / "shot.txt";
    std::ifstream in(path);
    if (!in) return false;
    std::map<std::string, std::string> kv;
    for (std::string line; std::getline(in, line);) {
        const std::size_t eq = line.find('=');
        if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
    }
    try {
        s.scene = kv.at("scene");
        s.name = kv.at("name");
        s.dir = kv.at("dir");
        s.first = std::stoi(kv.at("first"));
        s.last = std::stoi(kv.at("last"));
        s.chunk = std::stoi(kv.at("chunk"));
        s.simulate = kv.at("simulate") == "1";
    } catch (const std::exception&) {
        throw InputError(path.string(), "", "not a dgv farm shot file (a key is missing or not a number)");
    }
    if (s.chunk <= 0 || s.last < s.first)
        throw InputError(path.string(), "", "not a dgv farm shot file (bad frame range or chunk)");
    s.partition = kv["partition"];
    s.simJob = kv["sim_job"];
    s.renderJob = kv["render_job"];
    s.checkJob = kv["check_job"];
    return true;
}

/// Runs `argv` (searched on PATH, no shell) and returns its exit status (-1: could not start);
/// `out` receives its standard output.
int runCapture(const std::vector<std::string>& argv, std::string& out) {
    int fds[2];
    if (pipe(fds) != 0) return -1;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    posix_spawn_file_actions_addclose(&actions, fds[1]);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = 0;
    const int spawned = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    out.clear();
    if (spawned == 0) {
        char buf[4096];
        for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) != 0;) {
            if (n < 0) {
                if (errno == EINTR) continue;
                break;
            }
            out.append(buf, static_cast<std::size_t>(n));
        }
    }
    close(fds[0]);
    if (spawned != 0) return -1;
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// sbatch --parsable `args` `script`: the job id ("1234" of "1234;cluster"). RuntimeError naming
/// the script when sbatch fails.
std::string sbatch(const std::vector<std::string>& args, const fs::path& script) {
    std::vector<std::string> argv{"sbatch", "--parsable"};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.push_back(script.string());
    std::string out;
    const int rc = runCapture(argv, out);
    std::string id = out.substr(0, out.find_first_of(";\n"));
    if (rc != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
        throw RuntimeError("sbatch " + script.string() + " failed (exit " + std::to_string(rc) + "): " + out);
    return id;
}

/// The lines every script starts with: the shell, the job's name, log and partition, `extra`
/// directives (sbatch reads #SBATCH lines only before the first command).
std::string header(const Shot& s, const std::string& job, const std::string& log, const std::string& extra = "") {
    std::string h = "#!/bin/bash\n";
    h += "#SBATCH --job-name=" + shellQuote("dgv-" + s.name + "-" + job) + "\n";
    h += "#SBATCH --output=" + shellQuote((farmDir(s.dir) / "logs" / log).string()) + "\n";
    if (!s.partition.empty()) h += "#SBATCH --partition=" + shellQuote(s.partition) + "\n";
    h += extra;
    h += "# Written by dgv farm submit (docs/farm.md); Slurm runs it.\n";
    h += "set -u\n";
    h += "marker() {  # <name> <exit code>: written atomically, read by dgv farm status\n";
    h += "  d=" + shellQuote((farmDir(s.dir) / "done").string()) + "\n";
    h += "  printf '%s\\n' \"$2\" > \"$d/.$1.$$\" && mv -f \"$d/.$1.$$\" \"$d/$1\"\n";
    h += "}\n";
    return h;
}

std::string simulateScript(const Shot& s, const std::string& dgv, const FarmOptions& o) {
    std::string t = header(s, "simulate", "simulate.out");
    t += shellQuote(dgv) + " --progress log simulate " + shellQuote(s.scene) + " --out " + shellQuote(s.dir) +
         " --resume" + (o.vdb ? " --vdb" : "") + (o.mesh.empty() ? "" : " --mesh " + o.mesh) + "\n";
    t += "rc=$?\nmarker simulate \"$rc\"\nexit \"$rc\"\n";
    return t;
}

std::string renderScript(const Shot& s, const std::string& dgv) {
    std::string t = header(s, "render", "render.%a.out", "#SBATCH --array=0-" + std::to_string(s.tasks() - 1) + "\n");
    t += "task=${SLURM_ARRAY_TASK_ID:?not run as a Slurm array task}\n";
    t += "first=$(( " + std::to_string(s.first) + " + task * " + std::to_string(s.chunk) + " ))\n";
    t += "last=$(( first + " + std::to_string(s.chunk - 1) + " ))\n";
    t += "if (( last > " + std::to_string(s.last) + " )); then last=" + std::to_string(s.last) + "; fi\n";
    t += "# llvmpipe's threads: the CPUs Slurm gave this task, unless the site sets LP_NUM_THREADS.\n";
    t += "export LP_NUM_THREADS=${LP_NUM_THREADS:-${SLURM_CPUS_PER_TASK:-1}}\n";
    t += shellQuote(dgv) + " --progress log --threads \"${SLURM_CPUS_PER_TASK:-0}\" render " + shellQuote(s.scene) +
         " --frames \"$first-$last\" --out " + shellQuote(s.dir) + " --resume --farm-task\n";
    t += "rc=$?\nmarker \"render.$task\" \"$rc\"\nexit \"$rc\"\n";
    return t;
}

std::string checkScript(const Shot& s, const std::string& dgv, const FarmOptions& o) {
    std::string t = header(s, "check", "check.out");
    t += shellQuote(dgv) + " farm status " + shellQuote(s.dir) + " --check\n";
    t += "rc=$?\n";
    if (o.contactSheet || o.movie)
        t += "if (( rc == 0 )); then\n  " + shellQuote(dgv) + " --progress log render " + shellQuote(s.scene) +
             " --out " + shellQuote(s.dir) + " --resume --farm-task" + (o.contactSheet ? " --contact-sheet" : "") +
             (o.movie ? " --movie" : "") + "\n  rc=$?\nfi\n";
    t += "marker check \"$rc\"\nexit \"$rc\"\n";
    return t;
}

/// The dgv launcher beside this executable (app/launcher.cpp), by its absolute path: what the
/// scripts run (the same path on every node).
std::string selfPath() {
    std::error_code ec;
    const fs::path p = fs::read_symlink("/proc/self/exe", ec);
    if (ec) return "dgv";
    const fs::path launcher = p.parent_path() / "dgv";
    return p.filename() == "dgv-core" && fs::exists(launcher, ec) ? launcher.string() : p.string();
}

/// A frame is done when its PNG decodes in full and says it is that frame.
/// Which of the shot's frames, first to last, are on disk, whole and of this version of the
/// scene: the test `render --resume` applies (app/resume.hpp), so a frame left from an edited
/// scene is not done.
std::vector<char> framesDone(const Shot& s) {
    std::vector<char> done;
    for (int f = s.first; f <= s.last; ++f)
        done.push_back(
            frameIsComplete(framePath(s.dir, s.name, f, s.extension), f, s.width, s.height, s.key, nullptr, true) ? 1
                                                                                                                   : 0);
    return done;
}

/// The exit code a job's marker holds, or -1 when it has none yet.
int markerCode(const Shot& s, const std::string& name) {
    std::ifstream in(farmDir(s.dir) / "done" / name);
    int code = -1;
    if (in >> code) return code;
    return -1;
}

/// The tasks with a frame that is not done.
std::vector<int> missingTasks(const Shot& s) {
    const std::vector<char> done = framesDone(s);
    std::vector<int> tasks;
    for (int t = 0; t < s.tasks(); ++t)
        for (int f = s.taskFirst(t); f <= s.taskLast(t); ++f)
            if (!done[static_cast<std::size_t>(f - s.first)]) {
                tasks.push_back(t);
                break;
            }
    return tasks;
}

/// "0,2,5": Slurm's --array list.
std::string arrayList(const std::vector<int>& tasks) {
    std::string list;
    for (int t : tasks) list += (list.empty() ? "" : ",") + std::to_string(t);
    return list;
}

/// squeue's view of the shot's jobs ("<id> <state>" lines), empty when squeue is not on PATH.
std::string queued(const Shot& s) {
    std::string ids;
    for (const std::string* id : {&s.simJob, &s.renderJob, &s.checkJob})
        if (!id->empty()) ids += (ids.empty() ? "" : ",") + *id;
    if (ids.empty() || !onPath("squeue")) return "";
    std::string out;
    if (runCapture({"squeue", "-h", "-j", ids, "-o", "%i %T %r"}, out) != 0) return "";
    return out;
}

int submit(const FarmOptions& o) {
    if (o.chunk <= 0)
        throw InputError("--chunk", "", "expected a positive number of frames, got " + std::to_string(o.chunk));
    std::error_code ec;
    if (!fs::is_regular_file(o.scene, ec)) throw InputError(o.scene, "", "no such scene file");
    const SceneDesc scene = loadScene(o.scene);
    Shot s;
    s.scene = fs::absolute(o.scene).lexically_normal().string();
    s.name = scene.name;
    s.dir = fs::absolute(o.dir.empty() ? scene.output.dir : o.dir).lexically_normal().string();
    checkOutputFolder(s.dir, o.dir.empty() ? o.scene : "--out", o.dir.empty() ? "output.dir" : "");
    s.first = scene.frameStart;
    s.last = scene.frameEnd;
    s.chunk = o.chunk;
    s.partition = o.partition;
    // Anything moves (sim/simulation: forces, or a deformable object with a start velocity or
    // spin): the render tasks need the simulation's checkpoints. A still scene needs the job only
    // for the caches.
    bool moves = !scene.forces.empty();
    for (const ObjectDesc& obj : scene.objects)
        if (obj.deformable && (obj.velocity.squaredNorm() > 0 || obj.spinDegrees.squaredNorm() > 0)) moves = true;
    s.simulate = moves || o.vdb || !o.mesh.empty();
    if (Shot other; readShot(s.dir, other) && (other.scene != s.scene || other.name != s.name))
        throw InputError(o.dir.empty() ? o.scene : "--out", "",
                         s.dir + " holds the farm of another shot (" + other.scene + "); choose another output folder");
    if (!o.dryRun && !onPath("sbatch"))
        throw InputError("dgv farm submit", "",
                         "sbatch is not on PATH: run it on a Slurm submit host, or use --dry-run");

    const std::string dgv = selfPath();
    const fs::path fd = farmDir(s.dir);
    const std::string sim = s.simulate ? simulateScript(s, dgv, o) : "";
    const std::string render = renderScript(s, dgv);
    const std::string check = checkScript(s, dgv, o);
    if (o.dryRun) {
        if (s.simulate)
            std::printf("# %s\n%s", (fd / "simulate.sbatch").c_str(), sim.c_str());
        else
            std::printf("# no simulation job: nothing in '%s' moves\n", s.name.c_str());
        std::printf("# %s (sbatch%s)\n%s", (fd / "render.sbatch").c_str(),
                    s.simulate ? " --dependency=afterok:<simulate>" : "", render.c_str());
        std::printf("# %s (sbatch --dependency=afterok:<render>)\n%s", (fd / "check.sbatch").c_str(), check.c_str());
        return kExitOk;
    }
    ensureDirectory(fd / "logs");
    ensureDirectory(fd / "done");
    if (s.simulate) writeTextAtomically(fd / "simulate.sbatch", sim);
    writeTextAtomically(fd / "render.sbatch", render);
    writeTextAtomically(fd / "check.sbatch", check);
    // A new submission: the exit markers of an earlier one say nothing about it.
    for (const auto& entry : fs::directory_iterator(fd / "done", ec)) fs::remove(entry.path(), ec);
    if (s.simulate) s.simJob = sbatch({}, fd / "simulate.sbatch");
    s.renderJob =
        sbatch(s.simulate ? std::vector<std::string>{"--dependency=afterok:" + s.simJob} : std::vector<std::string>{},
               fd / "render.sbatch");
    s.checkJob = sbatch({"--dependency=afterok:" + s.renderJob}, fd / "check.sbatch");
    writeTextAtomically(fd / "shot.txt", shotText(s));
    if (s.simulate) std::printf("simulate %s\n", s.simJob.c_str());
    std::printf("render %s (array 0-%d, %d frames each)\ncheck %s\n", s.renderJob.c_str(), s.tasks() - 1, s.chunk,
                s.checkJob.c_str());
    return kExitOk;
}

Shot loadShot(const std::string& dir) {
    Shot s;
    if (!readShot(dir, s)) throw InputError(dir, "", "no dgv farm shot here (no farm/shot.txt; see dgv farm submit)");
    const SceneDesc scene = loadScene(s.scene);
    s.width = scene.render.width;
    s.height = scene.render.height;
    s.key = sceneFrameKey(scene);
    s.extension = scene.render.frameExtension();
    return s;
}

int status(const FarmOptions& o) {
    const Shot s = loadShot(o.dir);
    const std::vector<char> complete = framesDone(s);
    const int done = static_cast<int>(std::count(complete.begin(), complete.end(), 1));
    const int total = s.last - s.first + 1;
    std::printf("%s: frames %d-%d, %d of %d complete\n", s.name.c_str(), s.first, s.last, done, total);
    const int sim = markerCode(s, "simulate");
    if (s.simulate)
        std::printf("simulate (job %s): %s\n", s.simJob.c_str(),
                    sim < 0    ? "not finished"
                    : sim == 0 ? "done"
                               : ("FAILED, exit " + std::to_string(sim) +
                                  " (see farm/logs/simulate.out); the render tasks and the check never start")
                                     .c_str());
    int failed = 0;
    for (int t = 0; t < s.tasks(); ++t) {
        int missing = 0;
        for (int f = s.taskFirst(t); f <= s.taskLast(t); ++f)
            missing += !complete[static_cast<std::size_t>(f - s.first)];
        const int rc = markerCode(s, "render." + std::to_string(t));
        const char* state = missing == 0            ? "done"
                            : rc > 0                ? "FAILED"
                            : s.simulate && sim > 0 ? "never ran (the simulation failed)"
                                                    : "not finished";
        if (missing && rc > 0) ++failed;
        std::printf("render task %d (frames %d-%d): %s", t, s.taskFirst(t), s.taskLast(t), state);
        if (missing) std::printf(", %d frame%s missing", missing, missing > 1 ? "s" : "");
        if (missing && rc > 0) std::printf(", exit %d (see farm/logs/render.%d.out)", rc, t);
        std::printf("\n");
    }
    const int check = markerCode(s, "check");
    std::printf("check (job %s): %s\n", s.checkJob.c_str(),
                check < 0    ? "not finished"
                : check == 0 ? "done"
                             : ("FAILED, exit " + std::to_string(check)).c_str());
    const std::string q = queued(s);
    if (!q.empty()) std::printf("in the queue (id state reason):\n%s", q.c_str());
    if (failed > 0 || (s.simulate && sim > 0))
        std::printf("dgv farm resubmit %s renders only what is missing\n", shellQuote(s.dir).c_str());
    if (o.check && done < total) {
        std::fprintf(stderr, "dgv: error: %s: %d of %d frames are missing or incomplete\n", s.dir.c_str(), total - done,
                     total);
        return kExitFailure;
    }
    return kExitOk;
}

int resubmit(const FarmOptions& o) {
    Shot s = loadShot(o.dir);
    const std::vector<int> tasks = missingTasks(s);
    if (tasks.empty()) {
        std::printf("%s: every frame is complete; nothing to submit\n", s.name.c_str());
        return kExitOk;
    }
    const fs::path fd = farmDir(s.dir);
    const bool simAgain = s.simulate && markerCode(s, "simulate") != 0;
    if (o.dryRun) {
        if (simAgain) std::printf("sbatch %s\n", (fd / "simulate.sbatch").c_str());
        std::printf("sbatch --array=%s %s\nsbatch %s\n", arrayList(tasks).c_str(), (fd / "render.sbatch").c_str(),
                    (fd / "check.sbatch").c_str());
        return kExitOk;
    }
    if (!onPath("sbatch"))
        throw InputError("dgv farm resubmit", "", "sbatch is not on PATH: run it on a Slurm submit host");
    // The earlier check job waits on tasks that failed: it would never start.
    std::string ignored;
    if (!s.checkJob.empty() && onPath("scancel")) runCapture({"scancel", s.checkJob}, ignored);
    std::error_code ec;
    for (int t : tasks) fs::remove(fd / "done" / ("render." + std::to_string(t)), ec);
    fs::remove(fd / "done" / "check", ec);
    std::vector<std::string> dep;
    if (simAgain) {
        fs::remove(fd / "done" / "simulate", ec);
        s.simJob = sbatch({}, fd / "simulate.sbatch");  // --resume: it goes on from its last checkpoint
        dep.push_back("--dependency=afterok:" + s.simJob);
    }
    dep.push_back("--array=" + arrayList(tasks));
    s.renderJob = sbatch(dep, fd / "render.sbatch");
    s.checkJob = sbatch({"--dependency=afterok:" + s.renderJob}, fd / "check.sbatch");
    writeTextAtomically(fd / "shot.txt", shotText(s));
    if (simAgain) std::printf("simulate %s\n", s.simJob.c_str());
    std::printf("render %s (tasks %s)\ncheck %s\n", s.renderJob.c_str(), arrayList(tasks).c_str(), s.checkJob.c_str());
    return kExitOk;
}

}  // namespace

int runFarm(const FarmOptions& options) {
    if (options.action == "submit") return submit(options);
    if (options.action == "status") return status(options);
    return resubmit(options);
}

}  // namespace dgv::app
