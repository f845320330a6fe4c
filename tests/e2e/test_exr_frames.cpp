// EXR frames (render.format "exr", --format exr; docs/rendering.md, "EXR frames for
// compositing"): what dgv render writes, against its PNG frames of the same scene; --resume's
// trust in them; the refusals; and Blender opening them. A tiny scene (a tilted box of 6^3 points
// falling onto the ground, contact highlighted from frame 4 on) keeps each run under a second.

#include "e2e/e2e_run.hpp"
#include "io/checksum.hpp"
#include "io/exr.hpp"
#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;

namespace {

constexpr int kFrames = 8;

void writeScene(const fs::path& dir, const std::string& renderExtra = "") {
    std::ofstream(dir / "drop.json") << R"({"name": "drop", "frames": {"start": 1, "end": )" << kFrames
                                     << R"(, "fps": 24}, "substeps": 2,
  "objects": [{"name": "cube", "primitive": {"type": "box", "size": [0.4, 0.4, 0.4]},
               "transform": {"translate": [0, 0.29, 0], "rotate": [0, 0, 12]}, "resolution": 6,
               "color": [0.8, 0.3, 0.2], "material": {"damping": 1}}],
  "forces": [{"type": "gravity"}],
  "colliders": [{"type": "ground", "height": 0, "friction": 0.5}],
  "camera": {"type": "look_at", "eye": [1.2, 0.5, 1.6], "target": [0, 0.35, 0], "fov": 40},
  "render": {"width": 64, "height": 48, "contact": {"mode": "depth"})"
                                     << renderExtra << "}}\n";
}

std::string frameName(int frame, const char* extension) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "drop.%04d.%s", frame, extension);
    return buf;
}

}  // namespace

TEST_CASE("e2e: render --format exr writes sealed EXR frames: the PNG's colour, the depth and the contact matte",
          "[e2e][exr]") {
    test::TempDir dir("e2e_exr");
    writeScene(dir.path());
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out png").exitCode == 0);
    const Run r = runDgvIn(dir.path(), "render drop.json --out exr --format exr");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("drop.####.exr"));
    const std::vector<std::map<std::string, double>> stats = readStatsCsv(dir.path() / "exr" / "stats.csv");
    REQUIRE(stats.size() == kFrames);
    int framesWithContact = 0;
    for (int f = 1; f <= kFrames; ++f) {
        INFO("frame " << f);
        const fs::path file = dir.path() / "exr" / frameName(f, "exr");
        CHECK_FALSE(fs::exists(dir.path() / "exr" / frameName(f, "png")));
        REQUIRE(fileChecksumProblem(file).empty());
        std::vector<std::pair<std::string, std::string>> text;
        const LinearImage exr = readExr(file, &text);
        CHECK(std::find(text.begin(), text.end(), std::make_pair(std::string("dgv:frame"), std::to_string(f))) !=
              text.end());
        // The PNG is encoded from the same halves the EXR stores: one 16-bit code at most apart
        // (8-bit PNG: its codes times 257).
        const Image png = readPng(dir.path() / "png" / frameName(f, "png"));
        const Image fromExr = encodedImageOf(exr);
        REQUIRE(png.rgba.size() == fromExr.rgba.size());
        int worst = 0;
        for (std::size_t i = 0; i < png.rgba.size(); ++i)
            worst = std::max(worst, std::abs(int(png.rgba[i]) - int(to8bit(fromExr.rgba[i])) * 257));
        CHECK(worst == 0);
        // Depth: what shows is 0.5 to 8 m away (the eye is 2 m from the cube, the floor fades out
        // within a few metres of it); where nothing shows, the PNG has the background exactly.
        int seen = 0, none = 0;
        const std::uint16_t* background = nullptr;
        for (std::size_t p = 0; p < exr.depth.size(); ++p) {
            const float z = exr.depth[p];
            if (z == LinearImage::kNoDepth) {
                if (!background) background = &png.rgba[4 * p];
                CHECK(std::equal(background, background + 4, &png.rgba[4 * p]));
                ++none;
                continue;
            }
            CHECK(z > 0.5f);
            CHECK(z < 8.0f);
            ++seen;
        }
        CHECK(seen > 64 * 48 / 3);
        CHECK(none > 64 * 48 / 10);
        // The contact matte is there exactly on the frames with contacts.
        const float most = *std::max_element(exr.contact.begin(), exr.contact.end());
        CHECK(*std::min_element(exr.contact.begin(), exr.contact.end()) >= 0.0f);
        CHECK(most <= 1.0f);
        const bool contact = stats[static_cast<std::size_t>(f - 1)].at("contacts") > 0;
        CHECK((most > 0.5f) == contact);
        framesWithContact += contact ? 1 : 0;
    }
    CHECK(framesWithContact >= 2);
    CHECK(framesWithContact < kFrames);
}

