// Motion blur through `dgv render` (render.motion_blur; docs/rendering.md, "Motion blur"): a ball
// thrown across the view is smeared by the distance it travels while the shutter is open, a still
// shot draws exactly the frames it draws without blur, a turntable blurs with its camera, and a
// range of frames equals the same frames of the whole shot.

#include "e2e_run.hpp"

#include "base/types.hpp"
#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace dgv;
using namespace dgv::e2e;

namespace {

/// A 0.4 m ball thrown along x at `speed` m/s with nothing acting on it, seen side on from 3 m
/// (fov 30: 149 pixels a metre at the ball's depth, 240 pixels high), transparent background.
std::string throwScene(Real speed, const std::string& blur) {
    return R"({"name": "mb", "frames": {"start": 1, "end": 6, "fps": 24},
  "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.2}, "resolution": 10,
               "transform": {"translate": [-0.6, 0, 0]}, "velocity": [)" +
           std::to_string(speed) + R"(, 0, 0]}],
  "camera": {"type": "look_at", "eye": [0, 0, 3], "target": [0, 0, 0], "fov": 30},
  "render": {"width": 320, "height": 240, "transparent": true, "ground": false)" +
           blur + "}}";
}

Image renderFrame(const fs::path& dir, const std::string& scene, const std::string& frames, int frame) {
    std::ofstream(dir / "s.json") << scene;
    const Run r = runDgvIn(dir, "-q render s.json --frames " + frames + " --out out");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    char name[32];
    std::snprintf(name, sizeof name, "mb.%04d.png", frame);
    return readPng(dir / "out" / name);
}

}  // namespace

TEST_CASE("e2e: motion blur smears a thrown ball by shutter times speed", "[e2e][motion_blur]") {
    test::TempDir dir("e2e_motion_blur");
    const Real speed = 4;
    const Image sharp = renderFrame(dir.path(), throwScene(speed, ""), "5", 5);
    for (const Real shutter : {180.0, 90.0}) {
        INFO("shutter " << shutter);
        fs::remove_all(dir.path() / "out");
        const Image blurred = renderFrame(
            dir.path(), throwScene(speed, R"(, "motion_blur": {"shutter": )" + std::to_string(shutter) + "}"), "5", 5);
        // The ball's extent along x grows by the travel: the outermost samples' coverage is 1/n
        // of a pixel's alpha (n = 8 samples at most), so the smear is measured down to half that.
        const Real pixelsPerMetre = 120 / (3 * std::tan(15 * 3.14159265358979323846 / 180));
        const Real travel = speed * (shutter / 360) / 24 * pixelsPerMetre;
        const int grown = widestRun(blurred, 0.5 / 8) - widestRun(sharp, 0.5 / 8);
        CHECK(grown == Approx(travel).epsilon(0.1));
        // and the ball's middle is not a copy of the sharp frame
        CHECK(blurred.rgba != sharp.rgba);
    }
}

TEST_CASE("e2e: motion blur leaves still frames byte-identical, and a range equals the whole shot",
          "[e2e][motion_blur][determinism]") {
    test::TempDir dir("e2e_motion_blur_still");
    SECTION("nothing moves: the frames without blur, byte for byte") {
        const std::string still = throwScene(0, R"(, "motion_blur": true)");
        const Image a = renderFrame(dir.path(), still, "4", 4);
        fs::remove_all(dir.path() / "out");
        const Image b = renderFrame(dir.path(), throwScene(0, ""), "4", 4);
        CHECK(a.rgba == b.rgba);
    }
    SECTION("frames 4-5 of the thrown ball equal frames 4-5 of 1-6") {
        const std::string scene = throwScene(3, R"(, "motion_blur": true)");
        renderFrame(dir.path(), scene, "1-6", 6);
        const std::string whole4 = readAll(dir.path() / "out" / "mb.0004.png");
        const std::string whole5 = readAll(dir.path() / "out" / "mb.0005.png");
        fs::remove(dir.path() / "out" / "mb.0004.png");
        fs::remove(dir.path() / "out" / "mb.0005.png");
        renderFrame(dir.path(), scene, "4-5", 5);
        CHECK(readAll(dir.path() / "out" / "mb.0004.png") == whole4);
        CHECK(readAll(dir.path() / "out" / "mb.0005.png") == whole5);
    }
}

TEST_CASE("e2e: a turntable's camera blurs a shape at rest", "[e2e][motion_blur]") {
    test::TempDir dir("e2e_motion_blur_turntable");
    auto scene = [](const std::string& blur) {
        return R"({"name": "mb", "frames": {"start": 1, "end": 24, "fps": 24},
  "objects": [{"name": "box", "primitive": {"type": "box", "size": [0.6, 0.3, 0.4]}, "resolution": 10}],
  "camera": {"type": "turntable", "degrees": 360, "elevation": 20, "fov": 30},
  "render": {"width": 160, "height": 120)" +
               blur + "}}";
    };
    const Image sharp = renderFrame(dir.path(), scene(""), "3", 3);
    fs::remove_all(dir.path() / "out");
    const Image blurred = renderFrame(dir.path(), scene(R"(, "motion_blur": true)"), "3", 3);
    // 15 degrees a frame: the box's silhouette sweeps several pixels while the shutter is open
    long changed = 0;
    for (std::size_t i = 0; i < sharp.rgba.size(); i += 4) changed += sharp.rgba[i] != blurred.rgba[i];
    CHECK(changed > 300);
}

TEST_CASE("e2e: --motion-blur off draws the sharp frames, and --resume does not keep them for a blurred render",
          "[e2e][motion_blur][resume]") {
    test::TempDir dir("e2e_motion_blur_flag");
    const Image sharp = renderFrame(dir.path(), throwScene(4, ""), "5", 5);
    std::ofstream(dir.path() / "s.json") << throwScene(4, R"(, "motion_blur": true)");
    fs::remove_all(dir.path() / "out");
    const Run off = runDgvIn(dir.path(), "-q render s.json --frames 5 --out out --motion-blur off");
    REQUIRE(off.exitCode == 0);
    CHECK(readPng(dir.path() / "out" / "mb.0005.png").rgba == sharp.rgba);
    const Run on = runDgvIn(dir.path(), "render s.json --frames 5 --out out --resume");
    INFO("stderr: " << on.err);
    CHECK(on.exitCode == 0);
    CHECK_THAT(on.err, Catch::Contains("kept 0 complete frames, rendered 1"));
    CHECK(readPng(dir.path() / "out" / "mb.0005.png").rgba != sharp.rgba);
}
