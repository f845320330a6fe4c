// dgv farm (docs/farm.md): the Slurm scripts submit writes (the dependency, the array range, the
// chunks' frames, no simulation job for a still scene), bad input refused with nothing written,
// status and resubmit from the files in the shot's folder, and render --farm-task, which restarts
// from the checkpoints without writing them. sbatch is a stand-in script on PATH that prints job
// ids: the real cluster is scripts/farm-test.sh.

#include "e2e/e2e_run.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <sys/stat.h>

#include <fstream>
#include <string>

using namespace dgv;
using namespace dgv::e2e;

namespace {

/// A moving scene of `frames` frames (a box falling onto the ground) in `dir`.
fs::path writeScene(const fs::path& dir, int frames, bool moving = true) {
    const fs::path scene = dir / "shot.json";
    std::ofstream(scene) << R"({"name": "shot", "frames": {"start": 1, "end": )" << frames << R"(, "fps": 24},
  "objects": [{"name": "cube", "primitive": {"type": "box", "size": [0.4, 0.4, 0.4]},
               "transform": {"translate": [0, 0.29, 0], "rotate": [0, 0, 12]}, "resolution": 6}],
  "forces": [)" << (moving ? R"({"type": "gravity", "strength": 9.81})" : "")
                         << R"(],
  "colliders": [{"type": "ground", "height": 0}],
  "camera": {"type": "look_at", "eye": [1.2, 0.8, 1.6], "target": [0, 0.2, 0], "fov": 40},
  "render": {"width": 32, "height": 24, "supersample": 1}}
)";
    return scene;
}

/// A stand-in sbatch in <dir>/bin: appends its arguments to <dir>/sbatch.log, prints the next id.
std::string fakeSbatch(const fs::path& dir) {
    fs::create_directories(dir / "bin");
    const fs::path bin = dir / "bin" / "sbatch";
    std::ofstream(bin) << "#!/bin/sh\necho \"$*\" >> " << quote(dir / "sbatch.log") << "\nn=$(wc -l < "
                       << quote(dir / "sbatch.log") << ")\necho $((100 + n))\n";
    chmod(bin.c_str(), 0755);
    return "PATH=" + quote(dir / "bin") + ":\"$PATH\";";
}

}  // namespace

TEST_CASE("farm: submit --dry-run prints the three jobs with their dependency and chunks", "[e2e][farm]") {
    test::TempDir dir("e2e_farm_dry");
    writeScene(dir.path(), 10);
    const auto before = snapshot(dir.path());
    const Run r = runDgvIn(dir.path(), "farm submit shot.json --chunk 4 --out out --partition render --dry-run");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.out, Catch::Contains("simulate.sbatch"));
    CHECK_THAT(r.out, Catch::Contains(" simulate ") && Catch::Contains("--resume"));
    CHECK_THAT(r.out, Catch::Contains("--dependency=afterok:<simulate>"));
    CHECK_THAT(r.out, Catch::Contains("#SBATCH --array=0-2\n"));  // 1-4, 5-8, 9-10
    CHECK_THAT(r.out, Catch::Contains("first=$(( 1 + task * 4 ))"));
    CHECK_THAT(r.out, Catch::Contains("if (( last > 10 )); then last=10; fi"));  // the last, partial chunk
    CHECK_THAT(r.out, Catch::Contains("--resume --farm-task"));
    CHECK_THAT(r.out, Catch::Contains("#SBATCH --partition='render'"));
    CHECK_THAT(r.out, Catch::Contains("farm status") && Catch::Contains("--check"));
    CHECK(snapshot(dir.path()) == before);  // nothing written
}

TEST_CASE("farm: a scene where nothing moves has no simulation job", "[e2e][farm]") {
    test::TempDir dir("e2e_farm_still");
    writeScene(dir.path(), 6, false);
    const Run r = runDgvIn(dir.path(), "farm submit shot.json --chunk 6 --out out --dry-run");
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.out, Catch::Contains("no simulation job"));
    CHECK_THAT(r.out, !Catch::Contains("simulate.sbatch"));
    CHECK_THAT(r.out, !Catch::Contains("afterok:<simulate>"));
    CHECK_THAT(r.out, Catch::Contains("#SBATCH --array=0-0\n"));
}

TEST_CASE("farm: bad input gets one line naming it, exit 2 and nothing written", "[e2e][farm][bad_input]") {
    test::TempDir dir("e2e_farm_bad");
    writeScene(dir.path(), 4);
    const std::string path = fakeSbatch(dir.path());
    const auto before = snapshot(dir.path());
    auto refused = [&](const std::string& args, const std::string& prefix, const std::string& says) {
        const Run r = runDgvIn(dir.path(), args, prefix);
        INFO(args << "\nstderr: " << r.err);
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains(says));
        CHECK(snapshot(dir.path()) == before);
    };
    refused("farm submit shot.json --chunk 0 --out out", path, "--chunk");
    refused("farm submit shot.json --chunk -3 --out out", path, "--chunk");
    refused("farm submit missing.json --chunk 4 --out out", path, "missing.json");
    refused("farm submit shot.json --chunk 4 --out out", "PATH=/nonexistent;", "sbatch is not on PATH");
    refused("farm status nowhere", "", "nowhere");
    // A folder that holds another shot's farm.
    REQUIRE(runDgvIn(dir.path(), "farm submit shot.json --chunk 2 --out out", path).exitCode == 0);
    fs::copy_file(dir.path() / "shot.json", dir.path() / "other.json");
    const auto submitted = snapshot(dir.path());
    const Run r = runDgvIn(dir.path(), "farm submit other.json --chunk 2 --out out", path);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Catch::Contains("another shot"));
    CHECK(snapshot(dir.path()) == submitted);
}

