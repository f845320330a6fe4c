// The bad-input catalogue (docs/robustness.md): the real dgv executable on each bad input must
// exit 2 with exactly one line on stderr naming the input and the problem, print nothing on
// stdout, and create no file or folder.

#include "e2e/e2e_run.hpp"
#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;

namespace {

struct BadCase {
    std::string name;                                        ///< for the catalogue table
    std::vector<std::pair<std::string, std::string>> files;  ///< written into the case's folder first
    std::string args;                                        ///< dgv arguments, run in that folder
    std::vector<std::string> expect;                         ///< substrings of the one stderr line
};

/// Deterministic noise: `n` bytes from a fixed LCG.
std::string noise(std::size_t n, std::uint32_t seed) {
    std::string s(n, '\0');
    for (char& c : s) {
        seed = seed * 1664525u + 1013904223u;
        c = static_cast<char>(seed >> 24);
    }
    return s;
}

/// A scene whose only object is the mesh `mesh` (a path relative to the scene).
std::string meshScene(const std::string& mesh) {
    return R"({"frames": {"start": 1, "end": 1}, "objects": [{"mesh": ")" + mesh +
           R"(", "resolution": 8}], "render": {"width": 32, "height": 32, "supersample": 1}})";
}

/// A scene with a sphere and `extra` spliced into the top-level object (or the object's, via `objExtra`).
std::string sphereScene(const std::string& extra, const std::string& objExtra = "") {
    return R"({"frames": {"start": 1, "end": 2}, "objects": [{"primitive": {"type": "sphere", "radius": 0.5})" +
           objExtra + R"(}], "render": {"width": 32, "height": 32, "supersample": 1})" + extra + "}";
}

const char* kRing = "1 0 0\n0 1 0\n-1 0 0\n0 -1 0\n";

void checkCases(const std::string& tempName, const std::vector<BadCase>& cases) {
    test::TempDir root(tempName);
    int index = 0;
    for (const BadCase& c : cases) {
        const fs::path dir = root.path() / ("case" + std::to_string(index++));
        fs::create_directories(dir);
        for (const auto& [name, contents] : c.files) {
            fs::create_directories((dir / name).parent_path());
            std::ofstream(dir / name, std::ios::binary) << contents;
        }
        const std::vector<std::string> before = snapshot(dir);
        const Run r = runDgvIn(dir, c.args);
        INFO(c.name << "\n  dgv " << c.args << "\n  exit " << r.exitCode << "\n  stderr: " << r.err
                    << "  stdout: " << r.out);
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.err) == 1);
        CHECK(r.err.back() == '\n');
        CHECK(r.err.rfind("dgv", 0) == 0);
        CHECK(r.out.empty());
        for (const std::string& e : c.expect) CHECK_THAT(r.err, Catch::Contains(e));
        CHECK(snapshot(dir) == before);  // nothing created: no output folder, file or temporary
    }
}

}  // namespace

TEST_CASE("e2e: bad scene files exit 2 with one line and write nothing", "[e2e][badinput]") {
    checkCases("e2e_bad_scene", {
                                    {"missing scene file", {}, "render absent.json", {"absent.json", "no such file"}},
                                    {"scene path is a folder", {{"dir.json/x", ""}}, "render dir.json", {"dir.json"}},
                                    {"empty scene file",
                                     {{"s.json", "  \n"}},
                                     "render s.json",
                                     {"s.json", "malformed JSON", "the file is empty"}},
                                    {"scene that is not JSON",
                                     {{"s.json", "{\n  \"frames\": {\"start\": 1,,\n}\n"}},
                                     "render s.json",
                                     {"s.json", "malformed JSON", "line 2, column"}},
                                    {"truncated JSON",
                                     {{"s.json", "{\"objects\": [{\"primitive\": "}},
                                     "render s.json",
                                     {"s.json", "malformed JSON", "line 1"}},
                                    {"unknown key",
                                     {{"s.json", sphereScene(R"(, "frams": {"start": 1})")}},
                                     "render s.json",
                                     {"s.json", "frams", "unknown key", "did you mean 'frames'"}},
                                    {"unknown nested key",
                                     {{"s.json", sphereScene("", R"(, "voxel_sise": 0.1)")}},
                                     "render s.json",
                                     {"s.json", "objects[0].voxel_sise", "did you mean 'voxel_size'"}},
                                    {"unknown key with a newline in it",
                                     {{"s.json", sphereScene(R"(, "fra\nmes": {"start": 1})")}},
                                     "render s.json",
                                     {"s.json", "fra\\x0ames", "unknown key"}},
                                });
}

