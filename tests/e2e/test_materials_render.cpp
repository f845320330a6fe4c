// A mesh file's own look through `dgv render` (docs/rendering.md, "Materials from the file"): a
// box whose front carries a texture and whose other faces an MTL colour, at rest and dropped as
// jelly (the texture rides with the deforming surface), the scene's `color` overriding it, and a
// texture that is not there as one warning with the shot still rendered.

#include "e2e_run.hpp"

#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

using namespace dgv;
using namespace dgv::e2e;

namespace {

// A 0.4 m box, its front (+z) face textured (u across, v up), its other faces "side" (Kd green).
const char* kBoxObj =
    "mtllib box.mtl\n"
    "v -0.2 0 -0.2\nv 0.2 0 -0.2\nv 0.2 0.4 -0.2\nv -0.2 0.4 -0.2\n"
    "v -0.2 0 0.2\nv 0.2 0 0.2\nv 0.2 0.4 0.2\nv -0.2 0.4 0.2\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "usemtl front\nf 5/1 6/2 7/3 8/4\n"
    "usemtl side\nf 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// The front's texture: 16x16, its left half red and its right half blue.
void writeTexture(const fs::path& p) {
    Image img(16, 16);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            std::uint16_t* px = img.pixel(x, y);
            px[0] = x < 8 ? 65535 : 0;
            px[2] = x < 8 ? 0 : 65535;
            px[3] = 65535;
        }
    writePng(p, img);
}

/// The scene: `objectExtra` inside the object, `extra` at the top level.
std::string scene(const std::string& objectExtra, const std::string& extra) {
    return R"({"name": "tex", "frames": {"start": 1, "end": 14, "fps": 24},
  "objects": [{"name": "box", "mesh": "box.obj", "resolution": 10)" +
           objectExtra + R"(}],
  "camera": {"type": "look_at", "eye": [0.6, 0.9, 1.3], "target": [0, 0.2, 0], "fov": 35},
  "render": {"width": 96, "height": 72})" +
           extra + "}";
}

/// Pixels whose red, green or blue channel is over twice both others (8-bit codes).
struct Tally {
    int red = 0, green = 0, blue = 0;
};
Tally tally(const Image& img) {
    Tally t;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const std::uint16_t* p = img.pixel(x, y);
            const int r = to8bit(p[0]), g = to8bit(p[1]), b = to8bit(p[2]);
            t.red += r > 2 * g && r > 2 * b;
            t.green += g > 2 * r && g > 2 * b;
            t.blue += b > 2 * r && b > 2 * g;
        }
    return t;
}

void writeFiles(const fs::path& dir, const std::string& mtlMap) {
    std::ofstream(dir / "box.obj") << kBoxObj;
    std::ofstream(dir / "box.mtl") << "newmtl front\nKd 1 1 1\nmap_Kd " << mtlMap << "\nnewmtl side\nKd 0.02 0.6 0.02\n";
    writeTexture(dir / "rb.png");
}

}  // namespace

TEST_CASE("e2e: a mesh file's materials and texture are drawn, at rest and as the body deforms", "[e2e][materials]") {
    test::TempDir dir("e2e_materials");
    writeFiles(dir.path(), "rb.png");
    SECTION("at rest: the front's two halves and the green sides") {
        std::ofstream(dir.path() / "s.json") << scene("", "");
        const Run r = runDgvIn(dir.path(), "-q render s.json --frames 1 --out out");
        INFO("stderr: " << r.err);
        REQUIRE(r.exitCode == 0);
        const Tally t = tally(readPng(dir.path() / "out" / "tex.0001.png"));
        CHECK(t.red > 200);
        CHECK(t.blue > 200);
        CHECK(t.green > 50);
    }
    SECTION("dropped as jelly onto the ground: still textured after it lands and squashes") {
        std::ofstream(dir.path() / "s.json") << scene(R"(, "transform": {"translate": [0, 0.15, 0]})",
                                                      R"(, "forces": [{"type": "gravity"}], "colliders": [{"type": "ground"}])");
        const Run r = runDgvIn(dir.path(), "-q render s.json --frames 14 --out out");
        INFO("stderr: " << r.err);
        REQUIRE(r.exitCode == 0);
        const Tally t = tally(readPng(dir.path() / "out" / "tex.0014.png"));
        CHECK(t.red > 150);
        CHECK(t.blue > 150);
    }
    SECTION("the scene's color overrides the file's look") {
        std::ofstream(dir.path() / "s.json") << scene(R"(, "color": [0.6, 0.6, 0.6])", "");
        const Run r = runDgvIn(dir.path(), "-q render s.json --frames 1 --out out");
        REQUIRE(r.exitCode == 0);
        const Tally t = tally(readPng(dir.path() / "out" / "tex.0001.png"));
        CHECK(t.red == 0);
        CHECK(t.blue == 0);
        CHECK(t.green == 0);
    }
}

TEST_CASE("e2e: --resume re-renders the frames of a changed texture or MTL, and keeps them otherwise",
          "[e2e][materials][resume]") {
    test::TempDir dir("e2e_materials_resume");
    writeFiles(dir.path(), "rb.png");
    std::ofstream(dir.path() / "s.json") << scene("", "");
    REQUIRE(runDgvIn(dir.path(), "-q render s.json --frames 1-2 --out out").exitCode == 0);
    const fs::path frame = dir.path() / "out" / "tex.0001.png";
    const std::string before = readAll(frame);
    auto resume = [&]() {
        const Run r = runDgvIn(dir.path(), "render s.json --frames 1-2 --out out --resume");
        INFO("stderr: " << r.err);
        CHECK(r.exitCode == 0);
        return r.err;
    };
    CHECK_THAT(resume(), Catch::Contains("kept 2 complete frames, rendered 0"));
    SECTION("the texture: its halves swapped") {
        Image img(16, 16);
        for (int y = 0; y < 16; ++y)
            for (int x = 0; x < 16; ++x) {
                img.pixel(x, y)[0] = x < 8 ? 0 : 65535;
                img.pixel(x, y)[2] = x < 8 ? 65535 : 0;
                img.pixel(x, y)[3] = 65535;
            }
        writePng(dir.path() / "rb.png", img);
    }
    SECTION("the MTL: another green") {
        std::ofstream(dir.path() / "box.mtl") << "newmtl front\nKd 1 1 1\nmap_Kd rb.png\nnewmtl side\nKd 0.02 0.5 0.02\n";
    }
    CHECK_THAT(resume(), Catch::Contains("kept 0 complete frames, rendered 2 (2 of them were on disk"));
    CHECK(readAll(frame) != before);
}

TEST_CASE("e2e: a texture that is not there is one warning naming it, and the shot renders", "[e2e][materials]") {
    test::TempDir dir("e2e_materials_missing");
    writeFiles(dir.path(), "textures/gone.png");
    std::ofstream(dir.path() / "s.json") << scene("", "");
    const Run r = runDgvIn(dir.path(), "render s.json --frames 1 --out out");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("material 'front': texture 'textures/gone.png'") &&
                          Catch::Contains("no such file; the material is drawn in its colour"));
    const Tally t = tally(readPng(dir.path() / "out" / "tex.0001.png"));
    CHECK(t.red == 0);
    CHECK(t.blue == 0);
    CHECK(t.green > 50);
}
