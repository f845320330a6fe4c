// The dgv command as a user runs it: exit codes, one-line errors, nothing half-written.

#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <utility>
#include <vector>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> filesIn(const fs::path& dir) {
    std::vector<std::string> names;
    if (!fs::exists(dir)) return names;
    for (const auto& e : fs::recursive_directory_iterator(dir)) names.push_back(fs::relative(e.path(), dir).string());
    std::sort(names.begin(), names.end());
    return names;
}

std::string readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

std::size_t lineCount(const std::string& s) { return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n')); }

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

/// A small scene in `dir` rendering quickly.
fs::path writeSmallScene(const fs::path& dir, const std::string& extra = "") {
    fs::path scene = dir / "small.json";
    std::ofstream(scene) << R"({
  "frames": {"start": 1, "end": 2},
  "objects": [{"primitive": {"type": "sphere", "radius": 0.5}, "resolution": 12, "color": [0.8, 0.3, 0.2]}],
  "render": {"width": 64, "height": 48, "supersample": 1})"
                         << extra << "}\n";
    return scene;
}

}  // namespace

TEST_CASE("cli: help and version", "[app][cli]") {
    auto r = test::runDgv("--help");
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("render") && Catch::Contains("imgdiff") && Catch::Contains("Exit codes"));
    r = test::runDgv("render --help");
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("--frames"));
    // Each subcommand's help names the global options it also takes.
    for (const char* sub : {"render", "simulate", "info", "farm submit"}) {
        INFO(sub);
        r = test::runDgv(std::string(sub) + " --help");
        CHECK(r.exitCode == 0);
        CHECK_THAT(r.output, Catch::Contains("--threads N") && Catch::Contains("--quiet") &&
                                 Catch::Contains("--progress auto|bar|log") && Catch::Contains("Exit codes"));
    }
    r = test::runDgv("--version");
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::StartsWith("dgv "));
}

TEST_CASE("cli: bad usage exits 2 with one line", "[app][cli]") {
    for (const char* args : {"render", "frobnicate", "render a.json --width -5", "info"}) {
        INFO(args);
        auto r = test::runDgv(args);
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.output) == 1);
    }
}

TEST_CASE("cli: a mistyped command is named with the nearest one", "[app][cli]") {
    auto r = test::runDgv("rendr scenes/x.json");
    CHECK(r.exitCode == 2);
    CHECK(r.output == "dgv: error: unknown command 'rendr' (did you mean 'render'?)\n");
    r = test::runDgv("--threads 2 -q simualte x.json");  // a global option's value is not the command
    CHECK(r.exitCode == 2);
    CHECK(r.output == "dgv: error: unknown command 'simualte' (did you mean 'simulate'?)\n");
    r = test::runDgv("ifno a.obj");
    CHECK(r.output == "dgv: error: unknown command 'ifno' (did you mean 'info'?)\n");
    r = test::runDgv("frobnicate");
    CHECK(r.exitCode == 2);
    CHECK(r.output ==
          "dgv: error: unknown command 'frobnicate' (commands: render, simulate, gln, imgdiff, info, "
          "bench, farm; see dgv --help)\n");
    // A mistyped option is named with the nearest of the command's and the global options.
    for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
             {"render x.json --widht 64", "unknown option '--widht' for 'render' (did you mean '--width'?)"},
             {"simulate x.json --thraeds=2", "unknown option '--thraeds' for 'simulate' (did you mean '--threads'?)"},
             {"info a.obj --frobnicate", "unknown option '--frobnicate' for 'info' (see dgv info --help)"}}) {
        r = test::runDgv(args);
        CHECK(r.exitCode == 2);
        CHECK(r.output == "dgv: error: " + message + "\n");
    }
    // An extra argument after a known command keeps CLI11's message.
    r = test::runDgv("info a.obj b.obj");
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.output, Catch::Contains("b.obj") && !Catch::Contains("unknown command"));
}