TEST_CASE("farm: submit hands sbatch the dependency, status reads the folder, resubmit covers only what is missing",
          "[e2e][farm]") {
    test::FpTrapsOff guard;
    test::TempDir dir("e2e_farm_status");
    writeScene(dir.path(), 6);
    const std::string path = fakeSbatch(dir.path());
    const Run s = runDgvIn(dir.path(), "farm submit shot.json --chunk 2 --out out", path);
    INFO(s.err);
    REQUIRE(s.exitCode == 0);
    CHECK(s.out == "simulate 101\nrender 102 (array 0-2, 2 frames each)\ncheck 103\n");
    const std::string log = readAll(dir.path() / "sbatch.log");
    CHECK_THAT(log, Catch::Contains("--parsable --dependency=afterok:101 " +
                                    (dir.path() / "out/farm/render.sbatch").string()));
    CHECK_THAT(
        log, Catch::Contains("--parsable --dependency=afterok:102 " + (dir.path() / "out/farm/check.sbatch").string()));

    // What the jobs would do: the simulation, then tasks 0 and 2 (frames 1-2 and 5-6).
    REQUIRE(runDgvIn(dir.path(), "-q simulate shot.json --out out").exitCode == 0);
    const auto stateBefore = snapshot(dir.path() / "out" / "state");
    const std::string statsBefore = readAll(dir.path() / "out" / "stats.csv");
    REQUIRE(runDgvIn(dir.path(), "-q render shot.json --out out --frames 1-2 --resume --farm-task").exitCode == 0);
    REQUIRE(runDgvIn(dir.path(), "-q render shot.json --out out --frames 5-6 --resume --farm-task").exitCode == 0);
    CHECK(snapshot(dir.path() / "out" / "state") == stateBefore);
    CHECK(readAll(dir.path() / "out" / "stats.csv") == statsBefore);  // the tasks wrote no stats
    // Frames from the checkpoints are those of a straight render.
    REQUIRE(runDgvIn(dir.path(), "-q render shot.json --out full").exitCode == 0);
    for (const char* f : {"shot.0001.png", "shot.0005.png", "shot.0006.png"})
        CHECK(readAll(dir.path() / "out" / f) == readAll(dir.path() / "full" / f));

    const Run st = runDgvIn(dir.path(), "farm status out");
    INFO(st.out);
    CHECK(st.exitCode == 0);
    CHECK_THAT(st.out, Catch::Contains("4 of 6 complete"));
    CHECK_THAT(st.out, Catch::Contains("render task 0 (frames 1-2): done"));
    CHECK_THAT(st.out, Catch::Contains("render task 1 (frames 3-4): not finished, 2 frames missing"));
    CHECK(runDgvIn(dir.path(), "farm status out --check").exitCode == 1);

    // Task 1 failed: its marker, and a half-written frame 3 (which does not count).
    std::ofstream(dir.path() / "out" / "farm" / "done" / "render.1") << "130\n";
    std::ofstream(dir.path() / "out" / "farm" / "done" / "simulate") << "0\n";
    std::ofstream(dir.path() / "out" / "shot.0003.png") << "\x89PNG";
    const Run failed = runDgvIn(dir.path(), "farm status out");
    CHECK_THAT(failed.out, Catch::Contains("render task 1 (frames 3-4): FAILED, 2 frames missing, exit 130"));
    CHECK_THAT(failed.out, Catch::Contains("dgv farm resubmit"));
    const Run re = runDgvIn(dir.path(), "farm resubmit out", path);
    INFO(re.err);
    REQUIRE(re.exitCode == 0);
    CHECK(re.out == "render 104 (tasks 1)\ncheck 105\n");
    CHECK_THAT(readAll(dir.path() / "sbatch.log"), Catch::Contains("--parsable --array=1 "));

    // The scene edited after the frames were made (weaker gravity): none of them is of this
    // version, so none counts, and resubmit covers every task (the frames were counted done
    // when status only read the frame number).
    std::string text = readAll(dir.path() / "shot.json");
    text.replace(text.find("9.81"), 4, "4.00");
    std::ofstream(dir.path() / "shot.json") << text;
    const Run stale = runDgvIn(dir.path(), "farm status out");
    CHECK_THAT(stale.out, Catch::Contains("0 of 6 complete"));
    const Run again = runDgvIn(dir.path(), "farm resubmit out --dry-run", path);
    CHECK_THAT(again.out, Catch::Contains("--array=0,1,2 "));
}

TEST_CASE("farm: a failed simulation shows in status as the reason the renders never ran", "[e2e][farm]") {
    test::TempDir dir("e2e_farm_simfail");
    writeScene(dir.path(), 4);
    REQUIRE(runDgvIn(dir.path(), "farm submit shot.json --chunk 2 --out out", fakeSbatch(dir.path())).exitCode == 0);
    std::ofstream(dir.path() / "out" / "farm" / "done" / "simulate") << "1\n";
    const Run st = runDgvIn(dir.path(), "farm status out");
    CHECK_THAT(st.out, Catch::Contains("simulate (job 101): FAILED, exit 1"));
    CHECK_THAT(st.out, Catch::Contains("render task 0 (frames 1-2): never ran (the simulation failed)"));
}