TEST_CASE("e2e: scene values of the wrong type or out of range exit 2 with one line",
          "[e2e][badinput][slow][sanitize]") {
    checkCases("e2e_bad_values",
               {
                   {"wrong type",
                    {{"s.json", R"({"frames": {"start": "one", "end": 2}})"}},
                    "render s.json",
                    {"s.json", "frames.start", "\"one\""}},
                   {"wrong type (objects not an array)",
                    {{"s.json", R"({"objects": {"mesh": "a.obj"}})"}},
                    "render s.json",
                    {"s.json", "objects"}},
                   {"negative voxel size",
                    {{"s.json", sphereScene("", R"(, "voxel_size": -0.1)")}},
                    "render s.json",
                    {"s.json", "objects[0].voxel_size", "-0.1"}},
                   {"NaN-like voxel size (null)",
                    {{"s.json", sphereScene("", R"(, "voxel_size": null)")}},
                    "render s.json",
                    {"s.json", "objects[0].voxel_size", "null"}},
                   {"huge lattice",
                    {{"s.json", sphereScene("", R"(, "voxel_size": 1e-6)")}},
                    "render s.json",
                    {"s.json", "objects[0].voxel_size"}},
                   // A VDB voxel size far under the lattice's was found only when the frame was written,
                   // out of memory.
                   {"VDB voxel size over the memory budget",
                    {{"s.json", sphereScene(R"(, "output": {"vdb": true, "vdb_voxel_size": 1e-5})")}},
                    "simulate s.json",
                    {"s.json", "output.vdb_voxel_size", "1e-05 would make a world grid of", "the memory budget leaves",
                     "vdb_voxel_size", "would fit"}},
                   {"restitution between objects above 1",
                    {{"s.json", sphereScene(R"(, "collision": {"restitution": 1.5})")}},
                    "render s.json",
                    {"s.json", "collision.restitution", "1.5"}},
                   {"collision.objects not a bool",
                    {{"s.json", sphereScene(R"(, "collision": {"objects": "yes"})")}},
                    "render s.json",
                    {"s.json", "collision.objects"}},
                   {"frames end < start",
                    {{"s.json", R"({"frames": {"start": 5, "end": 2}})"}},
                    "render s.json",
                    {"s.json", "frames.end", "must be >= start (5)"}},
                   {"substeps 0",
                    {{"s.json", sphereScene(R"(, "substeps": 0)")}},
                    "render s.json",
                    {"s.json", "substeps", "0"}},
                   {"max_substeps below substeps",
                    {{"s.json", sphereScene(R"(, "substeps": 4, "max_substeps": 2)")}},
                    "render s.json",
                    {"s.json", "max_substeps", "[4, 1000], got 2"}},
                   {"cfl 0", {{"s.json", sphereScene(R"(, "cfl": 0)")}}, "render s.json", {"s.json", "cfl", "got 0"}},
                   {"resolution 0",
                    {{"s.json", sphereScene("", R"(, "resolution": 0)")}},
                    "render s.json",
                    {"s.json", "objects[0].resolution", "0"}},
                   {"render width 0",
                    {{"s.json", R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"width": 0}})"}},
                    "render s.json",
                    {"s.json", "render.width", "got 0"}},
                   // A scene name of 300 characters failed only at the first frame's write ("File name too long").
                   {"scene name longer than a file name allows",
                    {{"s.json", sphereScene(R"(, "name": ")" + std::string(300, 'n') + "\"")}},
                    "render s.json",
                    {"s.json", "name", "at most 200 characters", "got 300"}},
                   {"object name longer than a file name allows",
                    {{"s.json", sphereScene("", R"(, "name": ")" + std::string(201, 'o') + "\"")}},
                    "render s.json",
                    {"s.json", "objects[0].name", "at most 200 characters", "got 201"}},
               });
}