TEST_CASE("cli: global options are taken before or after the subcommand", "[app][cli][render]") {
    test::TempDir dir("cli_global_options");
    const fs::path scene = writeSmallScene(dir.path());
    const std::vector<std::pair<std::string, std::string>> runs = {
        {"a", "--threads 1 -q --progress log render " + q(scene) + " --frames 1 --out " + q(dir.path() / "a")},
        {"b", "render " + q(scene) + " --frames 1 --out " + q(dir.path() / "b") + " --threads 1 -q --progress log"},
        {"c", "render --threads 1 " + q(scene) + " -q --frames 1 --progress=log --out " + q(dir.path() / "c")}};
    for (const auto& [out, args] : runs) {
        INFO(args);
        auto r = test::runDgv(args);
        CHECK(r.exitCode == 0);
        CHECK(r.output.empty());  // -q took effect
        CHECK(fs::exists(dir.path() / out / "small.0001.png"));
    }
    // --progress after the subcommand takes effect: a bar even though the output is a pipe.
    auto bar = test::runDgv("render " + q(scene) + " --frames 1 --out " + q(dir.path() / "d") + " --progress bar");
    CHECK(bar.exitCode == 0);
    CHECK(bar.output.find('\r') != std::string::npos);
    // Checked as before the subcommand.
    auto bad = test::runDgv("render " + q(scene) + " --threads 5000");
    CHECK(bad.exitCode == 2);
    CHECK(lineCount(bad.output) == 1);
    CHECK_THAT(bad.output, Catch::Contains("--threads"));
    auto progress = test::runDgv("info x.obj --progress sometimes");
    CHECK(progress.exitCode == 2);
    CHECK_THAT(progress.output, Catch::Contains("--progress"));
}

TEST_CASE("cli: simulate writes stats.csv with the volume columns and a VDB cache", "[app][cli][dynamics]") {
    test::TempDir dir("cli_simulate");
    const std::string scene = std::string(DGV_SOURCE_DIR) + "/scenes/twisted_column.json";
    auto r =
        test::runDgv("-q simulate " + q(std::filesystem::path(scene)) + " --frames 4 --vdb --out " + q(dir.path()));
    INFO(r.output);
    REQUIRE(r.exitCode == 0);
    std::ifstream f(dir.path() / "stats.csv");
    std::string line;
    REQUIRE(std::getline(f, line));
    CHECK(line ==
          "frame,time,kinetic_energy,sum_dgamma2,max_cell_volume_error,total_volume_drift,inverted_cells,"
          "contacts,limited_points,step_ms,max_penetration,contact_precision,contact_recall,substeps,"
          "flipped_triangles,torn_edges,surface_stretch,reparametrisations,solve_iterations,solve_unconverged");
    int rows = 0;
    while (std::getline(f, line)) {
        ++rows;
        std::vector<double> v;
        std::stringstream ss(line);
        for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
        REQUIRE(v.size() == 20);
        CHECK(v[0] == rows);                  // frames 1..4
        CHECK(v[4] <= 1e-4);                  // max_cell_volume_error
        CHECK(std::abs(v[5]) <= 1e-6);        // total_volume_drift
        CHECK(v[6] == 0);                     // no inverted cell
        CHECK(v[13] == (rows == 1 ? 0 : 2));  // substeps: the scene's 2 (the first frame is not simulated)
        CHECK(v[14] == 0);                    // flipped_triangles
        CHECK(v[15] == 0);                    // torn_edges
        // surface_stretch: the worst edge against its frames' prediction, under the tear bound
        // (0 on the first row, which is not checked)
        CHECK(v[16] < 4);
        if (rows > 1) CHECK(v[16] > 0.5);
        CHECK(v[17] == 0);  // reparametrisations: a pinned column keeps its lattice
        CHECK(v[18] == 0);  // solve_iterations: the chain's step has no one solve
        CHECK(v[19] == 0);  // solve_unconverged
    }
    CHECK(rows == 4);
    for (int frame = 1; frame <= 4; ++frame)
        CHECK(std::filesystem::exists(dir.path() / "vdb" / ("twisted_column.000" + std::to_string(frame) + ".vdb")));
}

