// The contact highlight shows from each shipped contact scene's own camera: on a contact frame,
// rendered with the scene's render.contact and again with the highlight off (the same state,
// restored from the state checkpoint the first render wrote), at least 0.2 % of the image
// changes by more than 16/255 in some channel. Before the highlight spread over the body,
// glowed and marked the colliders (docs/rendering.md, "Contact highlight"), the same probe
// measured 0 % on contact_ball, levelset_drop and ring_drop and 0.04-0.05 % on jelly_drop and
// the two blobs scenes: the patch faced the ground or the other body.
#include "e2e/e2e_run.hpp"
#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

using namespace dgv;
using namespace dgv::e2e;
namespace fs = std::filesystem;

namespace {

/// The shipped scene with its file paths made absolute and frames.end = `frame`; `highlight`
/// false sets render.contact.mode to "off". Both variants have the same dynamics (the state
/// checkpoints' key leaves out `render`), so the second render restores the first one's state.
void writeVariant(const fs::path& file, const std::string& name, int frame, bool highlight) {
    nlohmann::json scene = nlohmann::json::parse(readAll(test::sourcePath("scenes/" + name + ".json")));
    scene["frames"]["end"] = frame;
    auto absolute = [](nlohmann::json& o, const char* key) {
        if (o.contains(key) && o[key].is_string())
            o[key] = test::sourcePath("scenes/" + o[key].get<std::string>()).string();
    };
    for (auto& o : scene["objects"]) absolute(o, "mesh");
    if (scene.contains("colliders"))
        for (auto& c : scene["colliders"]) {
            absolute(c, "mesh");
            absolute(c, "file");
        }
    if (!highlight) scene["render"]["contact"] = {{"mode", "off"}};
    std::ofstream(file) << scene.dump(2);
}

/// The share of pixels whose largest channel difference exceeds `contrast` (8-bit code values).
double changedShare(const Image& a, const Image& b, int contrast) {
    REQUIRE(a.width == b.width);
    REQUIRE(a.height == b.height);
    std::size_t changed = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            int d = 0;
            for (int c = 0; c < 3; ++c)
                d = std::max(d, std::abs(int(to8bit(a.pixel(x, y)[c])) - int(to8bit(b.pixel(x, y)[c]))));
            if (d > contrast) ++changed;
        }
    return double(changed) / (double(a.width) * a.height);
}

}  // namespace

TEST_CASE("e2e: the contact highlight shows from every shipped contact scene's own camera",
          "[e2e][render][contact][slow]") {
    // Each scene at a frame in contact (measured: 0.65, 0.22, 0.37, 0.50, 0.28 and 0.28 %).
    const std::pair<const char*, int> cases[] = {{"contact_ball", 3}, {"levelset_drop", 3}, {"jelly_drop", 6},
                                                 {"ring_drop", 6},    {"blobs_collide", 7}, {"blobs_knock", 4}};
    for (const auto& [name, frame] : cases) {
        DYNAMIC_SECTION(name << " frame " << frame) {
            test::TempDir dir(std::string("e2e_probe_") + name);
            writeVariant(dir.path() / "on.json", name, frame, true);
            writeVariant(dir.path() / "off.json", name, frame, false);
            const Run on = runDgvIn(dir.path(), "-q render on.json --out o");
            INFO(on.err);
            REQUIRE(on.exitCode == 0);
            char num[16];
            std::snprintf(num, sizeof num, "%04d", frame);
            const fs::path png = dir.path() / "o" / (std::string(name) + "." + num + ".png");
            const Image highlighted = readPng(png);
            const Image first = readPng(dir.path() / "o" / (std::string(name) + ".0001.png"));
            // The same frame without the highlight, from the checkpoint of that frame.
            const Run off = runDgvIn(dir.path(), "-q render off.json --out o --frames " + std::to_string(frame) + "-" +
                                                     std::to_string(frame));
            INFO(off.err);
            REQUIRE(off.exitCode == 0);
            const double share = changedShare(highlighted, readPng(png), 16);
            INFO(name << ": " << 100 * share << " % of the image changed by more than 16/255");
            std::printf("contact probe: %s frame %d: %.3f %% of the image changed by more than 16/255\n", name, frame,
                        100 * share);
            CHECK(share >= 0.002);
            // Frame 1 has no contact: the highlight changes nothing there.
            const Run offFirst = runDgvIn(dir.path(), "-q render off.json --out o --frames 1-1");
            REQUIRE(offFirst.exitCode == 0);
            CHECK(changedShare(first, readPng(dir.path() / "o" / (std::string(name) + ".0001.png")), 0) == 0);
        }
    }
}
