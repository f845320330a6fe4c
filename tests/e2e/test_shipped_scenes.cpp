// A shipped scene run past its last frame (every shipped dynamics scene keeps the volume
// goals over 240 frames). `ring_drop`'s blob is putty (stiffness with a yield; docs/math.md,
// "Plasticity: the rest shape yields"): as goo it spread into a sheet thinner than the lattice
// and folded at frame 53, as jelly it faults at frame 38 wedged under the ring. The scene file is
// the shipped one, only `frames.end` raised and the ring's mesh path made absolute.
#include "e2e/e2e_run.hpp"
#include "geom/surface_check.hpp"
#include "io/mesh_cache.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;
namespace fs = std::filesystem;

namespace {

using Rows = std::vector<std::map<std::string, double>>;

/// The shipped scene `name` with `frames.end` raised to `frames` and its mesh colliders' paths
/// made absolute, simulated in `dir`; its stats.csv rows (empty, with the error, if it failed).
Rows runShipped(const test::TempDir& dir, const std::string& name, int frames) {
    nlohmann::json scene = nlohmann::json::parse(readAll(test::sourcePath("scenes/" + name + ".json")));
    scene["frames"]["end"] = frames;
    if (scene.contains("colliders"))
        for (auto& c : scene["colliders"])
            if (c.contains("mesh")) c["mesh"] = test::sourcePath("scenes/" + c["mesh"].get<std::string>()).string();
    for (auto& o : scene["objects"])
        if (o.contains("mesh")) o["mesh"] = test::sourcePath("scenes/" + o["mesh"].get<std::string>()).string();
    std::ofstream(dir.path() / (name + ".json")) << scene.dump(2);
    const Run r = runDgvIn(dir.path(), "-q simulate " + name + ".json --out o");
    INFO(r.err);
    CHECK(r.exitCode == 0);
    return r.exitCode == 0 ? readStatsCsv(dir.path() / "o" / "stats.csv") : Rows();
}

/// The volume goals' figures over the rows, and the largest kinetic energy.
struct Figures {
    double maxErr = 0, maxDrift = 0, inverted = 0, peakEnergy = 0;
};
Figures figuresOf(const Rows& rows) {
    Figures f;
    for (const auto& row : rows) {
        f.maxErr = std::max(f.maxErr, row.at("max_cell_volume_error"));
        f.maxDrift = std::max(f.maxDrift, std::abs(row.at("total_volume_drift")));
        f.inverted = std::max(f.inverted, row.at("inverted_cells"));
        f.peakEnergy = std::max(f.peakEnergy, row.at("kinetic_energy"));
    }
    return f;
}

/// The volume goals of every shipped dynamics scene: max cell error ≤ 1e-4, |total drift| ≤ 1e-6,
/// no inverted cell.
void checkVolumeGoals(const Figures& f) {
    CHECK(f.maxErr <= 1e-4);
    CHECK(f.maxDrift <= 1e-6);
    CHECK(f.inverted == 0);
}

}  // namespace

TEST_CASE("e2e: the default scene's jelly lands on its plate, wobbles and rests within the volume goals",
          "[e2e][scene][slow]") {
    test::TempDir dir("e2e_default");
    // The jelly mould has no material settings: it is the jelly preset (scenes/README.md).
    REQUIRE_FALSE(
        nlohmann::json::parse(readAll(test::sourcePath("scenes/default.json")))["objects"][0].contains("material"));
    const Rows rows = runShipped(dir, "default", 72);
    REQUIRE(rows.size() == 72);
    checkVolumeGoals(figuresOf(rows));  // measured: max cell error 1.0e-5, drift ≤ 5e-7
    // The landing throws its squash back: after the first contact (frame 6, 62 J) the kinetic
    // energy dips into the squash and comes back above half of it (measured 28 → 54 J at frame
    // 13, the jelly's rebound with the ball still falling) before it dies away.
    int landing = -1;
    for (std::size_t i = 0; i < rows.size() && landing < 0; ++i)
        if (rows[i].at("contacts") > 0) landing = static_cast<int>(i);
    REQUIRE(landing > 0);
    const double impact = rows[static_cast<std::size_t>(landing)].at("kinetic_energy");
    double dip = impact, rebound = 0;
    for (std::size_t i = static_cast<std::size_t>(landing); i < static_cast<std::size_t>(landing) + 8; ++i) {
        dip = std::min(dip, rows[i].at("kinetic_energy"));
        if (dip < impact) rebound = std::max(rebound, rows[i].at("kinetic_energy"));
    }
    CHECK(dip < 0.6 * impact);
    CHECK(rebound > 0.5 * impact);
    CHECK(rows.back().at("kinetic_energy") < 1e-3);  // at rest (measured 3.2e-5 J)
    CHECK(rows.back().at("contacts") > 0);           // on the plate and the ground
}