TEST_CASE("cli: gln prints the certified linking number, or why not", "[app][cli][gln]") {
    test::TempDir dir("cli_gln");
    // Ring A: radius 1 in the xy-plane; rings B: radius 1 in the xz-plane, centred at (c, 0, 0):
    // linked (Hopf) for 0 < c < 2, unlinked for c > 2, touching A at (1, 0, 0) for c = 2.
    auto ring = [&](const std::string& name, double c, bool xz) {
        std::ofstream f(dir.path() / name);
        f << "# ring\n";
        for (int k = 0; k < 64; ++k) {
            const double phi = 2 * M_PI * k / 64;
            const double cs = k == 32 ? -1 : k == 0 ? 1 : std::cos(phi), sn = k == 32 || k == 0 ? 0 : std::sin(phi);
            if (xz)
                f << c + cs << " 0 " << sn << "\n";
            else
                f << cs << " " << sn << " 0\n";
        }
    };
    ring("a.txt", 0, false);
    ring("hopf.txt", 1, true);
    ring("apart.txt", 2.5, true);
    ring("touch.txt", 2, true);
    const std::string a = q(dir.path() / "a.txt");
    auto r = test::runDgv("gln " + a + " " + q(dir.path() / "hopf.txt"));
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("gln: 1\n") || Catch::Contains("gln: -1\n"));
    CHECK_THAT(r.output, Catch::Contains("raw: ") && Catch::Contains("bound: "));
    r = test::runDgv("gln " + a + " " + q(dir.path() / "apart.txt"));
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("gln: 0\n"));
    r = test::runDgv("gln " + a + " " + q(dir.path() / "hopf.txt") + " --method seed --tolerance 1");
    CHECK(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("method: seed"));
    // Intersecting curves: the linking number is undefined; exit 1.
    r = test::runDgv("gln " + a + " " + q(dir.path() / "touch.txt"));
    CHECK(r.exitCode == 1);
    CHECK_THAT(r.output, Catch::Contains("intersect"));
    // Bad curve files: one line naming the file and the line, exit 2.
    struct Bad {
        std::string text, expected;
    };
    for (const Bad& b : std::vector<Bad>{{"0 0 0\n1 0 0\n1 x 0\n0 1 0\n", "line 3"},
                                         {"0 0 0\n1 0 0\n# c\n1 1\n", "line 4"},
                                         {"0 0 0\n1 nan 0\n0 1 0\n", "line 2"},
                                         {"0 0 0\n1 0 0\n", "at least 3 vertices"}}) {
        INFO(b.text);
        std::ofstream(dir.path() / "bad.txt") << b.text;
        r = test::runDgv("gln " + a + " " + q(dir.path() / "bad.txt"));
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.output) == 1);
        CHECK_THAT(r.output, Catch::Contains("bad.txt") && Catch::Contains(b.expected));
    }
    r = test::runDgv("gln " + a + " " + q(dir.path() / "absent.txt"));
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.output, Catch::Contains("absent.txt"));
}

TEST_CASE("cli: bad scenes give one line naming file and path, exit 2, and write nothing", "[app][cli]") {
    test::TempDir dir("cli_bad");
    const fs::path out = dir.path() / "out";
    struct Case {
        std::string text, expected;
    };
    std::vector<Case> cases = {
        {"{\"objects\": [", "malformed JSON"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "voxel_size": 0}]})",
         "objects[0].voxel_size: expected a positive number"},
        {R"({"objects": [{"mesh": "missing.obj"}]})", "objects[0].mesh:"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "voxel_size": 1e-6}]})", "objects[0].voxel_size"},
    };
    for (const Case& c : cases) {
        INFO(c.text);
        fs::path scene = dir.path() / "bad.json";
        std::ofstream(scene) << c.text;
        auto r = test::runDgv("render " + q(scene) + " --out " + q(out));
        CHECK(r.exitCode == 2);
        CHECK(lineCount(r.output) == 1);
        CHECK_THAT(r.output, Catch::Contains("bad.json") && Catch::Contains(c.expected));
        CHECK_FALSE(fs::exists(out));
    }
    auto r = test::runDgv("render " + q(dir.path() / "absent.json"));
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.output, Catch::Contains("absent.json: no such file"));
}

