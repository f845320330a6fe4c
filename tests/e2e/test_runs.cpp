// Whole runs of the dgv executable under faults and restarts (docs/robustness.md): an unwritable
// output folder, a full disk, a killed run, --resume, and thread-count determinism.

#include "e2e/e2e_run.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;

namespace {

/// A small sphere scene ("small.json") in `dir`: `frames` frames of `w` x `h`, a turntable camera
/// so that every frame differs.
fs::path writeScene(const fs::path& dir, int frames, int w = 64, int h = 48) {
    const fs::path scene = dir / "small.json";
    std::ofstream(scene) << R"({"frames": {"start": 1, "end": )" << frames << R"(},
  "objects": [{"primitive": {"type": "sphere", "radius": 0.5}, "resolution": 12, "color": [0.8, 0.3, 0.2]},
              {"primitive": {"type": "box", "size": [0.4, 0.4, 0.4]}, "transform": {"translate": [0.7, 0, 0]}, "resolution": 8}],
  "camera": {"type": "turntable", "degrees": 360, "elevation": 20},
  "render": {"width": )" << w
                         << R"(, "height": )" << h << R"(, "supersample": 1}})"
                         << "\n";
    return scene;
}

std::string frameName(int frame) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "small.%04d.png", frame);
    return buf;
}

/// The files in `dir` (names only), sorted; temporaries (".name.tmp-HOST-PID") included.
std::vector<std::string> namesIn(const fs::path& dir) {
    return fs::exists(dir) ? snapshot(dir) : std::vector<std::string>{};
}

std::vector<std::string> frameNames(int first, int last) {
    std::vector<std::string> v;
    for (int f = first; f <= last; ++f) v.push_back(frameName(f));
    return v;
}

}  // namespace

TEST_CASE("e2e: an unwritable output folder gives one line, exit 1, and no partial frame", "[e2e][faults]") {
    test::TempDir dir("e2e_readonly");
    writeScene(dir.path(), 2);
    fs::path out;
    if (geteuid() != 0) {
        out = dir.path() / "ro";
        fs::create_directories(out);
        REQUIRE(::chmod(out.c_str(), 0555) == 0);
    } else {
        // root writes through chmod 0555; /proc/self is a folder in which no one can create files.
        out = "/proc/self";
    }
    const Run r = runDgvIn(dir.path(), "-q render small.json --out " + quote(out));
    if (geteuid() != 0) ::chmod(out.c_str(), 0755);
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 1);
    CHECK(lineCount(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("dgv: error: cannot write " + (out / frameName(1)).string() + ": "));
    if (geteuid() != 0) CHECK(namesIn(out).empty());
    CHECK(namesIn(dir.path()) == std::vector<std::string>{"small.json"});
}

TEST_CASE(
    "e2e: a frame the dynamics cannot step is retried, then ends the run with its fault kind, and none of it is "
    "written",
    "[e2e][faults]") {
    // A 0.2 m jelly ball fixed at 1 substep (max_substeps 1) lands at frame 8 and its surface
    // folds over (measured: 220 of 3,968 triangles). The run stops there: exit 1, one line that
    // names the kind, the frame and the substeps tried, frames 1-7 written and nothing of 8.
    // With the default adaptive substeps the same ball lands within the goals.
    test::TempDir dir("e2e_fault_kind");
    auto scene = [&](const std::string& substeps) {
        return R"({ "name": "fault", "frames": {"start": 1, "end": 10, "fps": 24})" + substeps + R"(,
          "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.2}, "resolution": 8,
                       "transform": {"translate": [0, 0.4, 0]}, "material": {"stiffness": 1000, "damping": 2}}],
          "forces": [{"type": "gravity"}], "colliders": [{"type": "ground", "height": 0}] })";
    };
    { std::ofstream(dir.path() / "fixed.json") << scene(R"(, "max_substeps": 1)"); }
    { std::ofstream(dir.path() / "adaptive.json") << scene(""); }
    const Run r = runDgvIn(dir.path(), "-q render fixed.json --out out");
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 1);
    CHECK(lineCount(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("dgv: error: dynamics [surface_torn]: frame 8 at 1 substeps, object 'ball': "
                                        "its surface folds or tears"));
    CHECK_THAT(r.err, Catch::Contains("(tried at 1 to 1 substeps; nothing of frame 8 was written)"));
    const auto rows = readStatsCsv(dir.path() / "out" / "stats.csv");
    REQUIRE(!rows.empty());
    CHECK(rows.back().at("frame") == 7);
    CHECK(fs::exists(dir.path() / "out" / "fault.0007.png"));
    CHECK(!fs::exists(dir.path() / "out" / "fault.0008.png"));
    const Run ok = runDgvIn(dir.path(), "-q simulate adaptive.json --out ok");
    INFO("adaptive stderr: " << ok.err);
    CHECK(ok.exitCode == 0);
    CHECK(readStatsCsv(dir.path() / "ok" / "stats.csv").back().at("frame") == 10);
}

