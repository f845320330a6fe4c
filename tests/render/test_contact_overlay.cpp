// Contact highlighting from the simulation's contact set R (sim/contact_highlight.hpp, scene key
// render.contact) and the overlays (lines and dots, FrameScene::lines / points).

#include "render/renderer.hpp"

#include "e2e/e2e_run.hpp"
#include "geom/embedding.hpp"
#include "geom/primitives.hpp"
#include "geom/voxelise.hpp"
#include "io/png.hpp"
#include "sim/contact_highlight.hpp"
#include "support/helpers.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>

using namespace dgv;

TEST_CASE("contact highlight: frames since contact per lattice point", "[render][contact]") {
    ContactHistory h;
    h.observe({0, 1, 0});
    CHECK(h.age() == std::vector<int>{ContactHistory::kNever, 0, ContactHistory::kNever});
    h.observe({1, 0, 0});
    CHECK(h.age() == std::vector<int>{0, 1, ContactHistory::kNever});
    h.observe({0, 0, 0});
    h.observe({0, 0, 0});
    CHECK(h.age() == std::vector<int>{2, 3, ContactHistory::kNever});
    h.observe({0, 0});  // a new lattice: the history restarts
    CHECK(h.age() == std::vector<int>{ContactHistory::kNever, ContactHistory::kNever});
}

TEST_CASE("contact highlight: per-point scalars by depth and by time since contact", "[render][contact]") {
    const std::vector<unsigned char> contact{1, 1, 0, 0};
    const std::vector<Real> depth{0.03, 0.0, 0.0, 0.0};
    const std::vector<int> age{0, 0, 3, ContactHistory::kNever};
    const std::vector<Real> d = contactPointScalar(ContactHighlightMode::Depth, contact, depth, age, 4, 0.01);
    CHECK(d[0] == Approx(0.04).epsilon(1e-15));
    CHECK(d[1] == 0.01);  // in R with zero depth: still highlighted
    CHECK(d[2] == -0.01); // outside R: negative, so the edge falls between points
    CHECK(d[3] == -0.01);
    const std::vector<Real> r = contactPointScalar(ContactHighlightMode::Recent, contact, depth, age, 4);
    CHECK(r == std::vector<Real>{1.0, 1.0, 0.25, -1.0});
    CHECK(contactPointScalar(ContactHighlightMode::Off, contact, depth, age, 4) == std::vector<Real>(4, 0.0));
}

TEST_CASE("contact highlight: point values reach the mesh vertices as the positions do", "[render][contact]") {
    // An affine field over the lattice points is reproduced exactly at trilinear vertices
    // (trilinear interpolation is exact for affine functions); anchored vertices take their
    // anchor's value.
    const TriangleMesh box = makeBox(Vec3(1.0, 0.8, 0.6), 4);
    VoxeliseSettings spec;
    spec.voxelSize = 0.1;
    const Lattice lat = voxelise(box, spec);
    REQUIRE(lat.size() > 100);
    std::vector<Vec3> verts = box.vertices;
    verts.push_back(Vec3(0.05, 0.02, -0.03));  // deep inside: trilinear
    const MeshEmbedding emb = embedVertices(lat, verts);
    auto field = [](const Vec3& x) { return 0.3 + 2.0 * x.x() - 1.5 * x.y() + 0.7 * x.z(); };
    std::vector<Real> pointValue(static_cast<std::size_t>(lat.size()));
    for (Index p = 0; p < lat.size(); ++p)
        pointValue[static_cast<std::size_t>(p)] =
            field(lat.originWorld + lat.spacing * lat.coords[static_cast<std::size_t>(p)].cast<Real>());
    std::vector<Real> out;
    pointScalarToVertices(emb, pointValue, out);
    REQUIRE(out.size() == verts.size());
    int trilinear = 0;
    for (std::size_t v = 0; v < verts.size(); ++v) {
        if (emb.trilinear(v)) {
            ++trilinear;
            CHECK(out[v] == Approx(field(verts[v])).margin(1e-12));
        } else {
            CHECK(out[v] == pointValue[static_cast<std::size_t>(emb.anchor[v])]);
        }
    }
    CHECK(emb.trilinear(verts.size() - 1));
    CHECK(trilinear >= 1);
}