TEST_CASE("cli: render writes a numbered PNG sequence and nothing else", "[app][cli][render]") {
    test::TempDir dir("cli_render");
    fs::path scene = writeSmallScene(dir.path());
    const fs::path out = dir.path() / "frames";
    auto r = test::runDgv("--progress log render " + q(scene) + " --out " + q(out));
    INFO(r.output);
    REQUIRE(r.exitCode == 0);
    CHECK(filesIn(out) == std::vector<std::string>{"small.0001.png", "small.0002.png"});
    CHECK_THAT(r.output, Catch::Contains("render 2/2 frames"));

    SECTION("a frame range renders only those frames, keeping the scene's numbers") {
        const fs::path out2 = dir.path() / "part";
        auto r2 = test::runDgv("-q render " + q(scene) + " --frames 2-2 --out " + q(out2));
        REQUIRE(r2.exitCode == 0);
        CHECK(r2.output.empty());
        CHECK(filesIn(out2) == std::vector<std::string>{"small.0002.png"});
        // the same frame rendered in another run is byte-identical
        CHECK(readBytes(out2 / "small.0002.png") == readBytes(out / "small.0002.png"));
    }
    SECTION("a range outside the scene is refused") {
        auto r2 = test::runDgv("render " + q(scene) + " --frames 2-9 --out " + q(dir.path() / "x"));
        CHECK(r2.exitCode == 2);
        CHECK_THAT(r2.output, Catch::Contains("outside the scene's range 1-2"));
        CHECK_FALSE(fs::exists(dir.path() / "x"));
    }
}