TEST_CASE("e2e: render --resume keeps whole EXR frames and renders a damaged or missing one again to the same bytes",
          "[e2e][exr][resume]") {
    test::TempDir dir("e2e_exr_resume");
    writeScene(dir.path(), R"(, "format": "exr")");
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out o").exitCode == 0);
    const fs::path out = dir.path() / "o";
    std::vector<std::string> first;
    for (int f = 1; f <= kFrames; ++f) first.push_back(readAll(out / frameName(f, "exr")));
    {  // one bit flipped in the middle of frame 3, frame 5 gone
        std::string bytes = first[2];
        bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
        std::ofstream(out / frameName(3, "exr"), std::ios::binary) << bytes;
        fs::remove(out / frameName(5, "exr"));
    }
    const Run r = runDgvIn(dir.path(), "--progress log render drop.json --out o --resume");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("resume: kept 6 complete frames, rendered 2 (1 of them were on disk but"));
    for (int f = 1; f <= kFrames; ++f) {
        INFO("frame " << f);
        CHECK(readAll(out / frameName(f, "exr")) == first[static_cast<std::size_t>(f - 1)]);
    }
    // A PNG render of the same folder does not take the EXR frames for its own.
    const Run png = runDgvIn(dir.path(), "--progress log render drop.json --out o --resume --format png");
    REQUIRE(png.exitCode == 0);
    CHECK_THAT(png.err, Catch::Contains("resume: kept 0 complete frames, rendered 8"));
}

TEST_CASE("e2e: EXR frames with a movie or a bit depth are refused in one line before anything is written",
          "[e2e][exr][bad_input]") {
    test::TempDir dir("e2e_exr_bad");
    writeScene(dir.path(), R"(, "format": "exr")");
    const Run movie = runDgvIn(dir.path(), "render drop.json --out o --movie");
    CHECK(movie.exitCode == 2);
    CHECK(lineCount(movie.err) == 1);
    CHECK_THAT(movie.err, Catch::Contains("--movie") && Catch::Contains("PNG frames"));
    writeScene(dir.path(), R"(, "format": "exr", "bit_depth": 16)");
    const Run depth = runDgvIn(dir.path(), "render drop.json --out o");
    CHECK(depth.exitCode == 2);
    CHECK(lineCount(depth.err) == 1);
    CHECK_THAT(depth.err, Catch::Contains("render.bit_depth") && Catch::Contains("PNG frames"));
    writeScene(dir.path(), R"(, "format": "tiff")");
    const Run format = runDgvIn(dir.path(), "render drop.json --out o");
    CHECK(format.exitCode == 2);
    CHECK_THAT(format.err, Catch::Contains("render.format"));
    CHECK_FALSE(fs::exists(dir.path() / "o"));
}

TEST_CASE("e2e: Blender opens a dgv EXR frame with its depth and reads the pixels dgv wrote", "[e2e][exr][blender]") {
    INFO("blender is not on PATH: scripts/install-deps.sh --tests installs Debian's blender");
    REQUIRE(std::system("command -v blender >/dev/null 2>&1") == 0);
    test::TempDir dir("e2e_exr_blender");
    writeScene(dir.path(), R"(, "transparent": true)");
    REQUIRE(runDgvIn(dir.path(), "-q render drop.json --out o --format exr --frames 6").exitCode == 0);
    const fs::path file = dir.path() / "o" / frameName(6, "exr");
    const LinearImage exr = readExr(file);
    // Pixels where dgv wrote an opaque cube, a half-covered edge and nothing at all.
    std::vector<std::pair<int, int>> probes;
    auto find = [&](auto wanted) {
        for (int y = 0; y < exr.height; ++y)
            for (int x = 0; x < exr.width; ++x)
                if (wanted(exr.rgba[(static_cast<std::size_t>(y) * exr.width + x) * 4 + 3])) {
                    probes.emplace_back(x, y);
                    return;
                }
    };
    find([](float a) { return a == 1.0f; });
    find([](float a) { return a > 0.2f && a < 0.8f; });
    find([](float a) { return a == 0.0f; });
    REQUIRE(probes.size() == 3);
    std::string xy;
    for (const auto& [x, y] : probes) xy += " " + std::to_string(x) + "," + std::to_string(y);
    const fs::path log = dir.path() / "blender.log";
    const std::string cmd = "blender -b --factory-startup -noaudio --python-exit-code 1 -P " +
                            quote(test::sourcePath("tests/e2e/blender_exr_check.py")) + " -- " + quote(file) + xy +
                            " > " + quote(log) + " 2>&1";
    const int status = std::system(cmd.c_str());
    const std::string out = readAll(log);
    INFO(out);
    REQUIRE(WIFEXITED(status));
    REQUIRE(WEXITSTATUS(status) == 0);
    CHECK_THAT(out, Catch::Contains("size 64 48 float 1 alpha PREMUL"));
    CHECK_THAT(out, Catch::Contains("outputs Image Alpha Depth"));
    // Blender holds the premultiplied halves as dgv wrote them (exact in float).
    std::istringstream lines(out);
    int checked = 0;
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("pixel ", 0) != 0) continue;
        std::istringstream f(line.substr(6));
        int x = 0, y = 0;
        float v[4];
        f >> x >> y >> v[0] >> v[1] >> v[2] >> v[3];
        for (int c = 0; c < 4; ++c)
            CHECK(v[c] == Approx(exr.rgba[(static_cast<std::size_t>(y) * exr.width + x) * 4 + c]).margin(1e-7));
        ++checked;
    }
    CHECK(checked == 3);
}