TEST_CASE("e2e: ring_drop's putty blob runs 240 frames within the volume goals and comes to rest",
          "[e2e][scene][plastic][slow]") {
    test::TempDir dir("e2e_ring_drop");
    REQUIRE(nlohmann::json::parse(readAll(test::sourcePath("scenes/ring_drop.json")))["objects"][0]["material"]["yield"]
                .get<double>() > 0);
    const Rows rows = runShipped(dir, "ring_drop", 240);
    REQUIRE(rows.size() == 240);
    const Figures f = figuresOf(rows);
    checkVolumeGoals(f);  // measured: max cell error 2.0e-6, drift 6.6e-8
    // At rest under the ring over the last two seconds. At damping 1 (the scene's earlier value)
    // the resting putty jittered, its median kinetic energy over frames 193-240 4.8e-4 J on one
    // machine, 1.2e-3 J on another and 8.0e-4 J with glibc's libm made to skip its FMA code
    // (chaotic: a last bit anywhere changed it), and run on it faulted at frame 271 on the rim
    // of its puddle (docs/math.md, "What the step does not do yet"). At 1.5 it settles the same
    // way under either libm, to 1.3e-7 J by frame 480.
    std::vector<double> resting;
    for (std::size_t i = rows.size() - 48; i < rows.size(); ++i) resting.push_back(rows[i].at("kinetic_energy"));
    std::sort(resting.begin(), resting.end());
    CHECK(resting[24] < 1e-3);     // the median (measured 1.9e-4 J, still decaying; 478 J at frame 13 as it fell)
    CHECK(resting.back() < 2e-3);  // no kick, no jitter (measured 3.8e-4 J; at damping 1, 1e-2 to 3.4e-2 J)
    CHECK(rows.back().at("contacts") > 0);  // on the ground
}

TEST_CASE("e2e: jelly_cantilever sags under gravity, wobbles and comes to rest within the volume goals",
          "[e2e][scene][load][slow]") {
    // A jelly bar held at one end (docs/math.md, "A pinned body under a uniform load"): before
    // the load modes the pins held it rigid, kinetic energy exactly 0 on every frame.
    // 480 frames: at rest the tree's frames grew its twist from round-off (Σ|δΓ|² 1e-10 at
    // frame 240, 2.3e-8 at 480, 2e-5 at 1440) before the frame sweeps ran on pinned bodies.
    test::TempDir dir("e2e_jelly_cantilever");
    const Rows rows = runShipped(dir, "jelly_cantilever", 480);
    REQUIRE(rows.size() == 480);
    const Figures f = figuresOf(rows);
    checkVolumeGoals(f);                                          // measured: max cell error 5.1e-6, drift 3.8e-7
    CHECK(f.peakEnergy > 0.5);                                    // it falls into its sag (measured 0.78 J at frame 13)
    CHECK(rows[239].at("kinetic_energy") < 1e-4 * f.peakEnergy);  // and rests there (measured 3.8e-7 J)
    double restingTwist = 0;
    for (std::size_t i = 239; i < rows.size(); ++i) restingTwist = std::max(restingTwist, rows[i].at("sum_dgamma2"));
    CHECK(restingTwist < 1e-10);  // measured 5.4e-12
}

TEST_CASE("e2e: material.pinned_load false keeps a pinned body rigid under gravity, as the notes' step does",
          "[e2e][scene][load]") {
    test::TempDir dir("e2e_pinned_load_off");
    nlohmann::json scene = nlohmann::json::parse(readAll(test::sourcePath("scenes/jelly_cantilever.json")));
    scene["frames"]["end"] = 12;
    scene["objects"][0]["material"]["pinned_load"] = false;
    std::ofstream(dir.path() / "off.json") << scene.dump(2);
    const Run r = runDgvIn(dir.path(), "-q simulate off.json --out o");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const Rows rows = readStatsCsv(dir.path() / "o" / "stats.csv");
    REQUIRE(rows.size() == 12);
    // the shape memory's answer to the round-off of the rest connection aside (measured ≤ 9e-28 J)
    CHECK(figuresOf(rows).peakEnergy < 1e-20);
}

