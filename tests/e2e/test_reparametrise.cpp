// Goo re-parametrised in a run as a user runs it (docs/math.md, "Re-parametrisation"): a goo ball
// wound up by a vortex is re-voxelised several times, stats.csv counts each remap, every frame
// keeps the volume goals, and a run cut after a remap resumes from its checkpoint (which carries
// the new lattice and surface) to the same frames, byte for byte.

#include "e2e/e2e_run.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;

namespace {

constexpr int kFrames = 16;

// The notes' goo (no viscosity) in a vortex: the flow that outruns a fixed lattice.
fs::path writeSwirlScene(const fs::path& dir, bool reparametrise = true) {
    const fs::path scene = dir / "swirl.json";
    std::ofstream(scene) << R"({"name": "swirl", "frames": {"start": 1, "end": )" << kFrames
                         << R"(, "fps": 24}, "substeps": 2,
  "objects": [{"name": "goo", "primitive": {"type": "sphere", "radius": 0.3}, "resolution": 10,
               "color": [0.4, 0.7, 0.3], "material": {"preset": "goo", "damping": 1, "viscosity": 0, "reparametrise": )"
                         << (reparametrise ? "true" : "false") << R"(}}],
  "forces": [{"type": "vortex", "position": [0, 0, 0], "axis": [0, 1, 0], "radius": 0.12, "strength": 3}],
  "camera": {"type": "look_at", "eye": [0, 1.6, 1.4], "target": [0, 0, 0], "fov": 40},
  "render": {"width": 64, "height": 48, "supersample": 1}})";
    return scene;
}

std::string numbered(const char* pattern, int frame) {
    char buf[64];
    std::snprintf(buf, sizeof buf, pattern, frame);
    return buf;
}

/// stats.csv without its step_ms column (wall-clock time, the one that differs between runs).
std::string statsWithoutTime(const fs::path& file) {
    std::istringstream in(readAll(file));
    std::string out;
    for (std::string line; std::getline(in, line);) {
        std::istringstream cells(line);
        int k = 0;
        for (std::string cell; std::getline(cells, cell, ','); ++k)
            if (k != 9) out += cell + ",";
        out += "\n";
    }
    return out;
}

}  // namespace

TEST_CASE("e2e: goo in a vortex is re-parametrised, keeps the volume goals and resumes after a remap to the same bytes",
          "[e2e][reparametrise][resume][slow]") {
    test::TempDir dir("e2e_remap");
    writeSwirlScene(dir.path());
    const Run full = runDgvIn(dir.path(), "render swirl.json --out full");
    INFO("stderr: " << full.err);
    REQUIRE(full.exitCode == 0);
    CHECK_THAT(full.err, Catch::Contains("frame 7: object 'goo' re-voxelised in its current shape"));
    const auto rows = readStatsCsv(dir.path() / "full" / "stats.csv");
    REQUIRE(rows.size() == kFrames);
    int remaps = 0, firstRemap = 0;
    for (const auto& row : rows) {
        INFO("frame " << row.at("frame"));
        CHECK(row.at("max_cell_volume_error") <= 1e-4);
        CHECK(std::abs(row.at("total_volume_drift")) <= 1e-6);
        CHECK(row.at("inverted_cells") == 0);
        CHECK(row.at("torn_edges") == 0);
        remaps += static_cast<int>(row.at("reparametrisations"));
        if (row.at("reparametrisations") > 0 && firstRemap == 0) firstRemap = static_cast<int>(row.at("frame"));
    }
    CHECK(remaps >= 3);  // measured: 4, at frames 7, 10, 13 and 15
    CHECK(firstRemap == 7);

    // A run stopped after frame 8, one frame after the first remap: it resumes from that
    // frame's checkpoint, on the remapped lattice, to the same frames and rows.
    REQUIRE(runDgvIn(dir.path(), "-q render swirl.json --out part").exitCode == 0);
    const fs::path part = dir.path() / "part";
    for (int f = 9; f <= kFrames; ++f) {
        fs::remove(part / numbered("swirl.%04d.png", f));
        fs::remove(part / numbered("state/swirl.%04d.dgvstate", f));
    }
    const Run resumed = runDgvIn(dir.path(), "--progress log render swirl.json --out part --resume");
    INFO("resumed: " << resumed.err);
    REQUIRE(resumed.exitCode == 0);
    CHECK_THAT(resumed.err, Catch::Contains("resuming the simulation from frame 8"));
    for (int f = 1; f <= kFrames; ++f) {
        INFO("frame " << f);
        const std::string a = readAll(dir.path() / "full" / numbered("swirl.%04d.png", f));
        REQUIRE(a.size() > 100);
        CHECK(readAll(part / numbered("swirl.%04d.png", f)) == a);
    }
    CHECK(statsWithoutTime(part / "stats.csv") == statsWithoutTime(dir.path() / "full" / "stats.csv"));

    // material.reparametrise false keeps the lattice: no remap is counted.
    test::TempDir off("e2e_remap_off");
    writeSwirlScene(off.path(), false);
    const Run kept = runDgvIn(off.path(), "-q simulate swirl.json --out out --frames 8");
    REQUIRE(kept.exitCode == 0);
    for (const auto& row : readStatsCsv(off.path() / "out" / "stats.csv")) CHECK(row.at("reparametrisations") == 0);
}