TEST_CASE("e2e: a full disk fails the frame being written and leaves no partial file", "[e2e][faults]") {
    // RLIMIT_FSIZE makes write() fail with EFBIG (SIGXFSZ ignored) like a full disk would, without
    // root or a special file system; frame 1 (~7 kB) cannot be written in 1 kB.
    test::TempDir dir("e2e_full");
    writeScene(dir.path(), 3, 128, 96);
    const Run r = runDgvIn(dir.path(), "-q render small.json --out out", "trap '' XFSZ; ulimit -f 1;");
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 1);
    CHECK(lineCount(r.err) == 1);
    CHECK_THAT(r.err,
               Catch::StartsWith("dgv: error: cannot write " + (dir.path() / "out" / frameName(1)).string() + ": "));
    CHECK_THAT(r.err, Catch::Contains("File too large"));
    CHECK(namesIn(dir.path() / "out").empty());  // no frame, no temporary
}

TEST_CASE("e2e: renders are byte-identical for 1 and 2 threads", "[e2e][determinism][slow]") {
    // --threads sets TBB's global_control (voxelising, the lattice and embedding: parallelFor /
    // parallelReduce); LP_NUM_THREADS sets Mesa llvmpipe's rasteriser threads.
    test::TempDir dir("e2e_threads");
    writeScene(dir.path(), 2, 96, 72);
    const Run one = runDgvIn(dir.path(), "-q --threads 1 render small.json --out t1", "LP_NUM_THREADS=1");
    const Run two = runDgvIn(dir.path(), "-q --threads 2 render small.json --out t2", "LP_NUM_THREADS=2");
    const Run all = runDgvIn(dir.path(), "-q render small.json --out t0", "LP_NUM_THREADS=4");
    REQUIRE(one.exitCode == 0);
    REQUIRE(two.exitCode == 0);
    REQUIRE(all.exitCode == 0);
    for (int f = 1; f <= 2; ++f) {
        INFO(frameName(f));
        const std::string a = readAll(dir.path() / "t1" / frameName(f));
        REQUIRE(a.size() > 100);
        CHECK(readAll(dir.path() / "t2" / frameName(f)) == a);
        CHECK(readAll(dir.path() / "t0" / frameName(f)) == a);
    }
}

