// State checkpoints of a moving scene (docs/robustness.md, "State checkpoints"): a run killed
// mid-way resumes from its last checkpoint to the same bytes as an uninterrupted run; render
// --frames A-B starts from a checkpoint instead of frame 1; truncated, corrupt and foreign
// checkpoints are skipped with a warning. A tiny scene (a tilted box of 6^3 points falling onto
// the ground, spinning; contacts from frame 4 on) keeps each run well under a second.

#include "e2e/e2e_run.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;

namespace {

constexpr int kFrames = 8;

/// The moving scene "drop.json" in `dir`; `gravity` changes the dynamics (another scene's
/// checkpoints), `vdb` turns the VDB cache on.
fs::path writeDropScene(const fs::path& dir, bool vdb, double gravity = 9.81) {
    const fs::path scene = dir / "drop.json";
    std::ofstream(scene) << R"({"name": "drop", "frames": {"start": 1, "end": )" << kFrames
                         << R"(, "fps": 24}, "substeps": 2,
  "objects": [{"name": "cube", "primitive": {"type": "box", "size": [0.4, 0.4, 0.4]},
               "transform": {"translate": [0, 0.29, 0], "rotate": [0, 0, 12]}, "resolution": 6,
               "color": [0.8, 0.3, 0.2], "material": {"damping": 1}, "spin": [0, 90, 0]}],
  "forces": [{"type": "gravity", "strength": )"
                         << gravity << R"(},
             {"type": "vortex", "position": [0.3, 0, 0], "axis": [0, 1, 0], "radius": 0.5, "strength": 3}],
  "colliders": [{"type": "ground", "height": 0, "friction": 0.5}],
  "camera": {"type": "look_at", "eye": [1.2, 0.8, 1.6], "target": [0, 0.2, 0], "fov": 40},
  "render": {"width": 64, "height": 48, "supersample": 1},
  "output": {"vdb": )" << (vdb ? "true" : "false")
                         << "}}\n";
    return scene;
}

std::string numbered(const char* pattern, int frame) {
    char buf[64];
    std::snprintf(buf, sizeof buf, pattern, frame);
    return buf;
}
std::string png(int f) { return numbered("drop.%04d.png", f); }
std::string vdb(int f) { return numbered("vdb/drop.%04d.vdb", f); }
std::string state(int f) { return numbered("state/drop.%04d.dgvstate", f); }

/// stats.csv without its column step_ms (the tenth: wall-clock time, the one column that differs
/// between two runs of the same scene; later columns follow it).
std::string statsWithoutTime(const fs::path& file) {
    std::istringstream in(readAll(file));
    std::string line, out;
    while (std::getline(in, line)) {
        std::size_t a = 0;
        for (int k = 0; k < 9 && a != std::string::npos; ++k) a = line.find(',', a + (k > 0 ? 1 : 0));
        const std::size_t b = a == std::string::npos ? a : line.find(',', a + 1);
        out +=
            (a == std::string::npos ? line : line.substr(0, a) + (b == std::string::npos ? "" : line.substr(b))) + "\n";
    }
    return out;
}

/// Column `i` of a CSV row.
std::string column(const std::string& row, int i) {
    std::istringstream in(row);
    std::string cell;
    for (int k = 0; k <= i; ++k) std::getline(in, cell, ',');
    return cell;
}

std::vector<std::string> lines(const std::string& text) {
    std::istringstream in(text);
    std::vector<std::string> v;
    for (std::string line; std::getline(in, line);) v.push_back(line);
    return v;
}

template <typename GridT>
bool sameValues(const openvdb::GridBase::Ptr& a, const openvdb::GridBase::Ptr& b) {
    const auto ga = openvdb::gridPtrCast<GridT>(a), gb = openvdb::gridPtrCast<GridT>(b);
    if (!ga || !gb || ga->activeVoxelCount() != gb->activeVoxelCount()) return false;
    if (ga->background() != gb->background()) return false;
    auto acc = gb->getConstAccessor();
    for (auto it = ga->cbeginValueOn(); it; ++it)
        if (!acc.isValueOn(it.getCoord()) || acc.getValue(it.getCoord()) != *it) return false;
    return true;
}

/// Two VDB files hold the same grids (names, types, transforms, grid metadata, every active
/// value); the header's random UUID is not compared.
bool sameVdbGrids(const fs::path& a, const fs::path& b) {
    openvdb::initialize();
    auto read = [](const fs::path& p) {
        openvdb::io::File file(p.string());
        file.open();
        auto grids = file.getGrids();
        file.close();
        return grids;
    };
    const auto ga = read(a), gb = read(b);
    if (ga->size() != gb->size()) return false;
    for (std::size_t i = 0; i < ga->size(); ++i) {
        const auto& x = (*ga)[i];
        const auto& y = (*gb)[i];
        if (x->getName() != y->getName() || x->valueType() != y->valueType() || x->transform() != y->transform())
            return false;
        if (static_cast<const openvdb::MetaMap&>(*x).str() != static_cast<const openvdb::MetaMap&>(*y).str())
            return false;
        const bool same = x->isType<openvdb::FloatGrid>()   ? sameValues<openvdb::FloatGrid>(x, y)
                          : x->isType<openvdb::Vec3SGrid>() ? sameValues<openvdb::Vec3SGrid>(x, y)
                                                            : false;
        if (!same) return false;
    }
    return true;
}

/// Every output of `dir` matches the uninterrupted run in `full`: frames byte for byte, stats.csv
/// but for step_ms, the VDB grids.
void checkSameOutputs(const fs::path& dir, const fs::path& full, bool pngs, bool vdbs) {
    for (int f = 1; f <= kFrames; ++f) {
        INFO("frame " << f);
        if (pngs) {
            const std::string a = readAll(full / png(f));
            REQUIRE(a.size() > 100);
            CHECK(readAll(dir / png(f)) == a);
        }
        if (vdbs) {
            REQUIRE(fs::exists(dir / vdb(f)));
            CHECK(sameVdbGrids(dir / vdb(f), full / vdb(f)));
        }
        if (f > 1) CHECK(fs::exists(dir / state(f)));
    }
    CHECK(lines(readAll(full / "stats.csv")).size() == kFrames + 1);
    CHECK(statsWithoutTime(dir / "stats.csv") == statsWithoutTime(full / "stats.csv"));
}

/// No hidden temporary is left anywhere under `dir`.
void checkNoTemporaries(const fs::path& dir) {
    for (const std::string& name : snapshot(dir)) {
        INFO(name);
        CHECK(fs::path(name).filename().string().front() != '.');
    }
}

}  // namespace

