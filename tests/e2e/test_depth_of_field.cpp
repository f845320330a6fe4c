// Depth of field through `dgv render` (camera.depth_of_field; docs/rendering.md, "Depth of
// field"): a ball at the focus distance stays sharp, one behind it spreads by the thin lens's
// circle of confusion, and the keys are read and refused by name.

#include "e2e_run.hpp"

#include "base/errors.hpp"
#include "base/types.hpp"
#include "io/png.hpp"
#include "io/scene_json.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace dgv;
using namespace dgv::e2e;

namespace {

/// A ball of radius `radius` at depth z, seen from (0, 0, 3) looking down −z (fov 30, 320x240,
/// transparent background), in focus at 3 m with f-stop `fStop` (0: no depth of field).
std::string ballScene(Real z, Real radius, Real fStop) {
    char text[1024];
    std::snprintf(text, sizeof text, R"({"name": "dof", "frames": {"start": 1, "end": 1, "fps": 24},
  "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": %g}, "resolution": 8,
               "transform": {"translate": [0, 0, %g]}}],
  "camera": {"type": "look_at", "eye": [0, 0, 3], "target": [0, 0, 0], "fov": 30%s},
  "render": {"width": 320, "height": 240, "transparent": true, "ground": false}})",
                  radius, z,
                  fStop > 0 ? (R"(, "depth_of_field": {"f_stop": )" + std::to_string(fStop) + R"(, "samples": 32})").c_str()
                            : "");
    return text;
}

Image render(const fs::path& dir, const std::string& scene) {
    std::ofstream(dir / "s.json") << scene;
    fs::remove_all(dir / "out");
    const Run r = runDgvIn(dir, "-q render s.json --out out");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    return readPng(dir / "out" / "dof.0001.png");
}

}  // namespace

TEST_CASE("e2e: depth of field keeps the focus plane sharp and spreads the rest by the circle of confusion",
          "[e2e][depth_of_field]") {
    test::TempDir dir("e2e_dof");
    constexpr Real kPi = 3.14159265358979323846;
    const double threshold = 0.5 / 32;  // the outermost lens sample's share of a pixel
    SECTION("a ball at the focus distance: as sharp as without") {
        // Its silhouette lies r²/d = 5 cm in front of the focus plane, a circle of 0.27 pixels:
        // the half-coverage width is the same, the faintest edge a pixel wider on each side at most.
        const Image sharp = render(dir.path(), ballScene(0, 0.4, 0));
        const Image focused = render(dir.path(), ballScene(0, 0.4, 0.5));
        CHECK(std::abs(widestRun(focused, 0.5) - widestRun(sharp, 0.5)) <= 1);
        CHECK(std::abs(widestRun(focused, threshold) - widestRun(sharp, threshold)) <= 2);
    }
    SECTION("a ball 8 m away, focus at 3 m: wider by the circle of confusion") {
        const int sharp = widestRun(render(dir.path(), ballScene(-5, 0.4, 0)), threshold);
        const int blurred = widestRun(render(dir.path(), ballScene(-5, 0.4, 0.5)), threshold);
        // The lens: 36 mm across the 320-pixel side, so f = 18 mm / tan(hfov/2), hfov from 30
        // degrees high at 4:3; aperture radius f / (2 × 0.5). A point 8 m away spreads over a disc
        // of 2 R (8 − 3)/8 on the focus plane, 120 / (3 tan 15°) pixels a metre.
        const Real focal = 0.018 / (std::tan(15 * kPi / 180) * 4.0 / 3.0);
        const Real aperture = focal / (2 * 0.5);
        const Real circle = 2 * aperture * (8.0 - 3.0) / 8.0 * 120 / (3 * std::tan(15 * kPi / 180));
        // The 32 lens samples (a Vogel spiral) reach across that fraction of the disc along x:
        double lo = 0, hi = 0;
        for (int k = 0; k < 32; ++k) {
            const double x = std::sqrt((k + 0.5) / 32) * std::cos(k * kPi * (3 - std::sqrt(5.0)));
            lo = std::min(lo, x);
            hi = std::max(hi, x);
        }
        CHECK(blurred - sharp == Approx(circle * (hi - lo) / 2).epsilon(0.1));
    }
}

TEST_CASE("scene_json: camera.depth_of_field reads f_stop, focus_distance and samples", "[io][scene][depth_of_field]") {
    const SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
      "camera": {"type": "look_at", "eye": [0, 0, 3], "depth_of_field": {"f_stop": 2, "focus_distance": 2.5, "samples": 24}}})",
                                   "d.json");
    CHECK(s.camera.depthOfField);
    CHECK(s.camera.fStop == 2);
    CHECK(s.camera.focusDistance == 2.5);
    CHECK(s.camera.dofSamples == 24);
    CHECK_FALSE(parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}]})", "d.json").camera.depthOfField);
    auto error = [](const std::string& dof) {
        try {
            parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}], "camera": {"depth_of_field": )" + dof + "}}",
                       "d.json");
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    CHECK_THAT(error(R"({"f_stop": 0})"), Catch::Contains("camera.depth_of_field.f_stop"));
    CHECK_THAT(error(R"({"focus_distance": -1})"), Catch::Contains("camera.depth_of_field.focus_distance"));
    CHECK_THAT(error(R"({"samples": 1})"), Catch::Contains("camera.depth_of_field.samples"));
    CHECK_THAT(error(R"({"fstop": 2})"), Catch::Contains("camera.depth_of_field.fstop"));
}