TEST_CASE("e2e: --resume re-renders exactly the missing, truncated and foreign frames", "[e2e][resume][slow]") {
    test::TempDir dir("e2e_resume");
    writeScene(dir.path(), 4);
    REQUIRE(runDgvIn(dir.path(), "-q render small.json --out full").exitCode == 0);
    REQUIRE(runDgvIn(dir.path(), "-q render small.json --out part").exitCode == 0);
    const fs::path part = dir.path() / "part";
    // frame 2 truncated (a half-written file from some other tool), frame 3 deleted, frame 4
    // replaced by frame 1's file (complete, but the wrong frame's metadata).
    fs::resize_file(part / frameName(2), fs::file_size(part / frameName(2)) / 2);
    fs::remove(part / frameName(3));
    fs::copy_file(part / frameName(1), part / frameName(4), fs::copy_options::overwrite_existing);
    const auto keptTime = fs::last_write_time(part / frameName(1));

    const Run r = runDgvIn(dir.path(), "--progress log render small.json --out part --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains(frameName(1) + " (complete, kept)"));
    for (int f = 2; f <= 4; ++f) CHECK_THAT(r.err, !Catch::Contains(frameName(f) + " (complete, kept)"));
    CHECK_THAT(r.err, Catch::Contains("resume: kept 1 complete frames, rendered 3"));
    CHECK(fs::last_write_time(part / frameName(1)) == keptTime);  // not rewritten
    CHECK(namesIn(part) == frameNames(1, 4));
    for (int f = 1; f <= 4; ++f) {
        INFO(frameName(f));
        CHECK(readAll(part / frameName(f)) == readAll(dir.path() / "full" / frameName(f)));
    }
    // Everything complete: a second --resume renders nothing.
    const Run again = runDgvIn(dir.path(), "--progress log render small.json --out part --resume");
    CHECK(again.exitCode == 0);
    CHECK_THAT(again.err, Catch::Contains("resume: kept 4 complete frames, rendered 0"));
    // A different resolution does not match the frames on disk: all are rendered again.
    const Run bigger = runDgvIn(dir.path(), "--progress log render small.json --out part --resume --resolution 80x60");
    CHECK(bigger.exitCode == 0);
    CHECK_THAT(bigger.err, Catch::Contains("resume: kept 0 complete frames, rendered 4"));
}

TEST_CASE("e2e: --resume never keeps frames of an earlier version of the scene or of another bit depth",
          "[e2e][resume][slow]") {
    test::TempDir dir("e2e_resume_version");
    const fs::path scene = writeScene(dir.path(), 3);
    REQUIRE(runDgvIn(dir.path(), "-q render small.json --out part").exitCode == 0);
    // The end frame moved on: the frames on disk are of the same scene and are kept.
    writeScene(dir.path(), 4);
    const Run longer = runDgvIn(dir.path(), "--progress log render small.json --out part --resume");
    INFO("stderr: " << longer.err);
    REQUIRE(longer.exitCode == 0);
    CHECK_THAT(longer.err, Catch::Contains("resume: kept 3 complete frames, rendered 1"));
    // A colour changed: every frame on disk is of another version of the scene, none is kept.
    std::string text = readAll(scene);
    text.replace(text.find("0.8, 0.3, 0.2"), 13, "0.2, 0.3, 0.8");
    std::ofstream(scene) << text;
    const Run recoloured = runDgvIn(dir.path(), "--progress log render small.json --out part --resume");
    INFO("stderr: " << recoloured.err);
    REQUIRE(recoloured.exitCode == 0);
    CHECK_THAT(recoloured.err, Catch::Contains("resume: kept 0 complete frames, rendered 4 (4 of them were on disk"));
    REQUIRE(runDgvIn(dir.path(), "-q render small.json --out fresh").exitCode == 0);
    for (int f = 1; f <= 4; ++f)
        CHECK(readAll(dir.path() / "part" / frameName(f)) == readAll(dir.path() / "fresh" / frameName(f)));
    // 16-bit RGBA output: the 8-bit frames are replaced, not mixed with 16-bit ones.
    text = readAll(scene);
    text.replace(text.find("\"supersample\": 1}"), 17, R"("supersample": 1, "bit_depth": 16, "transparent": true})");
    std::ofstream(scene) << text;
    const Run deeper = runDgvIn(dir.path(), "--progress log render small.json --out part --resume");
    INFO("stderr: " << deeper.err);
    REQUIRE(deeper.exitCode == 0);
    CHECK_THAT(deeper.err, Catch::Contains("resume: kept 0 complete frames, rendered 4"));
    // The same scene by another path gives the same bytes (the key is the content, not the path).
    REQUIRE(runDgvIn(dir.path(), "-q render " + quote((dir.path() / "small.json").string()) + " --out abs").exitCode ==
            0);
    for (int f = 1; f <= 4; ++f)
        CHECK(readAll(dir.path() / "abs" / frameName(f)) == readAll(dir.path() / "part" / frameName(f)));
}

namespace {

/// `render small.json --movie --out m` in `dir` with a stand-in ffmpeg (a shell script whose
/// last argument is the movie's temporary) first on PATH.
/// With `alone`, PATH holds the stand-in's folder only (no ffprobe, whatever the machine has; the
/// script uses shell builtins).
Run renderMovieWith(const fs::path& dir, const std::string& ffmpegScript, bool alone = false) {
    fs::create_directories(dir);
    writeScene(dir, 2);
    fs::create_directories(dir / "bin");
    const fs::path fake = dir / "bin" / "ffmpeg";
    std::ofstream(fake) << "#!/bin/sh\nfor last; do :; done\n" << ffmpegScript;
    fs::permissions(fake, fs::perms::owner_all);
    return runDgvIn(dir, "render small.json --movie --out m",
                    "PATH=" + quote(dir / "bin") + (alone ? std::string() : ":\"$PATH\""));
}

/// A stand-in ffmpeg that makes the movie as a silent 4 KB stub, and answers the decode check
/// (`-f framecrc -`) with `decoded` frame lines.
std::string stubMovieScript(int decoded) {
    std::string s = "case \"$*\" in *framecrc*)\n";
    for (int i = 0; i < decoded; ++i) s += "  echo '0, " + std::to_string(i) + ", " + std::to_string(i) + ", 1, 100, 0x0'\n";
    return s + "  exit 0;;\nesac\nprintf '%4096s' x > \"$last\"\nexit 0\n";
}

}  // namespace

TEST_CASE("e2e: --movie does not trust ffmpeg's exit status: a broken movie is not kept", "[e2e][faults]") {
    // ffmpeg on a full disk prints "Error writing trailer ... No space left on device", exits 0
    // and leaves a few broken bytes. A stand-in does just that (no ffmpeg is needed for the test).
    test::TempDir dir("e2e_movie");
    const Run r = renderMovieWith(
        dir.path(),
        "printf 'x' > \"$last\"\necho \"Error writing trailer of $last: No space left on device\" >&2\nexit 0\n");
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 1);
    CHECK_THAT(r.err, Catch::Contains("ffmpeg failed making"));
    CHECK_THAT(r.err, Catch::Contains("No space left on device"));
    CHECK_THAT(r.err, Catch::Contains("the frames are complete"));
    CHECK(namesIn(dir.path() / "m") == frameNames(1, 2));  // no movie, no temporary, no log
}