TEST_CASE("e2e: absurd sizes, positions and frame rates are refused up front", "[e2e][badinput]") {
    // Each of these failed late before: a fault at frame 2 after frame 1 was written (exit 1,
    // which a farm retries), an empty image with exit 0, or a message blaming another cause.
    const std::string drop = R"(, "forces": [{"type": "gravity"}])";
    checkCases("e2e_bad_extremes",
               {
                   {"radius 1e300 (a fault at frame 2)",
                    {{"s.json", R"({"frames": {"start": 1, "end": 2}, "objects": [{"primitive": {"type": "sphere",
                       "radius": 1e300}}], "forces": [{"type": "gravity"}], "camera": {"type": "turntable"}})"}},
                    "simulate s.json",
                    {"s.json", "objects[0].primitive", "\"object0\" is 2e+300 m across", "from 1e-06 to 1e+09 m"}},
                   {"an object of 1e-7 m (an empty image)",
                    {{"s.json", sphereScene("", "").replace(sphereScene("", "").find("0.5"), 3, "5e-8")}},
                    "render s.json",
                    {"s.json", "objects[0].primitive", "is 1e-07 m across", "give it a size in that range"}},
                   {"a mesh scaled past 1e9 m",
                    {{"s.json", sphereScene("", R"(, "transform": {"scale": 1e10})")}},
                    "render s.json",
                    {"s.json", "objects[0].transform.scale", "is 1e+10 m across"}},
                   {"translate 1e300 (\"the mesh is flat\" after a warning)",
                    {{"s.json", sphereScene("", R"(, "transform": {"translate": [1e300, 0, 0]})")}},
                    "render s.json",
                    {"s.json", "objects[0].transform.translate", "would lie 1e+300 m from the origin",
                     "move the scene nearer the origin"}},
                   {"translate -1e12 (wrong volumes, no fault)",
                    {{"s.json", sphereScene(drop, R"(, "transform": {"translate": [0, -1e12, 0]})")}},
                    "simulate s.json",
                    {"s.json", "objects[0].transform.translate", "1e+12 times its size"}},
                   {"camera eye 1e300 (\"up must not be parallel\")",
                    {{"s.json", sphereScene(R"(, "camera": {"type": "look_at", "eye": [1e300, 0, 0]})")}},
                    "render s.json",
                    {"s.json", "camera.eye", "lies 1e+300 m from the target"}},
                   {"fps 1e-300 (lattice_folded, |Γ + δΓ| = -nan)",
                    {{"s.json", sphereScene(R"(, "frames": {"start": 1, "end": 3, "fps": 1e-300})" + drop)}},
                    "-q simulate s.json",
                    {"s.json", "objects[0].material", "needs 3.13e+301 substeps per frame",
                     "more than the 1000 dgv takes", "raise frames.fps to 0.0314 or more"}},
                   {"a small stiff jelly with max_substeps too low for it",
                    {{"s.json", sphereScene(R"(, "max_substeps": 10)" + drop,
                                            R"(, "material": {"stiffness": 4e6}, "resolution": 8)")}},
                    "-q simulate s.json",
                    {"s.json", "max_substeps", "which needs 84 substeps per frame at 24 fps",
                     "more than max_substeps 10 allows: set it to 84 or more"}},
               });
}