TEST_CASE("cli: render with a keyframed camera, --resolution and --gl-backend", "[app][cli][render]") {
    test::TempDir dir("cli_render_keys");
    const fs::path scene = writeSmallScene(dir.path(), R"(,
  "camera": {"type": "keyframed", "keys": [{"frame": 1, "eye": [0, 0.5, 3], "target": [0, 0, 0]},
                                           {"frame": 2, "eye": [3, 0.5, 0], "target": [0, 0, 0], "fov": 25}]})");
    const fs::path out = dir.path() / "frames";
    auto r = test::runDgv("-q render " + q(scene) + " --resolution 80x40 --gl-backend osmesa --contact-sheet --out " +
                          q(out));
    INFO(r.output);
    REQUIRE(r.exitCode == 0);
    const std::string png = readBytes(out / "small.0001.png");
    REQUIRE(png.size() > 24);
    auto be32 = [&](std::size_t at) {
        return (unsigned(static_cast<unsigned char>(png[at])) << 24) |
               (unsigned(static_cast<unsigned char>(png[at + 1])) << 16) |
               (unsigned(static_cast<unsigned char>(png[at + 2])) << 8) |
               unsigned(static_cast<unsigned char>(png[at + 3]));
    };
    CHECK(be32(16) == 80u);  // IHDR width, height
    CHECK(be32(20) == 40u);
    // the camera moved between the keys
    CHECK(readBytes(out / "small.0002.png") != png);
    // the contact sheet: 2 frames side by side with 4-pixel gaps
    const std::string sheet = readBytes(out / "small.contact.png");
    REQUIRE(sheet.size() > 24);
    CHECK(filesIn(out) == std::vector<std::string>{"small.0001.png", "small.0002.png", "small.contact.png"});
    auto sheet32 = [&](std::size_t at) {
        return (unsigned(static_cast<unsigned char>(sheet[at + 2])) << 8) |
               unsigned(static_cast<unsigned char>(sheet[at + 3]));
    };
    CHECK(sheet32(16) == 2 * 80u + 3 * 4u);
    CHECK(sheet32(20) == 40u + 2 * 4u);
    // Each thumbnail carries its frame number at its lower left: a dark box 10 x 14 pixels at
    // (2, 24) of the 80 x 40 thumbnail with the digit in white, "1" on the first, "2" on the second.
    const dgv::Image sheetImage = dgv::readPng(out / "small.contact.png");
    auto box = [&](int thumb) {
        std::string bits;
        const int ox = 4 + thumb * (80 + 4) + 2, oy = 4 + 24;
        for (int y = 0; y < 14; ++y)
            for (int x = 0; x < 10; ++x) {
                const unsigned v = dgv::to8bit(sheetImage.pixel(ox + x, oy + y)[0]);  // the sheet is 8-bit
                REQUIRE((v == 255 || v == dgv::to8bit(6000)));
                bits += v == 255 ? '#' : '.';
            }
        return bits;
    };
    // "1" is .#. / ##. / .#. / .#. / ### at twice the size, 2 pixels in from the box's corner.
    const std::string one = box(0), two = box(1);
    CHECK(one.substr(2 * 10, 10) == "....##....");   // the digit's top row, twice
    CHECK(one.substr(11 * 10, 10) == "..######..");  // its foot
    CHECK(two.substr(2 * 10, 10) == "..######..");   // "2" starts with a full bar
    CHECK(one != two);
    // --movie needs ffmpeg: without it, a clear one-line error before anything is rendered
    if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) {
        auto m = test::runDgv("render " + q(scene) + " --movie --out " + q(dir.path() / "m"));
        CHECK(m.exitCode == 2);
        CHECK_THAT(m.output, Catch::Contains("ffmpeg is not on PATH"));
        CHECK_FALSE(fs::exists(dir.path() / "m"));
    } else {
        auto m = test::runDgv("-q render " + q(scene) + " --movie --out " + q(dir.path() / "m"));
        CHECK(m.exitCode == 0);
        CHECK(fs::file_size(dir.path() / "m" / "small.mp4") > 0);
    }

    for (const char* bad : {"--resolution 80", "--resolution 0x40", "--resolution 80x40x2", "--gl-backend vulkan"}) {
        auto b = test::runDgv("render " + q(scene) + " " + bad + " --out " + q(dir.path() / "x"));
        INFO(bad << ": " << b.output);
        CHECK(b.exitCode == 2);
        CHECK(lineCount(b.output) <= 2);
        CHECK_FALSE(fs::exists(dir.path() / "x"));
    }
    const fs::path badKeys = writeSmallScene(dir.path(), R"(,
  "camera": {"type": "keyframed", "keys": [{"frame": 2, "eye": [0, 0.5, 3]}, {"frame": 1, "eye": [1, 0, 3]}]})");
    auto k = test::runDgv("render " + q(badKeys) + " --out " + q(dir.path() / "y"));
    CHECK(k.exitCode == 2);
    CHECK_THAT(k.output, Catch::Contains("camera.keys[1].frame") && Catch::Contains("increase"));
}

TEST_CASE("cli: info describes a mesh and its voxelisation", "[app][cli]") {
    test::TempDir dir("cli_info");
    fs::path obj = dir.path() / "cube.obj";
    std::ofstream(obj) << "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 0 0 2\nv 2 0 2\nv 2 2 2\nv 0 2 2\n"
                          "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";
    auto r = test::runDgv("info " + q(obj) + " --voxel-size 0.25");
    INFO(r.output);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("triangles: 12\n"));
    CHECK_THAT(r.output, Catch::Contains("closed: yes\n"));
    CHECK_THAT(r.output, Catch::Contains("manifold: yes\n"));
    CHECK_THAT(r.output, Catch::Contains("mesh_volume: 8\n"));
    CHECK_THAT(r.output, Catch::Contains("voxels: 512\n"));  // 8 x 8 x 8 centres inside
    CHECK_THAT(r.output, Catch::Contains("voxel_to_mesh_volume: 1.0000\n"));

    auto bad = test::runDgv("info " + q(dir.path() / "none.obj"));
    CHECK(bad.exitCode == 2);
    CHECK(lineCount(bad.output) == 1);
}