TEST_CASE("e2e: --movie on a full disk names the full disk, though a log beside the movie would be lost",
          "[e2e][faults]") {
    // On a full disk ffmpeg's messages written to a file in the output folder are lost. The
    // stand-in drops its message when its stderr is a file, writes a 4 KB stub and exits 0.
    test::TempDir dir("e2e_movie_full");
    const Run r = renderMovieWith(dir.path(),
                                  "printf '%4096s' x > \"$last\"\n"
                                  "[ -f /proc/$$/fd/2 ] || echo \"Error writing trailer of $last: No space left on "
                                  "device\" >&2\nexit 0\n",
                                  true);
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 1);
    CHECK_THAT(r.err, Catch::Contains("(the disk is full: No space left on device); the frames are complete"));
    CHECK(namesIn(dir.path() / "m") == frameNames(1, 2));  // no movie, no temporary, no log
}

TEST_CASE("e2e: --movie without ffprobe checks the movie by decoding it with ffmpeg", "[e2e][faults]") {
    test::TempDir dir("e2e_movie_decode");
    // A silent ffmpeg that leaves a movie of one frame of two: refused.
    const Run bad = renderMovieWith(dir.path() / "bad", stubMovieScript(1), true);
    INFO("stderr: " << bad.err);
    CHECK(bad.exitCode == 1);
    CHECK_THAT(bad.err, Catch::Contains("(the movie decodes to 1 frames of 2); the frames are complete"));
    CHECK(namesIn(dir.path() / "bad" / "m") == frameNames(1, 2));
    // One that decodes to both frames: kept.
    const Run good = renderMovieWith(dir.path() / "good", stubMovieScript(2), true);
    INFO("stderr: " << good.err);
    CHECK(good.exitCode == 0);
    CHECK(fs::file_size(dir.path() / "good" / "m" / "small.mp4") == 4096);
}

TEST_CASE("e2e: SIGTERM while ffmpeg makes the movie ends the run as interrupted and keeps no movie", "[e2e][faults]") {
    // The ffmpeg step went on after a SIGTERM and exited 0 with "wrote the preview movie". The
    // stand-in sends dgv (whose pid ends the temporary's name) SIGTERM, then writes its output.
    test::TempDir dir("e2e_movie_term");
    const Run r = renderMovieWith(
        dir.path(), "pid=${last%.mp4}; pid=${pid##*-}\nkill -TERM \"$pid\"\nprintf 'x' > \"$last\"\nexit 0\n");
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 130);
    CHECK_THAT(r.err, Catch::Contains("interrupted"));
    CHECK_THAT(r.err, !Catch::Contains("wrote the preview movie"));
    CHECK(namesIn(dir.path() / "m") == frameNames(1, 2));  // no movie, no temporary, no log
}