TEST_CASE("e2e: a small jelly ball whose wobble needs more substeps than the default gets them", "[e2e]") {
    // The jelly preset's stiffness grows as 1/size: a ball of 0.1 mm radius wobbles at 352 Hz and
    // needs 93 substeps at 24 fps. With the default most of 16 (32 on a retry) it faulted at
    // frame 2.
    test::TempDir dir("e2e_small_jelly");
    std::ofstream(dir.path() / "s.json") << R"({"frames": {"start": 1, "end": 4},
      "objects": [{"primitive": {"type": "sphere", "radius": 1e-4}, "resolution": 8,
                   "transform": {"translate": [0, 1.6e-4, 0]}}],
      "forces": [{"type": "gravity"}], "colliders": [{"type": "ground", "height": 0}]})";
    const Run r = runDgvIn(dir.path(), "--progress log simulate s.json --out o");
    INFO(r.err);
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("which needs 93 substeps per frame at 24 fps: up to 93 substeps per frame are "
                                      "taken"));
    CHECK_THAT(r.err, Catch::Contains("simulate 4/4 frames"));
}

TEST_CASE("e2e: objects that start inside each other exit 2 naming both, and write nothing", "[e2e][badinput][slow]") {
    // docs/math.md, "Overlapping starts": two balls of radius 0.3 whose centres are 0.4 apart
    // overlap by 0.2 (less the contact margin of a voxel); render and simulate refuse them.
    auto pair = [](double apart, const std::string& collision) {
        return R"({"frames": {"start": 1, "end": 3}, "collision": )" + collision + R"(,
          "objects": [{"name": "left", "primitive": {"type": "sphere", "radius": 0.3}, "resolution": 12,
                       "material": {"stiffness": 300}, "velocity": [1, 0, 0]},
                      {"name": "right", "primitive": {"type": "sphere", "radius": 0.3}, "resolution": 12,
                       "material": {"stiffness": 300}, "transform": {"translate": [)" +
               std::to_string(apart) + R"(, 0, 0]}}],
          "render": {"width": 32, "height": 32, "supersample": 1}})";
    };
    checkCases(
        "e2e_bad_overlap",
        {
            // -q: the objects are built (and described on stderr) before the overlap can be measured
            {"overlapping start (render)",
             {{"s.json", pair(0.4, R"({"objects": true})")}},
             "-q render s.json",
             {"s.json", "objects[1].transform", "'left' and 'right' start inside each other", "move them apart"}},
            {"overlapping start (simulate)",
             {{"s.json", pair(0.4, R"({"objects": true})")}},
             "-q simulate s.json",
             {"s.json", "'left' and 'right' start inside each other"}},
        });
    // Apart, or not colliding with each other, the same objects run.
    test::TempDir dir("e2e_overlap_ok");
    std::ofstream(dir.path() / "apart.json") << pair(0.7, R"({"objects": true})");
    std::ofstream(dir.path() / "through.json") << pair(0.4, R"({"objects": false})");
    for (const char* name : {"apart.json", "through.json"}) {
        const Run r = runDgvIn(dir.path(), std::string("-q simulate ") + name + " --out o_" + name);
        INFO(name << ": " << r.err);
        CHECK(r.exitCode == 0);
    }
}

TEST_CASE("e2e: bad meshes exit 2 with one line and write nothing", "[e2e][badinput][slow][sanitize]") {
    const std::string offBadIndex = "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 7\n";
    checkCases("e2e_bad_mesh",
               {
                   {"missing mesh file",
                    {{"s.json", meshScene("missing.obj")}},
                    "render s.json",
                    {"s.json", "objects[0].mesh", "missing.obj"}},
                   {"missing mesh file (info)", {}, "info missing.obj", {"missing.obj", "file not found"}},
                   {"a scene file given to info",
                    {{"s.json", meshScene("m.obj")}},
                    "info s.json",
                    {"s.json", "is a scene file", "'dgv info' reads a mesh"}},
                   {"mesh path is a folder (info)", {{"d.obj/x", ""}}, "info d.obj", {"d.obj", "directory"}},
                   {"random bytes as .obj",
                    {{"s.json", meshScene("noise.obj")}, {"noise.obj", noise(2048, 1)}},
                    "render s.json",
                    {"noise.obj"}},
                   {"random bytes as .ply", {{"noise.ply", noise(2048, 2)}}, "info noise.ply", {"noise.ply"}},
                   {"random bytes as .stl", {{"noise.stl", noise(2048, 3)}}, "info noise.stl", {"noise.stl"}},
                   {"random bytes as .off", {{"noise.off", noise(2048, 4)}}, "info noise.off", {"noise.off"}},
                   {"empty mesh file",
                    {{"s.json", meshScene("empty.obj")}, {"empty.obj", ""}},
                    "render s.json",
                    {"empty.obj", "the file is empty"}},
                   {"mesh without faces",
                    {{"points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"}},
                    "info points.obj",
                    {"points.obj", "no triangles"}},
                   {"mesh with NaN vertices",
                    {{"s.json", meshScene("nan.obj")}, {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"}},
                    "render s.json",
                    {"nan.obj", "vertex 1"}},
                   {"mesh with infinite vertices",
                    {{"inf.obj", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n"}},
                    "info inf.obj",
                    {"inf.obj", "vertex 2"}},
                   {"degenerate triangles only",
                    {{"flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"}},
                    "info flat.obj",
                    {"flat.obj", "no triangles"}},
                   {"OFF with a bad face index",
                    {{"s.json", meshScene("bad.off")}, {"bad.off", offBadIndex}},
                    "render s.json",
                    {"bad.off", "line 7", "face vertex index '7'"}},
                   {"OFF with a bad face index (info)",
                    {{"bad.off", offBadIndex}},
                    "info bad.off",
                    {"bad.off", "line 7", "face vertex index '7'"}},
                   // A single triangle voxelised as an open mesh became a sheet one voxel thick, and its
                   // dynamics went non-finite at frame 2.
                   {"a single triangle as an object",
                    {{"s.json", meshScene("tri.obj")}, {"tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"}},
                    "render s.json",
                    {"s.json", "objects[0]", "is flat (its size along z is 0)", "give it a thickness"}},
               });
}

TEST_CASE("e2e: bad curve files for gln exit 2 with one line naming the line", "[e2e][badinput]") {
    checkCases(
        "e2e_bad_curve",
        {
            {"missing curve file", {{"a.txt", kRing}}, "gln a.txt absent.txt", {"absent.txt", "no such file"}},
            {"curve path is a folder", {{"a.txt", kRing}, {"d.txt/x", ""}}, "gln a.txt d.txt", {"d.txt", "folder"}},
            {"fewer than 3 vertices",
             {{"a.txt", kRing}, {"b.txt", "# two\n0 0 0\n1 0 0\n"}},
             "gln a.txt b.txt",
             {"b.txt", "at least 3 vertices, found 2"}},
            {"empty curve file", {{"a.txt", kRing}, {"b.txt", ""}}, "gln a.txt b.txt", {"b.txt", "found 0"}},
            {"NaN coordinate",
             {{"a.txt", kRing}, {"b.txt", "0 0 0\n1 nan 0\n0 1 0\n"}},
             "gln a.txt b.txt",
             {"b.txt", "line 2", "not a finite number"}},
            {"infinite coordinate",
             {{"a.txt", kRing}, {"b.txt", "0 0 0\n1 0 0\n0 1 1e999\n"}},
             "gln a.txt b.txt",
             {"b.txt", "line 3", "not a finite number"}},
            {"unparsable line",
             {{"a.txt", kRing}, {"b.txt", "0 0 0\n1 0 0\n1 x 0\n0 1 0\n"}},
             "gln a.txt b.txt",
             {"b.txt", "line 3", "expected three numbers"}},
            {"two numbers on a line",
             {{"a.txt", kRing}, {"b.txt", "0 0 0\n1 0 0\n# c\n1 1\n"}},
             "gln a.txt b.txt",
             {"b.txt", "line 4", "got 2"}},
            {"first curve bad too", {{"a.txt", "1 2 3\n"}, {"b.txt", kRing}}, "gln a.txt b.txt", {"a.txt", "found 1"}},
        });
}

TEST_CASE("e2e: imgdiff on a missing or non-PNG file exits 2 with one line", "[e2e][badinput]") {
    // A valid 1x1 PNG as the other side.
    const std::vector<unsigned char> encoded = encodePng(Image(1, 1));
    const std::string png(encoded.begin(), encoded.end());
    Image light(1, 1);
    for (int c = 0; c < 3; ++c) light.pixel(0, 0)[c] = 65535;
    const std::vector<unsigned char> lightEncoded = encodePng(light);
    const std::string white(lightEncoded.begin(), lightEncoded.end());
    checkCases(
        "e2e_bad_imgdiff",
        {
            {"imgdiff: missing reference",
             {{"b.png", png}},
             "imgdiff absent.png b.png",
             {"absent.png", "No such file"}},
            {"imgdiff: missing candidate", {{"a.png", png}}, "imgdiff a.png absent.png --diff-out d", {"absent.png"}},
            {"imgdiff: not a PNG",
             {{"a.png", png}, {"text.png", "hello, not a picture\n"}},
             "imgdiff a.png text.png --diff-out d",
             {"text.png", "not a PNG file"}},
            {"imgdiff: truncated PNG",
             {{"a.png", png}, {"cut.png", png.substr(0, 40)}},
             "imgdiff a.png cut.png --diff-out d",
             {"cut.png", "cannot read PNG"}},
            // It exited 1, imgdiff's "the images differ", with "cannot create folder".
            {"imgdiff: --diff-out is a file",
             {{"a.png", png}, {"w.png", white}, {"taken", ""}},
             "imgdiff a.png w.png --diff-out taken",
             {"--diff-out", "taken: not a folder"}},
        });
}

TEST_CASE("e2e: bad command-line options exit 2 with one line and write nothing", "[e2e][badinput][slow]") {
    const std::string scene = sphereScene("");
    const std::string s = "s.json";
    checkCases(
        "e2e_bad_cli",
        {
            {"--frames B < A", {{s, scene}}, "render s.json --frames 5-2 --out o", {"--frames", "empty (B < A)"}},
            {"--frames not a range",
             {{s, scene}},
             "render s.json --frames 1-x --out o",
             {"--frames", "expected A-B or N"}},
            {"--frames outside the scene",
             {{s, scene}},
             "render s.json --frames 1-9 --out o",
             {"--frames", "outside the scene's range 1-2"}},
            {"--resolution 0x0", {{s, scene}}, "render s.json --resolution 0x0 --out o", {"--resolution", "\"0x0\""}},
            {"--resolution without x",
             {{s, scene}},
             "render s.json --resolution 640 --out o",
             {"--resolution", "expected WxH"}},
            {"--width out of range", {{s, scene}}, "render s.json --width 0 --out o", {"--width"}},
            {"unknown option", {{s, scene}}, "render s.json --bogus --out o", {"--bogus"}},
            {"unknown subcommand", {}, "frobnicate", {"frobnicate"}},
            {"missing argument", {}, "render", {"scene"}},
            {"--threads negative", {{s, scene}}, "--threads -1 render s.json --out o", {"--threads"}},
            {"gln --method unknown", {{"a.txt", kRing}}, "gln a.txt a.txt --method magic", {"--method", "magic"}},
            {"info --voxel-size negative",
             {{"a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"}},
             "info a.obj --voxel-size -1",
             {"--voxel-size"}},
            {"--out is a file",
             {{s, scene}, {"taken", "a file\n"}},
             "render s.json --out taken",
             {"taken", "not a folder"}},
            {"--out below a file",
             {{s, scene}, {"taken", "a file\n"}},
             "render s.json --out taken/frames",
             {"taken", "not a folder"}},
            {"scene output.dir is a file",
             {{s, sphereScene(R"(, "output": {"dir": "taken"})")}, {"taken", "x"}},
             "render s.json",
             {"s.json", "output.dir", "not a folder"}},
        });
}

TEST_CASE("e2e: a scene path that is a pipe or a device exits 2 with one line instead of blocking", "[e2e][badinput]") {
    test::TempDir dir("e2e_bad_fifo");
    REQUIRE(std::system(("mkfifo " + quote(dir.path() / "pipe.json")).c_str()) == 0);
    // Reading the FIFO blocked until a writer came (and /dev/zero was read without bound): a
    // writer that opens and closes it after 5 s unblocks such a reader, so the test cannot hang.
    const std::string unblock = "{ (sleep 5; timeout 5 sh -c ': > pipe.json') > /dev/null 2>&1 & };";
    for (const std::string& path : {std::string("pipe.json"), std::string("/dev/zero")}) {
        const Run r = runDgvIn(dir.path(), "render " + path + " --out o", path == "pipe.json" ? unblock : "");
        INFO(path << ": exit " << r.exitCode << ", stderr: " << r.err);
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains(path) && Catch::Contains("not a regular file"));
        CHECK_FALSE(fs::exists(dir.path() / "o"));
    }
}

TEST_CASE(
    "e2e: an I/O error while reading a scene, curve, mesh, PNG or level-set file exits 1 naming the file and "
    "the errno",
    "[e2e][faults]") {
    // A read error was reported as bad content, exit 2 ("malformed JSON: the file is empty"),
    // which a farm does not retry. /proc/self/mem is a regular file whose read at offset 0 fails
    // with EIO in the process that reads it: a real I/O error without an injection library.
    test::TempDir dir("e2e_read_eio");
    std::ofstream(dir.path() / "ring.txt") << "1 0 0\n0 1 0\n-1 0 0\n0 -1 0\n";
    // The mesh (assimp), the PNG (libpng) and the level set (OpenVDB) said "the file is empty",
    // "Read Error" and "not an OpenVDB file", exit 2.
    std::ofstream(dir.path() / "mesh.json")
        << R"({"frames": {"start": 1, "end": 1}, "objects": [{"mesh": "/proc/self/mem", "resolution": 8}]})";
    std::ofstream(dir.path() / "levelset.json")
        << R"({"frames": {"start": 1, "end": 1}, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8}],
              "colliders": [{"type": "levelset", "file": "/proc/self/mem"}]})";
    for (const std::string& cmd :
         {std::string("render /proc/self/mem --out o"), std::string("simulate /proc/self/mem --out o"),
          std::string("gln ring.txt /proc/self/mem"), std::string("info /proc/self/mem"),
          std::string("simulate mesh.json --out o"), std::string("simulate levelset.json --out o"),
          std::string("imgdiff /proc/self/mem /proc/self/mem")}) {
        const Run r = runDgvIn(dir.path(), cmd);
        INFO(cmd << ": exit " << r.exitCode << ", stderr: " << r.err);
        CHECK(r.exitCode == 1);
        CHECK(lineCount(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains("/proc/self/mem: read error: Input/output error"));
        CHECK_FALSE(fs::exists(dir.path() / "o"));
    }
}

TEST_CASE("e2e: a state checkpoint that cannot be read (EIO) is skipped with the system's reason", "[e2e][faults]") {
    // It was skipped as "not a dgv state file", the content blamed for the disk.
    test::TempDir dir("e2e_state_eio");
    std::ofstream(dir.path() / "s.json") << R"({"name": "s", "frames": {"start": 1, "end": 4},
      "objects": [{"primitive": {"type": "sphere", "radius": 0.2}, "resolution": 8,
                   "transform": {"translate": [0, 0.5, 0]}}], "forces": [{"type": "gravity"}]})";
    REQUIRE(runDgvIn(dir.path(), "-q simulate s.json --out o --frames 3").exitCode == 0);
    const fs::path state = dir.path() / "o" / "state" / "s.0003.dgvstate";
    REQUIRE(fs::exists(state));
    fs::remove(state);
    fs::create_symlink("/proc/self/mem", state);
    const Run r = runDgvIn(dir.path(), "simulate s.json --out o --resume");
    INFO(r.err);
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("s.0003.dgvstate: cannot be read: Input/output error (the system failed to "
                                      "read it, not its content)"));
    CHECK_THAT(r.err, Catch::Contains("frames 1-2 restored from the checkpoint"));
    CHECK(readStatsCsv(dir.path() / "o" / "stats.csv").size() == 4);
}