TEST_CASE("cli: an FBX mesh in centimetres comes in metres and one line says so", "[app][cli][render]") {
    const fs::path spider = "/usr/share/assimp/models/FBX/spider.fbx";  // package assimp-testmodels
    REQUIRE(fs::exists(spider));
    const std::string line =
        "dgv: " + spider.string() + ": the file's unit is 0.01 m (FBX UnitScaleFactor 1); scaled by 0.01 to metres\n";
    auto info = test::runDgv("info " + q(spider) + " --resolution 8");
    INFO(info.output);
    REQUIRE(info.exitCode == 0);
    CHECK_THAT(info.output,
               Catch::StartsWith(line) && Catch::Contains("unit_scale: 0.01\n") && Catch::Contains("size: 150.59"));
    // In a scene the object's transform comes after the unit; the pin group's second import of
    // the file says nothing.
    test::TempDir dir("cli_fbx_units");
    const fs::path scene = dir.path() / "spider.json";
    std::ofstream(scene) << R"({"frames": {"start": 1, "end": 1},
  "objects": [{"mesh": ")"
                         << spider.string() << R"(", "transform": {"scale": 0.01}, "resolution": 8,
               "pin": {"group": "Kopf"}}],
  "render": {"width": 64, "height": 48, "supersample": 1}})";
    auto r = test::runDgv("render " + q(scene) + " --out " + q(dir.path() / "out") + " --progress log");
    INFO(r.output);
    CHECK(r.exitCode == 0);
    const std::size_t first = r.output.find(line);
    CHECK(first != std::string::npos);
    CHECK(r.output.find(line, first + 1) == std::string::npos);
    // 193.38 m x 0.01 along z over 8 lattice points: both scales were applied.
    CHECK_THAT(r.output, Catch::Contains("(h = 0.2417;"));
}