TEST_CASE("e2e: a run killed by SIGTERM leaves complete frames and --resume finishes it byte-identically",
          "[e2e][resume][faults][slow]") {
    test::TempDir dir("e2e_kill");
    const int frames = 24;
    writeScene(dir.path(), frames);
    REQUIRE(runDgvIn(dir.path(), "-q render small.json --out full").exitCode == 0);
    // Start a run, wait for its second frame, then SIGTERM it (the shell reports dgv's exit code).
    const std::string killer = "( " + quote(DGV_EXE) +
                               " -q render small.json --out part & pid=$!; n=0; "
                               "while [ ! -e part/" +
                               frameName(2) +
                               " ] && [ $n -lt 400 ]; do sleep 0.05; n=$((n+1)); done; "
                               "kill -TERM $pid; wait $pid; echo $? > killed.rc ) 2> killed.err; true;";
    const Run setup = runDgvIn(dir.path(), "--version", killer);
    REQUIRE(setup.exitCode == 0);
    const int killedRc = std::stoi(readAll(dir.path() / "killed.rc"));
    const std::string killedErr = readAll(dir.path() / "killed.err");
    fs::remove(dir.path() / "killed.rc");
    fs::remove(dir.path() / "killed.err");
    const fs::path part = dir.path() / "part";
    const std::vector<std::string> left = namesIn(part);
    INFO("exit " << killedRc << ", " << left.size() << " files left, stderr: " << killedErr);
    // 130 (interrupted) with one line, or, on a very fast machine, 0 (finished before the signal).
    // Not 1: the handler removes the temporary being written, and that failed write is the
    // interruption, not an I/O error.
    CHECK((killedRc == 130 || killedRc == 0));
    if (killedRc == 130) {
        CHECK(lineCount(killedErr) == 1);
        CHECK_THAT(killedErr, Catch::Contains("interrupted"));
    }
    for (const std::string& name : left) {
        INFO(name);
        CHECK(name.front() != '.');                                          // no temporary left behind
        CHECK(readAll(part / name) == readAll(dir.path() / "full" / name));  // every frame left is complete
    }
    const Run r = runDgvIn(dir.path(), "--progress log render small.json --out part --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("resume: kept " + std::to_string(left.size()) + " complete frames"));
    CHECK(namesIn(part) == frameNames(1, frames));
    for (int f = 1; f <= frames; ++f) {
        INFO(frameName(f));
        CHECK(readAll(part / frameName(f)) == readAll(dir.path() / "full" / frameName(f)));
    }
}

// A run inside code that never polls for cancellation (here the VDB benchmark; in the field an
// import stuck in a library) still ends: a second SIGINT/SIGTERM exits at once, and the first
// one after a 10 s grace (docs/robustness.md; that path takes 10 s, so it is checked by hand).
TEST_CASE("e2e: a second signal ends a run at once, with one line and exit 130", "[e2e][faults]") {
    test::TempDir dir("e2e_signal2");
    const std::string killer =
        "( " + quote(DGV_EXE) +
        " bench vdb > bench.out & pid=$!; n=0; "
        "while ! grep -q bench.threads bench.out 2>/dev/null && [ $n -lt 400 ]; do sleep 0.05; n=$((n+1)); done; "
        "kill -TERM $pid; sleep 0.2; kill -INT $pid; wait $pid; echo $? > killed.rc ) 2> killed.err; true;";
    REQUIRE(runDgvIn(dir.path(), "--version", killer).exitCode == 0);
    const std::string err = readAll(dir.path() / "killed.err");
    INFO("stderr: " << err << "stdout: " << readAll(dir.path() / "bench.out"));
    CHECK(std::stoi(readAll(dir.path() / "killed.rc")) == 130);
    CHECK(lineCount(err) == 1);
    CHECK_THAT(err, Catch::Contains("dgv: interrupted"));
    // It stopped inside the benchmark: the figures of the full frame were never printed.
    CHECK_THAT(readAll(dir.path() / "bench.out"), !Catch::Contains("vdb.frame_seconds"));
}

namespace {

/// Forks `dgv render <dir>/small.json --out <dir>/o` with stderr into <dir>/<name>.err; with
/// `pendingTerm` the child first blocks SIGTERM and sends it to itself (pending across exec).
/// Everything the child needs is made before fork (only async-signal-safe calls after it).
pid_t spawnRender(const fs::path& dir, const std::string& name, bool pendingTerm) {
    const std::string log = (dir / (name + ".err")).string(), out = (dir / "o").string(),
                      scene = (dir / "small.json").string();
    const pid_t pid = fork();
    if (pid != 0) return pid;
    if (pendingTerm) {
        sigset_t term;
        sigemptyset(&term);
        sigaddset(&term, SIGTERM);
        sigprocmask(SIG_BLOCK, &term, nullptr);
        kill(getpid(), SIGTERM);
    }
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0 || dup2(fd, STDERR_FILENO) < 0) _exit(99);
    execl(DGV_EXE, DGV_EXE, "render", scene.c_str(), "--out", out.c_str(), static_cast<char*>(nullptr));
    _exit(98);
}

}  // namespace