TEST_CASE("e2e: an output folder that is a dangling symbolic link exits 2 naming the link's target",
          "[e2e][badinput]") {
    // Making the folder failed after the setup, with only "File exists".
    test::TempDir dir("e2e_bad_out_link");
    std::ofstream(dir.path() / "s.json") << sphereScene("");
    fs::create_symlink(dir.path() / "missing" / "folder", dir.path() / "o");
    for (const std::string out : {"o", "o/frames"}) {
        const Run r = runDgvIn(dir.path(), "render s.json --out " + out);
        INFO("--out " << out << ": exit " << r.exitCode << ", stderr: " << r.err);
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains("--out") && Catch::Contains("symbolic link") &&
                              Catch::Contains("missing/folder") && Catch::Contains("which does not exist"));
        CHECK(r.out.empty());
        CHECK_FALSE(fs::exists(dir.path() / "missing"));
    }
}

TEST_CASE("e2e: a part thinner than the lattice resolves runs, with one warning naming the object", "[e2e][badinput]") {
    // A cube 1 m across with a rod 0.03 m thick and 0.6 m long on one face: at resolution 16
    // (h = 0.1) the rod has no complete cell, so its far vertices follow the cube's fit.
    auto box = [](std::ostringstream& obj, int base, double x0, double y0, double z0, double x1, double y1, double z1) {
        for (int c = 0; c < 8; ++c)
            obj << "v " << (c & 1 ? x1 : x0) << ' ' << (c & 2 ? y1 : y0) << ' ' << (c & 4 ? z1 : z0) << '\n';
        const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
        for (const auto& f : faces)
            obj << "f " << base + f[0] << ' ' << base + f[1] << ' ' << base + f[2] << ' ' << base + f[3] << '\n';
    };
    std::ostringstream cube, rodded;
    box(cube, 1, -0.5, -0.5, -0.5, 0.5, 0.5, 0.5);
    box(rodded, 1, -0.5, -0.5, -0.5, 0.5, 0.5, 0.5);
    box(rodded, 9, 0.5, -0.015, -0.015, 1.1, 0.015, 0.015);
    test::TempDir dir("e2e_thin_part");
    std::ofstream(dir.path() / "cube.obj") << cube.str();
    std::ofstream(dir.path() / "rodded.obj") << rodded.str();
    auto scene = [](const std::string& mesh) {
        return R"({"frames": {"start": 1, "end": 2}, "objects": [{"name": "part", "mesh": ")" + mesh +
               R"(", "resolution": 16, "transform": {"translate": [0, 1, 0]}}], "forces": [{"type": "gravity"}]})";
    };
    std::ofstream(dir.path() / "cube.json") << scene("cube.obj");
    std::ofstream(dir.path() / "rodded.json") << scene("rodded.obj");
    const Run thin = runDgvIn(dir.path(), "-q simulate rodded.json --out o_rodded");
    INFO("stderr: " << thin.err);
    CHECK(thin.exitCode == 0);
    CHECK(lineCount(thin.err) == 1);
    // The rod's far end: its 4 vertices 2.5 voxels and more from the cube's lattice, of 16.
    CHECK_THAT(thin.err, Catch::StartsWith("dgv: warning: object 'part': 4 of its 16 vertices lie 2.5 voxels or more "
                                           "from its lattice"));
    CHECK_THAT(thin.err, Catch::Contains("a higher 'resolution' simulates them"));
    const Run whole = runDgvIn(dir.path(), "-q simulate cube.json --out o_cube");
    INFO("stderr: " << whole.err);
    CHECK(whole.exitCode == 0);
    CHECK(whole.err.empty());
    // `dgv info` says the same of the mesh, at the same resolution.
    const Run info = runDgvIn(dir.path(), "info rodded.obj --resolution 16");
    INFO("stdout: " << info.out);
    CHECK(info.exitCode == 0);
    CHECK_THAT(info.out, Catch::Contains("\nunresolved_vertices: 4 of 16 "));
    const Run infoCube = runDgvIn(dir.path(), "info cube.obj --resolution 16");
    CHECK_THAT(infoCube.out, Catch::Contains("\nunresolved_vertices: 0 of 8 "));
}