TEST_CASE("e2e: a jelly hanging from a small pin that faults says how to hold it rigid", "[e2e][scene][load][slow]") {
    // docs/math.md, "What the step does not do yet": a ball held by a sphere pin of 1.6 voxels
    // under gravity folds within frames (measured: its surface flips at frame 20 at every
    // substep count up to 64, caught before the frame is written; the step itself faulted at
    // frame 24); the line names the way out.
    test::TempDir dir("e2e_small_pin");
    const std::string scene = R"({"name": "hang", "frames": {"start": 1, "end": 72, "fps": 24}, "substeps": 2,
        "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.2}, "resolution": 16,
                     "transform": {"translate": [0, 0.6, 0]},
                     "material": {"density": 1000, "damping": 2, "stiffness": 100},
                     "pin": {"centre": [0, 0.8, 0], "radius": 0.04}}],
        "forces": [{"type": "gravity"}]})";
    std::ofstream(dir.path() / "hang.json") << scene;
    const Run r = runDgvIn(dir.path(), "-q simulate hang.json --out o");
    INFO(r.err);
    CHECK(r.exitCode == 1);
    CHECK(r.err.find("object 'ball'") != std::string::npos);
    CHECK(r.err.find("material.pinned_load to false") != std::string::npos);
    // Never a torn frame (docs/math.md, "Never a torn frame"): the frame that failed left no row,
    // no checkpoint; the frames before it are all there.
    const std::size_t at = r.err.find("nothing of frame ");
    REQUIRE(at != std::string::npos);
    const int failed = std::stoi(r.err.substr(at + 17));
    CHECK(failed > 2);
    const Rows rows = readStatsCsv(dir.path() / "o" / "stats.csv");
    CHECK(rows.size() == static_cast<std::size_t>(failed - 1));
    char name[64];
    std::snprintf(name, sizeof name, "hang.%04d.dgvstate", failed - 1);
    CHECK(std::filesystem::exists(dir.path() / "o" / "state" / name));
    std::snprintf(name, sizeof name, "hang.%04d.dgvstate", failed);
    CHECK_FALSE(std::filesystem::exists(dir.path() / "o" / "state" / name));
    for (const auto& row : rows) {  // the sphere primitive has 3,968 triangles
        CHECK(row.at("flipped_triangles") <= kMaxFlippedFraction * 3968);
        CHECK(row.at("torn_edges") == 0);
    }
    // and so set, it holds
    nlohmann::json rigid = nlohmann::json::parse(scene);
    rigid["objects"][0]["material"]["pinned_load"] = false;
    rigid["frames"]["end"] = 24;
    std::ofstream(dir.path() / "rigid.json") << rigid.dump(2);
    const Run ok = runDgvIn(dir.path(), "-q simulate rigid.json --out o2");
    INFO(ok.err);
    CHECK(ok.exitCode == 0);
}

TEST_CASE("e2e: goo_viscosity's thick ball lands as a mound and stays taller than the thin one's puddle",
          "[e2e][scene][viscosity][slow]") {
    // docs/math.md, "Viscosity: the viscous stress at every scale": two goo balls differing only
    // in material.viscosity (1 against 1e-6 m²/s), their surfaces read back from the mesh cache.
    test::TempDir dir("e2e_goo_viscosity");
    const Run r = runDgvIn(
        dir.path(), "-q simulate " + quote(test::sourcePath("scenes/goo_viscosity.json")) + " --mesh ply --out o");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const Rows rows = readStatsCsv(dir.path() / "o" / "stats.csv");
    REQUIRE(rows.size() == 72);
    checkVolumeGoals(figuresOf(rows));  // measured: max cell error 9.6e-6, drift 2.2e-7
    auto extent = [&](const std::string& object, int frame) {
        char name[64];
        std::snprintf(name, sizeof name, "%s.%04d.ply", object.c_str(), frame);
        const MeshCacheData m = readMeshCacheFrame(dir.path() / "o" / "mesh" / name);
        Vec3 lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30);
        for (const Vec3& p : m.positions) {
            lo = lo.cwiseMin(p);
            hi = hi.cwiseMax(p);
        }
        return Vec3(hi - lo);  // x: width, y: height
    };
    const Vec3 thick = extent("thick", 72), thin = extent("thin", 72);
    INFO("frame 72: thick " << thick.y() << " m high, " << thick.x() << " m wide; thin " << thin.y() << " high, "
                            << thin.x() << " wide");
    CHECK(thick.y() > 2 * thin.y());        // measured 0.231 and 0.088 m (both 0.5 m at frame 1)
    CHECK(thin.x() > 1.5 * thick.x());      // measured 1.38 and 0.75 m
    CHECK(extent("thick", 24).y() > 0.33);  // still a mound a second after landing (measured 0.37)
}