namespace {

/// A ball (radius 0.5, centre 0.52 above the ground collider at y = 0) pushed down onto it,
/// seen from below and in front (no drawn ground), so the flattened contact patch faces the
/// camera; `contact` is the render.contact object ("" for none).
void writeBallScene(const std::filesystem::path& dir, const std::string& contact, int frames) {
    std::ofstream f(dir / "ball.json");
    f << R"({ "name": "ball", "frames": { "start": 1, "end": )" << frames << R"(, "fps": 24 }, "substeps": 2,
  "objects": [ { "name": "ball", "primitive": { "type": "sphere", "radius": 0.5 }, "resolution": 14,
                 "transform": { "translate": [0, 0.52, 0] }, "color": [0.7, 0.2, 0.2],
                 "velocity": [0, -1.5, 0] } ],
  "forces": [ { "type": "gravity" } ],
  "colliders": [ { "type": "ground", "height": 0 } ],
  "camera": { "type": "look_at", "eye": [0, -1.0, 2.4], "target": [0, 0.35, 0], "fov": 35 },
  "render": { "width": 128, "height": 128, "ground": false)"
      << (contact.empty() ? "" : ", \"contact\": " + contact) << R"( } })";
}

/// Where a world point lands in a 128x128 frame of that camera (pixel column, row from the top).
Vec2 project(const Vec3& p) {
    Camera cam;
    cam.eye = Vec3(0, -1.0, 2.4);
    cam.target = Vec3(0, 0.35, 0);
    cam.fovYDegrees = 35;
    const Vec4 c = cam.clipFromView(1.0, 0.1, 10) * cam.viewFromWorld() * p.homogeneous();
    return Vec2((c.x() / c.w() * 0.5 + 0.5) * 128, (0.5 - c.y() / c.w() * 0.5) * 128);
}

/// Green-highlighted: the ramp colour is pure green, the ball red.
bool highlighted(const Image& img, int x, int y) {
    const std::uint16_t* p = img.pixel(x, y);
    return p[1] > p[0] + 8000;
}

}  // namespace

TEST_CASE("contact highlight: a ball pushed onto the ground shows R at the bottom only", "[render][contact][e2e]") {
    test::TempDir dir("contact_ball");
    const int frames = 6;
    writeBallScene(dir.path(), R"({ "mode": "depth", "low": [0, 1, 0], "high": [0, 1, 0.5] })", frames);
    const e2e::Run run = e2e::runDgvIn(dir.path(), "-q render ball.json --out hi");
    REQUIRE(run.exitCode == 0);
    const Image img = readPng(dir.path() / "hi" / "ball.0006.png");
    REQUIRE(img.width == 128);
    // stats.csv: the last frame has points in contact.
    const std::string stats = e2e::readAll(dir.path() / "hi" / "stats.csv");
    INFO(stats);
    // Pixels in the flattened patch where the ball meets the ground, on its upper front and on
    // its side (all three facing the camera).
    const Vec2 bottom = project(Vec3(0, 0.02, 0.1));
    const Vec2 top = project(Vec3(0, 0.75, 0.42));
    const Vec2 side = project(Vec3(0.35, 0.52, 0.35));
    int hot = 0, hotAbove = 0;
    const Vec2 centre = project(Vec3(0, 0.35, 0.5));  // the front of the ball at 0.35 m
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x)
            if (highlighted(img, x, y)) {
                ++hot;
                if (y < centre.y()) ++hotAbove;
            }
    CHECK(hot >= 20);        // a visible patch
    CHECK(hotAbove == 0);    // nothing above 0.35 m on the front of the ball
    CHECK(highlighted(img, int(bottom.x()), int(bottom.y())));
    CHECK_FALSE(highlighted(img, int(top.x()), int(top.y())));
    CHECK_FALSE(highlighted(img, int(side.x()), int(side.y())));

    // The same scene without the key: no highlighted pixel at all, and the top of the ball is
    // the same colour (the ramp changes only where R is).
    writeBallScene(dir.path(), "", frames);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render ball.json --out off --frames 6").exitCode == 0);
    const Image off = readPng(dir.path() / "off" / "ball.0006.png");
    int hotOff = 0;
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) hotOff += highlighted(off, x, y) ? 1 : 0;
    CHECK(hotOff == 0);
    for (int c = 0; c < 4; ++c)
        CHECK(off.pixel(int(top.x()), int(top.y()))[c] == img.pixel(int(top.x()), int(top.y()))[c]);

    // --frames 6 alone (simulated from frame 1) gives the same highlighted frame.
    writeBallScene(dir.path(), R"({ "mode": "depth", "low": [0, 1, 0], "high": [0, 1, 0.5] })", frames);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render ball.json --out part --frames 6").exitCode == 0);
    CHECK(e2e::readAll(dir.path() / "part" / "ball.0006.png") == e2e::readAll(dir.path() / "hi" / "ball.0006.png"));
}