TEST_CASE("e2e: a moving scene's run cut after frame 4 resumes from its state checkpoint to the same bytes",
          "[e2e][resume][faults]") {
    test::TempDir dir("e2e_ckpt_cut");
    writeDropScene(dir.path(), true);
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out full").exitCode == 0);
    const fs::path full = dir.path() / "full";
    // The contacts make the volume projection rebuild its multigrid mid-run (a cache the
    // checkpoint must carry): frame 1 has none, the last frame some.
    const std::vector<std::string> stats = lines(readAll(full / "stats.csv"));
    REQUIRE(stats.size() == kFrames + 1);
    REQUIRE(column(stats[0], 7) == "contacts");
    CHECK(column(stats[1], 7) == "0");
    CHECK(std::stoi(column(stats.back(), 7)) > 0);

    // A run that stopped after frame 4: later frames, VDB files and checkpoints gone, and the
    // write of frame 5's checkpoint cut half-way.
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out part").exitCode == 0);
    const fs::path part = dir.path() / "part";
    const std::string keptStats = lines(readAll(part / "stats.csv"))[4];
    for (int f = 5; f <= kFrames; ++f) {
        fs::remove(part / png(f));
        fs::remove(part / vdb(f));
        if (f > 5) fs::remove(part / state(f));
    }
    fs::resize_file(part / state(5), fs::file_size(part / state(5)) / 2);
    // stats.csv as the stopped run left it: frames 1-4
    {
        std::string text;
        for (std::size_t i = 0; i <= 4; ++i) text += lines(readAll(part / "stats.csv"))[i] + "\n";
        std::ofstream(part / "stats.csv") << text;
    }

    const Run r = runDgvIn(dir.path(), "--progress log render drop.json --out part --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("resume: kept 4 complete frames, rendered 4"));
    CHECK_THAT(r.err,
               Catch::Contains("warning: ignored 1 state checkpoint (" + (part / state(5)).string() + ": truncated"));
    CHECK_THAT(r.err, Catch::Contains("resuming the simulation from frame 4 (" + (part / state(4)).string() + ")"));
    checkSameOutputs(part, full, true, true);
    // The rows of the restored frames are the stopped run's own (its step_ms included).
    CHECK(lines(readAll(part / "stats.csv"))[4] == keptStats);
    checkNoTemporaries(part);
}

TEST_CASE("e2e: a moving scene's render killed by SIGKILL resumes to the same bytes", "[e2e][resume][faults][slow]") {
    test::TempDir dir("e2e_ckpt_kill");
    writeDropScene(dir.path(), false);
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out full").exitCode == 0);
    // Start a render, wait for the checkpoint of frame 3, then SIGKILL it: no handler runs, so
    // a temporary being written may stay behind (a hidden name; never mistaken for a frame).
    const std::string killer = "( " + quote(DGV_EXE) +
                               " -q render drop.json --out part & pid=$!; n=0; "
                               "while [ ! -e part/" +
                               state(3) +
                               " ] && [ $n -lt 600 ]; do sleep 0.02; n=$((n+1)); done; "
                               "kill -KILL $pid; wait $pid; echo $? > killed.rc ) 2> killed.err; true;";
    REQUIRE(runDgvIn(dir.path(), "--version", killer).exitCode == 0);
    const int killedRc = std::stoi(readAll(dir.path() / "killed.rc"));
    INFO("killed run: exit " << killedRc << ", stderr: " << readAll(dir.path() / "killed.err"));
    CHECK((killedRc == 137 || killedRc == 0));  // 0: finished before the signal (a very fast machine)
    const fs::path part = dir.path() / "part";
    for (const std::string& name : snapshot(part)) {
        if (fs::path(name).filename().string().front() == '.' || fs::is_directory(part / name)) continue;
        if (name.find(".png") != std::string::npos) {
            INFO(name);
            CHECK(readAll(part / name) == readAll(dir.path() / "full" / name));  // every frame left is complete
        }
    }
    const Run r = runDgvIn(dir.path(), "--progress log render drop.json --out part --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    if (killedRc == 137) CHECK_THAT(r.err, Catch::Contains("resuming the simulation from frame"));
    checkSameOutputs(part, dir.path() / "full", true, false);
}

TEST_CASE("e2e: simulate --resume after SIGKILL gives the same stats.csv and VDB grids", "[e2e][resume][faults]") {
    test::TempDir dir("e2e_ckpt_sim");
    writeDropScene(dir.path(), true);
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out full").exitCode == 0);
    const std::string killer = "( " + quote(DGV_EXE) +
                               " -q simulate drop.json --out part & pid=$!; n=0; "
                               "while [ ! -e part/" +
                               state(2) +
                               " ] && [ $n -lt 600 ]; do sleep 0.01; n=$((n+1)); done; "
                               "kill -KILL $pid; wait $pid; echo $? > killed.rc ) 2> killed.err; true;";
    REQUIRE(runDgvIn(dir.path(), "--version", killer).exitCode == 0);
    const int killedRc = std::stoi(readAll(dir.path() / "killed.rc"));
    INFO("killed run: exit " << killedRc);
    CHECK((killedRc == 137 || killedRc == 0));
    const Run r = runDgvIn(dir.path(), "--progress log simulate drop.json --out part --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("resume: "));
    if (killedRc == 137) CHECK_THAT(r.err, Catch::Contains("resuming the simulation from frame"));
    checkSameOutputs(dir.path() / "part", dir.path() / "full", false, true);
    // Everything there: a second --resume restores the last frame and simulates nothing.
    const Run again = runDgvIn(dir.path(), "--progress log simulate drop.json --out part --resume");
    CHECK(again.exitCode == 0);
    CHECK_THAT(again.err, Catch::Contains("resume: frames 1-8 restored from the checkpoint, simulating 0 frames"));
    checkSameOutputs(dir.path() / "part", dir.path() / "full", false, true);
}

TEST_CASE("e2e: simulate --resume never keeps a truncated, emptied or foreign VDB file",
          "[e2e][resume][faults][slow]") {
    test::TempDir dir("e2e_ckpt_vdb");
    writeDropScene(dir.path(), true);
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out full").exitCode == 0);
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out part").exitCode == 0);
    const fs::path part = dir.path() / "part";
    // Frame 7 replaced by frame 3's file (complete, but another frame): the checkpoints of
    // frames 7 and 8 are not used, the run resumes from frame 6.
    fs::copy_file(part / vdb(3), part / vdb(7), fs::copy_options::overwrite_existing);
    const Run swapped = runDgvIn(dir.path(), "--progress log simulate drop.json --out part --resume");
    INFO("stderr: " << swapped.err);
    REQUIRE(swapped.exitCode == 0);
    CHECK_THAT(swapped.err, Catch::Contains("not used: the VDB file of frame 7 holds frame 3"));
    CHECK_THAT(swapped.err, Catch::Contains("resume: frames 1-6 restored from the checkpoint, simulating 2 frames"));
    checkSameOutputs(part, dir.path() / "full", false, true);
    // Frame 5 cut in half and frame 6 emptied: it resumes from frame 4.
    fs::resize_file(part / vdb(5), fs::file_size(part / vdb(5)) / 2);
    fs::resize_file(part / vdb(6), 0);
    const Run r = runDgvIn(dir.path(), "--progress log simulate drop.json --out part --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("not used: the VDB file of frame 5 is corrupt (its checksum does not match)"));
    CHECK_THAT(r.err, Catch::Contains("resume: frames 1-4 restored from the checkpoint, simulating 4 frames"));
    checkSameOutputs(part, dir.path() / "full", false, true);
}

TEST_CASE("e2e: simulate --resume finds a flipped bit anywhere in a VDB file before OpenVDB reads it",
          "[e2e][resume][faults]") {
    test::TempDir dir("e2e_ckpt_vdb_bit");
    writeDropScene(dir.path(), true);
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out full").exitCode == 0);
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out part").exitCode == 0);
    const fs::path part = dir.path() / "part";
    const std::string whole = readAll(part / vdb(6));
    // A bit in the file metadata, in the grids' topology (where OpenVDB 10's reader corrupted
    // its heap and aborted), in a compressed leaf (where its non-delayed reader accepted the
    // damage) and in the last byte: each is found and frames 6-8 are made again.
    for (const double at : {0.01, 0.05, 0.3, 0.6, 0.9, 1.0}) {
        const std::size_t i = std::min(whole.size() - 1, static_cast<std::size_t>(at * double(whole.size())));
        std::string flipped = whole;
        flipped[i] = static_cast<char>(flipped[i] ^ 0x10);
        std::ofstream(part / vdb(6), std::ios::binary) << flipped;
        const Run r = runDgvIn(dir.path(), "--progress log simulate drop.json --out part --resume");
        INFO("byte " << i << " of " << whole.size() << ", stderr: " << r.err);
        REQUIRE(r.exitCode == 0);
        CHECK_THAT(r.err, Catch::Contains("resume: 3 state checkpoints (frames 6-8) not used: the VDB file of frame 6"));
        CHECK_THAT(r.err, Catch::Contains("resume: frames 1-5 restored from the checkpoint, simulating 3 frames"));
        checkSameOutputs(part, dir.path() / "full", false, true);
    }
}

TEST_CASE("e2e: render --frames A-B of a moving scene starts from the checkpoint and equals a full render",
          "[e2e][resume][slow]") {
    test::TempDir dir("e2e_ckpt_range");
    writeDropScene(dir.path(), false);
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out full").exitCode == 0);
    // A render farm: simulate once, then render the shot in two pieces into one folder.
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out farm").exitCode == 0);
    const fs::path farm = dir.path() / "farm";
    fs::remove(farm / state(6));  // the piece 6-8 starts from frame 5's state, simulating frame 6
    const Run first = runDgvIn(dir.path(), "--progress log render drop.json --out farm --frames 1-5");
    REQUIRE(first.exitCode == 0);
    CHECK_THAT(first.err, !Catch::Contains("resuming the simulation"));  // frame 1 needs none
    const Run second = runDgvIn(dir.path(), "--progress log render drop.json --out farm --frames 6-8");
    INFO("stderr: " << second.err);
    REQUIRE(second.exitCode == 0);
    CHECK_THAT(second.err,
               Catch::Contains("resuming the simulation from frame 5 (" + (farm / state(5)).string() + ")"));
    checkSameOutputs(farm, dir.path() / "full", true, false);
    // Without checkpoints the same range simulates from frame 1: the same frames.
    const Run plain = runDgvIn(dir.path(), "--progress log render drop.json --out plain --frames 6-8");
    REQUIRE(plain.exitCode == 0);
    CHECK_THAT(plain.err, !Catch::Contains("resuming the simulation"));
    for (int f = 6; f <= 8; ++f) CHECK(readAll(dir.path() / "plain" / png(f)) == readAll(dir.path() / "full" / png(f)));
}

TEST_CASE("e2e: checkpoints of another scene, corrupt ones and foreign files are skipped with a warning",
          "[e2e][resume][faults][slow]") {
    test::TempDir dir("e2e_ckpt_foreign");
    writeDropScene(dir.path(), false);
    REQUIRE(runDgvIn(dir.path(), "-q simulate drop.json --out full").exitCode == 0);

    // Another scene of the same name (weaker gravity) left its checkpoints in the folder.
    test::TempDir other("e2e_ckpt_other");
    writeDropScene(other.path(), false, 4.0);
    REQUIRE(runDgvIn(other.path(), "-q simulate drop.json --out " + quote(dir.path() / "mixed")).exitCode == 0);
    const fs::path mixed = dir.path() / "mixed";
    const Run r = runDgvIn(dir.path(), "--progress log simulate drop.json --out mixed --resume");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("warning: ignored 7 state checkpoints (" + (mixed / state(8)).string() +
                                      ": of another scene or lattice; ...)"));
    CHECK_THAT(r.err, Catch::Contains("resume: no usable checkpoint, simulating 8 frames"));
    CHECK(statsWithoutTime(mixed / "stats.csv") == statsWithoutTime(dir.path() / "full" / "stats.csv"));

    // A flipped byte in the payload, and a file that is not a checkpoint at all.
    {
        std::fstream f(mixed / state(8), std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(static_cast<std::streamoff>(fs::file_size(mixed / state(8)) - 9));
        f.put('\x5a');
    }
    std::ofstream(mixed / state(7)) << "not a checkpoint\n";
    const Run again = runDgvIn(dir.path(), "--progress log simulate drop.json --out mixed --resume");
    INFO("stderr: " << again.err);
    REQUIRE(again.exitCode == 0);
    CHECK_THAT(again.err, Catch::Contains("warning: ignored 2 state checkpoints (" + (mixed / state(8)).string() +
                                          ": checksum mismatch (corrupt); ...)"));
    CHECK_THAT(again.err, Catch::Contains("resuming the simulation from frame 6"));
    CHECK(lineCount(again.err) >= 2);
    CHECK(statsWithoutTime(mixed / "stats.csv") == statsWithoutTime(dir.path() / "full" / "stats.csv"));
}