TEST_CASE("e2e: the drawn surface stays out of the static colliders, frame by frame", "[e2e][collider]") {
    // A jelly ball dropped onto a sphere collider rolls off it onto the ground. Its lattice
    // points sink into both by up to about a voxel at the landings (the step's contact layer);
    // the mesh cache, which is what the frames draw, has no vertex inside either.
    test::TempDir dir("e2e_drawn_surface");
    std::ofstream(dir.path() / "s.json") << R"({"name": "drape", "frames": {"start": 1, "end": 30, "fps": 24},
  "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.25}, "resolution": 10,
               "transform": {"translate": [0.08, 0.95, 0]}, "material": {"preset": "jelly"}}],
  "forces": [{"type": "gravity"}],
  "colliders": [{"type": "sphere", "centre": [0, 0.3, 0], "radius": 0.3}, {"type": "ground"}],
  "output": {"mesh": "ply"}})";
    const Run r = runDgvIn(dir.path(), "-q simulate s.json --out o");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    double lowest = 1e9, nearest = 1e9;
    for (int f = 1; f <= 30; ++f) {
        char name[64];
        std::snprintf(name, sizeof name, "o/mesh/ball.%04d.ply", f);
        const MeshCacheData d = readMeshCacheFrame(dir.path() / name);
        for (const Vec3& v : d.positions) {
            lowest = std::min(lowest, v.y());
            nearest = std::min(nearest, (v - Vec3(0, 0.3, 0)).norm());
        }
    }
    CHECK(lowest >= -1e-5);
    CHECK(nearest >= 0.3 - 1e-5);
    CHECK(lowest < 0.01);  // it did reach the ground
}

TEST_CASE("e2e: a plane collider is a wall at any orientation: a jelly thrown at it stays on its side",
          "[e2e][collider]") {
    // A jelly ball thrown at 3 m/s into a wall tilted 20 degrees from the vertical: its surface
    // reaches the wall and never passes it, its lattice points stay within the contact layer, and
    // it comes back off the wall (the throw's momentum is not lost into the wall).
    test::TempDir dir("e2e_plane_wall");
    const Real tilt = 20 * 3.14159265358979323846 / 180;
    const Vec3 normal(-std::cos(tilt), std::sin(tilt), 0);
    char scene[1024];
    std::snprintf(scene, sizeof scene, R"({"name": "wall", "frames": {"start": 1, "end": 18, "fps": 24},
  "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.2}, "resolution": 10,
               "transform": {"translate": [-0.35, 1, 0]}, "velocity": [3, 0, 0], "material": {"preset": "jelly"}}],
  "colliders": [{"type": "plane", "point": [0.2, 1, 0], "normal": [%.9f, %.9f, 0]}],
  "output": {"mesh": "ply"}})",
                  normal.x(), normal.y());
    std::ofstream(dir.path() / "s.json") << scene;
    const Run r = runDgvIn(dir.path(), "-q simulate s.json --out o");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    double closest = 1e9, firstX = 0, lastX = 0;
    for (int f = 1; f <= 18; ++f) {
        char name[64];
        std::snprintf(name, sizeof name, "o/mesh/ball.%04d.ply", f);
        const MeshCacheData d = readMeshCacheFrame(dir.path() / name);
        Vec3 c = Vec3::Zero();
        for (const Vec3& v : d.positions) {
            closest = std::min(closest, normal.dot(v - Vec3(0.2, 1, 0)));
            c += v / static_cast<double>(d.positions.size());
        }
        (f == 1 ? firstX : lastX) = c.x();
    }
    CHECK(closest >= -1e-5);  // the drawn surface never passes the wall
    CHECK(closest < 0.01);    // and it did reach it
    CHECK(lastX < firstX + 0.4);  // thrown 3 m/s × 0.7 s = 2.1 m if it had passed; it came back
    const Rows rows = readStatsCsv(dir.path() / "o" / "stats.csv");
    double deepest = 0;
    for (const auto& row : rows) deepest = std::max(deepest, row.at("max_penetration"));
    CHECK(deepest < 1.0);  // voxels: the lattice within its contact layer
}