TEST_CASE("contact highlight: bad render.contact settings are one-line input errors", "[render][contact][e2e]") {
    test::TempDir dir("contact_bad");
    writeBallScene(dir.path(), R"({ "mode": "deep" })", 1);
    e2e::Run r = e2e::runDgvIn(dir.path(), "-q render ball.json --out o");
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Catch::Contains("render.contact.mode: expected one of 'off', 'depth', 'recent'"));
    writeBallScene(dir.path(), R"({ "mode": "recent", "fade": 3 })", 1);
    r = e2e::runDgvIn(dir.path(), "-q render ball.json --out o");
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Catch::Contains("render.contact.fade: unknown key"));
    CHECK_FALSE(std::filesystem::exists(dir.path() / "o"));
}

TEST_CASE("overlays: lines and dots are drawn where the camera projects them", "[render][overlay]") {
    test::FpTrapsOff guard;  // Mesa's shader compiler uses floating-point exceptions
    RenderSettings s;
    s.width = 128;
    s.height = 128;
    Renderer renderer(s);
    Camera cam;
    cam.eye = Vec3(0, 0, 5);
    cam.target = Vec3::Zero();
    cam.fovYDegrees = 35;
    FrameScene scene;
    scene.groundPlane = false;
    scene.meshes.push_back(test::uvSphere(Vec3::Zero(), 0.5));
    const Image plain = renderer.render(scene, cam);
    // A horizontal line through the sphere's centre (in front of it), and a dot on the right.
    Polyline line;
    line.points = {Vec3(-1.2, 0, 0.6), Vec3(1.2, 0, 0.6)};
    line.closed = false;
    line.colour = Vec3(0, 1, 0);
    line.width = 3;
    scene.lines.push_back(line);
    PointSet dots;
    dots.points = {Vec3(1.0, 0.8, 0)};
    dots.colour = Vec3(0, 0, 1);
    dots.size = 6;
    scene.points.push_back(dots);
    // A dot behind the sphere, depth-tested: hidden.
    PointSet hidden;
    hidden.points = {Vec3(0, 0.2, -1.0)};
    hidden.colour = Vec3(1, 1, 0);
    hidden.size = 6;
    hidden.onTop = false;
    scene.points.push_back(hidden);
    const Image img = renderer.render(scene, cam);
    auto at = [&](const Image& im, const Vec3& p, int c) {
        const Vec4 q = cam.clipFromView(1.0, 0.1, 10) * cam.viewFromWorld() * p.homogeneous();
        const int x = int((q.x() / q.w() * 0.5 + 0.5) * 128), y = int((0.5 - q.y() / q.w() * 0.5) * 128);
        return im.pixel(x, y)[c];
    };
    // Line: pure green (sRGB 1 -> 65535) at its middle and near its ends; 4 px away unchanged.
    for (double x : {-1.0, 0.0, 0.9}) {
        CHECK(at(img, Vec3(x, 0, 0.6), 1) == 65535);
        CHECK(at(img, Vec3(x, 0, 0.6), 0) == 0);
    }
    CHECK(at(img, Vec3(0, 0.12, 0.6), 0) == at(plain, Vec3(0, 0.12, 0.6), 0));
    CHECK(at(img, Vec3(1.0, 0.8, 0), 2) == 65535);
    CHECK(at(img, Vec3(1.0, 0.8, 0), 1) == 0);
    // The hidden dot leaves the sphere as it was.
    for (int c = 0; c < 4; ++c) CHECK(at(img, Vec3(0, 0.2, -1.0), c) == at(plain, Vec3(0, 0.2, -1.0), c));
    // Dots are round: the corner of the 6 px square stays background.
    const Vec4 q = cam.clipFromView(1.0, 0.1, 10) * cam.viewFromWorld() * Vec3(1.0, 0.8, 0).homogeneous();
    const int cx = int((q.x() / q.w() * 0.5 + 0.5) * 128), cy = int((0.5 - q.y() / q.w() * 0.5) * 128);
    CHECK(img.pixel(cx + 3, cy + 3)[2] == plain.pixel(cx + 3, cy + 3)[2]);
}