TEST_CASE("cli: transform.units reads a mesh file in another unit, and a mesh of an unlikely size is warned of",
          "[app][cli]") {
    test::TempDir dir("cli_units");
    // A 200-unit cube: a file in centimetres read as metres is 200 m across.
    std::ofstream(dir.path() / "cube.obj")
        << "v 0 0 0\nv 200 0 0\nv 200 200 0\nv 0 200 0\nv 0 0 200\nv 200 0 200\nv 200 200 200\nv 0 200 200\n"
           "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";
    auto run = [&](const std::string& transform) {
        const fs::path scene = dir.path() / "s.json";
        std::ofstream(scene) << R"({"frames": {"start": 1, "end": 1}, "objects": [{"name": "cube", "mesh": "cube.obj",
          "resolution": 8)" << transform
                             << R"(}], "render": {"width": 64, "height": 48, "supersample": 1}})";
        return test::runDgv("simulate " + q(scene) + " --out " + q(dir.path() / "out") + " --progress log");
    };
    auto spacing = [](const std::string& log) {
        const std::size_t at = log.find("(h = ");
        return at == std::string::npos ? -1.0 : std::strtod(log.c_str() + at + 5, nullptr);
    };
    const auto metres = run("");
    INFO(metres.output);
    REQUIRE(metres.exitCode == 0);
    CHECK_THAT(metres.output, Catch::Contains("dgv: warning: object 'cube' (cube.obj) is 200 m across: is the file in "
                                              "centimetres or millimetres?"));
    const auto cm = run(R"(, "transform": {"units": "cm"})");
    INFO(cm.output);
    REQUIRE(cm.exitCode == 0);
    CHECK_THAT(cm.output, !Catch::Contains("across"));
    CHECK(spacing(cm.output) == Approx(spacing(metres.output) / 100).epsilon(1e-9));
    // 2 m across, 10⁵ m out: floats step its surface by about a centimetre.
    const auto far = run(R"(, "transform": {"units": "cm", "translate": [100000, 0, 0]})");
    CHECK_THAT(far.output, Catch::Contains("object 'cube' (cube.obj) lies 1e+05 m from the origin, 5e+04 times its "
                                           "size: floats keep about 7 digits"));
    const auto tiny = run(R"(, "transform": {"units": 1e-6})");
    CHECK_THAT(tiny.output, Catch::Contains("is 0.0002 m across, under a millimetre"));
    const auto bad = run(R"(, "transform": {"units": "furlong"})");
    CHECK(bad.exitCode == 2);
    CHECK_THAT(bad.output, Catch::Contains("objects[0].transform.units: expected m, cm, mm, km, in, ft or metres per "
                                           "unit (a number > 0), got \"furlong\""));
    // A primitive is in metres: warned of past what the renderer's floats resolve (1e6 m), refused
    // past what dgv simulates and draws (under 1e-6 m it rendered an empty image).
    std::ofstream(dir.path() / "huge.json") << R"({"frames": {"start": 1, "end": 1}, "objects": [{"name": "moon",
      "primitive": {"type": "sphere", "radius": 1e7}, "resolution": 8}]})";
    const auto moon = test::runDgv("simulate " + q(dir.path() / "huge.json") + " --out " + q(dir.path() / "o5"));
    CHECK_THAT(moon.output, Catch::Contains("object 'moon' (a primitive) is 2e+07 m across: the renderer's floats "
                                            "resolve 1e-6 to 1e6 m objects"));
    std::ofstream(dir.path() / "tiny.json") << R"({"frames": {"start": 1, "end": 1}, "objects": [{"name": "dot",
      "primitive": {"type": "sphere", "radius": 1e-8}, "resolution": 8}]})";
    const auto dot = test::runDgv("simulate " + q(dir.path() / "tiny.json") + " --out " + q(dir.path() / "o4"));
    CHECK(dot.exitCode == 2);
    CHECK_THAT(dot.output, Catch::Contains("objects[0].primitive: \"dot\" is 2e-08 m across; dgv simulates and draws "
                                           "objects from 1e-06 to 1e+09 m across"));
    std::ofstream(dir.path() / "p.json") << R"({"frames": {"start": 1, "end": 1}, "objects": [{"primitive":
      {"type": "sphere"}, "transform": {"units": "cm"}}]})";
    const auto onPrimitive = test::runDgv("simulate " + q(dir.path() / "p.json") + " --out " + q(dir.path() / "o3"));
    CHECK(onPrimitive.exitCode == 2);
    CHECK_THAT(onPrimitive.output, Catch::Contains("transform.units: applies to a mesh file"));
}

TEST_CASE("cli: imgdiff passes identical images and fails different ones", "[app][cli][render]") {
    test::TempDir dir("cli_imgdiff");
    fs::path a = writeSmallScene(dir.path());
    REQUIRE(test::runDgv("-q render " + q(a) + " --out " + q(dir.path() / "a")).exitCode == 0);
    fs::path scene2 = dir.path() / "moved" / "small.json";
    fs::create_directories(scene2.parent_path());
    std::ofstream(scene2) << R"({
  "frames": {"start": 1, "end": 2},
  "objects": [{"primitive": {"type": "sphere", "radius": 0.5}, "resolution": 12, "color": [0.2, 0.3, 0.8]}],
  "render": {"width": 64, "height": 48, "supersample": 1}})";
    REQUIRE(test::runDgv("-q render " + q(scene2) + " --out " + q(dir.path() / "b")).exitCode == 0);
    auto same =
        test::runDgv("imgdiff " + q(dir.path() / "a/small.0001.png") + " " + q(dir.path() / "a/small.0001.png"));
    CHECK(same.exitCode == 0);
    CHECK(same.output == "PASS: 0 pixels differ; mean error 0.0000, max error 0.000 at (0, 0) channel R\n");
    auto diff = test::runDgv("imgdiff " + q(dir.path() / "a/small.0001.png") + " " +
                             q(dir.path() / "b/small.0001.png") + " --diff-out " + q(dir.path() / "d"));
    CHECK(diff.exitCode == 1);
    CHECK_THAT(diff.output, Catch::StartsWith("FAIL: ") && !Catch::Contains("FAIL: FAIL"));
    CHECK(fs::exists(dir.path() / "d" / "small.0001.diff.png"));
    CHECK(fs::exists(dir.path() / "d" / "small.0001.new.png"));
}