TEST_CASE("e2e: a signal that reaches dgv before its own code runs ends the run as interrupted", "[e2e][faults]") {
    // A SIGTERM sent while dgv is still being loaded, held pending by a blocked mask (which exec
    // keeps): its handlers, installed before any library's constructor, take it, and the run
    // ends with one line and exit 130 instead of running to the end with the signal ignored.
    test::TempDir dir("e2e_signal_early");
    writeScene(dir.path(), 2);
    const pid_t pid = spawnRender(dir.path(), "early", true);
    REQUIRE(pid >= 0);
    int status = 0;
    REQUIRE(waitpid(pid, &status, 0) == pid);
    const std::string err = readAll(dir.path() / "early.err");
    INFO("stderr: " << err);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 130);
    CHECK(lineCount(err) == 1);
    CHECK_THAT(err, Catch::Contains("dgv: interrupted"));
    CHECK(!fs::exists(dir.path() / "o" / frameName(2)));
}

TEST_CASE("e2e: SIGTERM while dgv-core is still being loaded ends the run as interrupted", "[e2e][faults]") {
    // The launcher (dgv) execs dgv-core with the stop signals blocked; the loader then spends
    // about 90 ms on dgv-core's libraries before any of its code runs. A SIGTERM sent as soon as
    // the process is dgv-core lands in that time: it waits, blocked, for the handlers.
    test::TempDir dir("e2e_signal_loading");
    writeScene(dir.path(), 2);
    const pid_t pid = spawnRender(dir.path(), "loading", false);
    REQUIRE(pid >= 0);
    const std::string exe = "/proc/" + std::to_string(pid) + "/exe";
    bool core = false;
    for (int i = 0; i < 50000 && !core; ++i) {  // at most ~5 s
        char target[4096];
        const ssize_t n = readlink(exe.c_str(), target, sizeof target - 1);
        core = n > 0 && std::string(target, static_cast<std::size_t>(n)).find("dgv-core") != std::string::npos;
        if (!core) usleep(100);
    }
    kill(pid, SIGTERM);
    int status = 0;
    REQUIRE(waitpid(pid, &status, 0) == pid);
    const std::string err = readAll(dir.path() / "loading.err");
    INFO("stderr: " << err);
    CHECK(core);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 130);
    CHECK(lineCount(err) == 1);
    CHECK_THAT(err, Catch::Contains("dgv: interrupted"));
}

// A farm's hang-up and a closed pipe: SIGHUP stops a run as SIGTERM does (one line, exit 130,
// complete frames), and a reader of stderr that goes away (`dgv ... 2>&1 | head -1`) does not
// kill it: SIGPIPE is ignored, the writes to the pipe fail, the frames are written to the end.
TEST_CASE("e2e: SIGHUP stops a run like SIGTERM, a closed stderr pipe does not stop it", "[e2e][faults]") {
    test::TempDir dir("e2e_hup_pipe");
    const int frames = 6;
    writeScene(dir.path(), frames);
    const std::string piped =
        "( " + quote(DGV_EXE) +
        " --progress log render small.json --out piped 2>&1; echo $? > piped.rc ) | head -c 1 > /dev/null; true;";
    REQUIRE(runDgvIn(dir.path(), "--version", piped).exitCode == 0);
    CHECK(std::stoi(readAll(dir.path() / "piped.rc")) == 0);
    CHECK(namesIn(dir.path() / "piped") == frameNames(1, frames));
    const std::string hangUp = "( " + quote(DGV_EXE) +
                               " -q render small.json --out hup & pid=$!; n=0; "
                               "while [ ! -e hup/" +
                               frameName(1) +
                               " ] && [ $n -lt 400 ]; do sleep 0.05; n=$((n+1)); done; "
                               "kill -HUP $pid; wait $pid; echo $? > hup.rc ) 2> hup.err; true;";
    REQUIRE(runDgvIn(dir.path(), "--version", hangUp).exitCode == 0);
    const int rc = std::stoi(readAll(dir.path() / "hup.rc"));
    const std::string err = readAll(dir.path() / "hup.err");
    INFO("exit " << rc << ", stderr: " << err);
    CHECK((rc == 130 || rc == 0));  // 0 only if it finished before the signal
    if (rc == 130) {
        CHECK(lineCount(err) == 1);
        CHECK_THAT(err, Catch::Contains("interrupted"));
    }
    for (const std::string& name : namesIn(dir.path() / "hup")) CHECK(name.front() != '.');
}