TEST_CASE("cli: a camera's focal length and sensor in millimetres frame as the field of view they make",
          "[app][cli][render]") {
    // A 64 x 48 render (aspect 4:3): a 36 mm sensor spans the width, so a lens of f mm has the
    // vertical field of view 2 atan(36 / (2 f) * 3 / 4). f = 40.5 mm gives 2 atan(1/3) = 36.87°.
    test::TempDir dir("cli_lens");
    const double fovY = 2 * std::atan(1.0 / 3.0) * 180 / M_PI;
    char fov[64];
    std::snprintf(fov, sizeof fov, "%.17g", fovY);
    for (const std::string& cam :
         {std::string(R"("fov": )") + fov, std::string(R"("focal_length": 40.5)"),
          std::string(R"("focal_length": 40.5, "sensor": 36)"), std::string(R"("focal_length": 20)")}) {
        const fs::path sub = dir.path() / std::to_string(cam.size());
        fs::create_directories(sub);
        const fs::path scene = writeSmallScene(
            sub, R"(, "camera": {"type": "look_at", "eye": [0, 0.5, 3], "target": [0, 0, 0], )" + cam + "}");
        REQUIRE(test::runDgv("-q render " + q(scene) + " --out " + q(sub / "o")).exitCode == 0);
    }
    auto png = [&](const std::string& cam) {
        return q(dir.path() / std::to_string(cam.size()) / "o" / "small.0001.png");
    };
    const std::string byFov = std::string(R"("fov": )") + fov;
    // The same field of view: the same pixels (within the golden-image rule).
    CHECK(test::runDgv("imgdiff " + png(byFov) + " " + png(R"("focal_length": 40.5)")).exitCode == 0);
    CHECK(test::runDgv("imgdiff " + png(byFov) + " " + png(R"("focal_length": 40.5, "sensor": 36)")).exitCode == 0);
    // A wider lens frames another picture.
    CHECK(test::runDgv("imgdiff " + png(byFov) + " " + png(R"("focal_length": 20)")).exitCode == 1);
    // fov and focal_length together, and a sensor without a focal length, are refused.
    const fs::path both = writeSmallScene(dir.path(), R"(, "camera": {"fov": 30, "focal_length": 35})");
    const auto bad = test::runDgv("render " + q(both) + " --out " + q(dir.path() / "bad"));
    CHECK(bad.exitCode == 2);
    CHECK_THAT(bad.output, Catch::Contains("camera.focal_length: give fov or focal_length, not both"));
    const fs::path sensor = writeSmallScene(dir.path(), R"(, "camera": {"sensor": 24})");
    const auto alone = test::runDgv("render " + q(sensor) + " --out " + q(dir.path() / "bad"));
    CHECK(alone.exitCode == 2);
    CHECK_THAT(alone.output, Catch::Contains("camera.sensor: applies with focal_length"));
}

TEST_CASE("cli: every benchmark runs and prints name: value unit lines", "[app][cli][bench][slow]") {
    auto r = test::runDgv("bench --quick --repeats 1");
    INFO(r.output);
    REQUIRE(r.exitCode == 0);
    std::istringstream in(r.output);
    std::string line;
    int figures = 0;
    while (std::getline(in, line)) {
        if (line.rfind("dgv:", 0) == 0) continue;
        INFO(line);
        CHECK_THAT(line, Catch::Matches("[a-z_.0-9]+: .+"));
        ++figures;
    }
    CHECK(figures >= 9);
    CHECK_THAT(r.output, Catch::Contains("geometry.") && Catch::Contains("voxelise.") && Catch::Contains("render.") &&
                             Catch::Contains("contact_pair_r8_ratio: "));
    auto unknown = test::runDgv("bench nonsense");
    CHECK(unknown.exitCode == 2);
}
