// Contact highlighting from the simulation's contact set R (view/contact_highlight.hpp, scene key
// render.contact) and the overlays (lines and dots, FrameScene::lines / points).

#include "render/renderer.hpp"

#include "e2e/e2e_run.hpp"
#include "geom/embedding.hpp"
#include "geom/primitives.hpp"
#include "geom/voxelise.hpp"
#include "io/png.hpp"
#include "view/contact_highlight.hpp"
#include "view/gln_overlay.hpp"
#include "view/lattice_overlay.hpp"
#include "io/scene_json.hpp"
#include "collide/gln_network.hpp"
#include "geom/lattice.hpp"
#include "support/helpers.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
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
    CHECK(d[1] == 0.01);   // in R with zero depth: still highlighted
    CHECK(d[2] == -0.01);  // outside R: negative, so the edge falls between points
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
/// `extra` is appended to the scene's top level (e.g. `"collision": {...}`) and `renderExtra` to
/// its render object after "contact".
void writeBallScene(const std::filesystem::path& dir, const std::string& contact, int frames,
                    const std::string& extra = "", const std::string& renderExtra = "") {
    std::ofstream f(dir / "ball.json");
    f << R"({ "name": "ball", "frames": { "start": 1, "end": )" << frames << R"(, "fps": 24 }, "substeps": 2,
  "objects": [ { "name": "ball", "primitive": { "type": "sphere", "radius": 0.5 }, "resolution": 14,
                 "transform": { "translate": [0, 0.52, 0] }, "color": [0.7, 0.2, 0.2],
                 "velocity": [0, -1.5, 0] } ],
  "forces": [ { "type": "gravity" } ],
  "colliders": [ { "type": "ground", "height": 0 } ],)"
      << extra << R"(
  "camera": { "type": "look_at", "eye": [0, -1.0, 2.4], "target": [0, 0.35, 0], "fov": 35 },
  "render": { "width": 128, "height": 128, "ground": false)"
      << (contact.empty() ? "" : ", \"contact\": " + contact) << renderExtra << R"( } })";
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

TEST_CASE("contact highlight: a ball pushed onto the ground shows R at the bottom only",
          "[render][contact][e2e][slow]") {
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
    CHECK(hot >= 20);      // a visible patch
    CHECK(hotAbove == 0);  // nothing above 0.35 m on the front of the ball
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

TEST_CASE("overlays: GLN loop sets follow the network's rings", "[render][overlay]") {
    const Lattice lat = [] {
        VoxeliseSettings spec;
        spec.voxelSize = 0.1;
        return voxelise(makeSphere(0.5, 32, 16), spec);
    }();
    const GlnNetwork net(lat);
    REQUIRE(net.fine().size() > 50);
    REQUIRE(!net.coarse().empty());
    const std::vector<Vec3> x = restPositions(lat);
    CHECK(glnOverlayLoops(net, GlnLoopSet::All, x, {}).size() == net.fine().size());
    CHECK(glnOverlayLoops(net, GlnLoopSet::Coarse, x, {}).size() == net.coarse().size());
    CHECK(glnOverlayLoops(net, GlnLoopSet::Contact, x, {}).empty());  // no step yet: R empty
    // Two points in R: exactly their fine rings, in ring order.
    std::vector<unsigned char> R(static_cast<std::size_t>(lat.size()), 0);
    R[static_cast<std::size_t>(net.fine()[3].centre)] = 1;
    R[static_cast<std::size_t>(net.fine()[7].centre)] = 1;
    const std::vector<ClosedCurve> two = glnOverlayLoops(net, GlnLoopSet::Contact, x, R);
    REQUIRE(two.size() == 2);
    CHECK(two[0] == net.fineCurve(3, x));
    CHECK(two[1] == net.fineCurve(7, x));
}

TEST_CASE("overlays: GLN loops are drawn where the camera projects them", "[render][overlay]") {
    test::FpTrapsOff guard;
    VoxeliseSettings spec;
    spec.voxelSize = 0.1;
    const Lattice lat = voxelise(makeSphere(0.5, 32, 16), spec);
    const GlnNetwork net(lat);
    const std::vector<Vec3> x = restPositions(lat);
    RenderSettings s;
    s.width = 128;
    s.height = 128;
    Renderer renderer(s);
    Camera cam;
    cam.eye = Vec3(0, 0, 2.5);
    cam.target = Vec3::Zero();
    cam.fovYDegrees = 35;
    auto pixelOf = [&](const Vec3& p) {
        const Vec4 q = cam.clipFromView(1.0, 0.1, 10) * cam.viewFromWorld() * p.homogeneous();
        return Vec2((q.x() / q.w() * 0.5 + 0.5) * 128, (0.5 - q.y() / q.w() * 0.5) * 128);
    };
    FrameScene scene;
    scene.groundPlane = false;
    scene.meshes.push_back(test::uvSphere(Vec3::Zero(), 0.5));
    const Image plain = renderer.render(scene, cam);
    // The coarse rings (2 voxels across: 30 px here) facing the eye, 2 px wide, pure green, over
    // the surface (they lie on boundary lattice points, just under it), as dgv render draws them.
    const std::vector<ClosedCurve> loops = glnOverlayLoops(net, GlnLoopSet::Coarse, x, {}, &cam.eye);
    const std::vector<ClosedCurve> every = glnOverlayLoops(net, GlnLoopSet::Coarse, x, {});
    REQUIRE(!loops.empty());
    CHECK(loops.size() < every.size());
    // Facing the eye on the +z side: the kept rings' centroids are in front, the ones left out
    // are not on the front cap.
    auto centroid = [](const ClosedCurve& c) {
        Vec3 m = Vec3::Zero();
        for (const Vec3& v : c) m += v;
        return Vec3(m / Real(c.size()));
    };
    for (const ClosedCurve& c : every) {
        const Vec3 m = centroid(c);
        if (loopFacesPoint(c, cam.eye))
            CHECK(m.z() > -0.1);
        else
            CHECK(m.normalized().z() < 0.5);
    }
    auto draw = [&](const std::vector<ClosedCurve>& set) {
        FrameScene sc = scene;
        for (const ClosedCurve& c : set) {
            Polyline l;
            l.points = c;
            l.colour = Vec3(0, 1, 0);
            l.width = 2;
            l.onTop = true;
            sc.lines.push_back(l);
        }
        return renderer.render(sc, cam);
    };
    const Image img = draw(loops);
    auto isLoop = [](const std::uint16_t* p) { return p[1] > 60000 && p[0] < 4000 && p[2] < 4000; };
    // Every ring vertex on the side facing the camera (away from the silhouette) projects to a
    // pixel of pure loop colour.
    int probed = 0, green = 0;
    for (const ClosedCurve& c : loops)
        for (const Vec3& v : c) {
            if (v.z() < 0.72 * v.norm()) continue;
            const Vec2 px = pixelOf(v);
            ++probed;
            green += isLoop(img.pixel(int(px.x()), int(px.y()))) ? 1 : 0;
        }
    REQUIRE(probed >= 20);
    CHECK(green >= probed * 9 / 10);  // a vertex on a pixel border may share it with the surface
    // Without the culling the far side's rings show through as well: more loop pixels.
    const Image both = draw(every);
    int front = 0, all = 0;
    for (int yy = 0; yy < 128; ++yy)
        for (int xx = 0; xx < 128; ++xx) {
            front += isLoop(img.pixel(xx, yy)) ? 1 : 0;
            all += isLoop(both.pixel(xx, yy)) ? 1 : 0;
            if (isLoop(img.pixel(xx, yy))) CHECK(isLoop(both.pixel(xx, yy)));
        }
    CHECK(all > front + front / 10);
    // Pixels beyond the ball's disc and the loops' reach are the background, as without loops.
    const Vec2 corner = pixelOf(Vec3(0.75, 0.75, 0));
    for (int c = 0; c < 4; ++c)
        CHECK(img.pixel(int(corner.x()), int(corner.y()))[c] == plain.pixel(int(corner.x()), int(corner.y()))[c]);
}

namespace {

/// The ball scene of writeBallScene with `overlays` as render.overlays and GLN detection.
void writeLoopScene(const std::filesystem::path& dir, const std::string& overlays, int frames) {
    writeBallScene(dir, "", frames, R"(
  "collision": { "detect": "gln" },)",
                   ", \"overlays\": " + overlays);
}

}  // namespace

TEST_CASE("overlays: render.overlays.gln_loops draws the rings of the contact set", "[render][overlay][e2e][slow]") {
    test::TempDir dir("gln_loops");
    writeLoopScene(dir.path(), R"({ "gln_loops": true, "gln_color": [0, 1, 0], "line_width": 2 })", 6);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render ball.json --out on --frames 6").exitCode == 0);
    writeLoopScene(dir.path(), R"({ "gln_loops": false, "gln_color": [0, 1, 0] })", 6);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render ball.json --out off --frames 6").exitCode == 0);
    const Image on = readPng(dir.path() / "on" / "ball.0006.png");
    const Image off = readPng(dir.path() / "off" / "ball.0006.png");
    int loopPixels = 0, above = 0, offPixels = 0;
    const Vec2 centre = project(Vec3(0, 0.35, 0.5));
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) {
            offPixels += highlighted(off, x, y) ? 1 : 0;
            if (!highlighted(on, x, y)) continue;
            ++loopPixels;
            above += y < centre.y() ? 1 : 0;
        }
    CHECK(offPixels == 0);
    CHECK(loopPixels >= 20);  // the rings of the flattened patch
    CHECK(above == 0);        // only where the ball meets the ground
    // Pixels the loops do not reach are the same as without them.
    const Vec2 top = project(Vec3(0, 0.75, 0.42));
    for (int c = 0; c < 4; ++c)
        CHECK(on.pixel(int(top.x()), int(top.y()))[c] == off.pixel(int(top.x()), int(top.y()))[c]);

    // "all": every fine ring, over the whole front of the ball.
    writeLoopScene(dir.path(), R"({ "gln_loops": true, "gln_loop_set": "all", "gln_color": [0, 1, 0] })", 6);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render ball.json --out all --frames 6").exitCode == 0);
    const Image all = readPng(dir.path() / "all" / "ball.0006.png");
    int allAbove = 0;
    for (int y = 0; y < int(centre.y()); ++y)
        for (int x = 0; x < 128; ++x) allAbove += highlighted(all, x, y) ? 1 : 0;
    CHECK(allAbove >= 50);
}

TEST_CASE("overlays: bad render.overlays settings are one-line input errors", "[render][overlay][e2e]") {
    test::TempDir dir("overlay_bad");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {R"({ "gln_loops": "yes" })", "render.overlays.gln_loops: expected true or false"},
        {R"({ "gln_loops": true, "gln_loop_set": "some" })",
         "render.overlays.gln_loop_set: expected one of 'contact', 'all', 'coarse'"},
        {R"({ "gln_loops": true, "line_width": 0.5 })", "render.overlays.line_width"},
        {R"({ "gln_loops": true, "line_width": 65 })", "render.overlays.line_width"},
        {R"({ "gln_loops": true, "gln_color": [1, 0] })", "render.overlays.gln_color"},
        {R"({ "gln_loop": true })", "render.overlays.gln_loop: unknown key"},
        {R"({ "lattice": true, "lattice_set": "surface" })",
         "render.overlays.lattice_set: expected one of 'boundary', 'all'"},
    };
    for (const auto& [overlays, message] : cases) {
        INFO(overlays);
        writeLoopScene(dir.path(), overlays, 1);
        const e2e::Run r = e2e::runDgvIn(dir.path(), "-q render ball.json --out o");
        CHECK(r.exitCode == 2);
        CHECK_THAT(r.err, Catch::Contains(message));
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK_FALSE(std::filesystem::exists(dir.path() / "o"));
    }
    // Parsed values (sRGB colour to linear).
    const SceneDesc s = parseScene(R"({ "objects": [ { "primitive": { "type": "sphere" } } ],
        "render": { "overlays": { "gln_loops": true, "gln_loop_set": "coarse", "gln_color": [1, 0, 0.5], "line_width": 3 } } })",
                                   dir.path() / "p.json");
    CHECK(s.render.overlayGlnLoops);
    CHECK(s.render.overlayGlnLoopSet == GlnLoopSet::Coarse);
    CHECK(s.render.overlayGlnColour.x() == 1.0);
    CHECK(s.render.overlayGlnColour.y() == 0.0);
    CHECK(s.render.overlayGlnColour.z() == Approx(0.21404114).epsilon(1e-6));
    CHECK(s.render.overlayLineWidth == 3.0);
    const SceneDesc d =
        parseScene(R"({ "objects": [ { "primitive": { "type": "sphere" } } ] })", dir.path() / "d.json");
    CHECK_FALSE(d.render.overlayGlnLoops);
    CHECK(d.render.overlayGlnLoopSet == GlnLoopSet::Contact);
    CHECK(d.render.overlayLineWidth == 1.5);
    CHECK(d.render.overlayLatticeSet == LatticeDotSet::Boundary);
    CHECK(d.render.contactMode == ContactHighlightMode::Off);  // no render.contact: off
    const SceneDesc c = parseScene(R"({ "objects": [ { "primitive": { "type": "sphere" } } ],
        "render": { "contact": { "footprint": false }, "overlays": { "lattice_set": "all" } } })",
                                   dir.path() / "c.json");
    CHECK(c.render.contactMode == ContactHighlightMode::Depth);  // render.contact without a mode: depth
    CHECK(c.render.overlayLatticeSet == LatticeDotSet::All);
    const SceneDesc r = parseScene(R"({ "objects": [ { "primitive": { "type": "sphere" } } ],
        "render": { "contact": { "mode": "recent" } } })",
                                   dir.path() / "r.json");
    CHECK(r.render.contactMode == ContactHighlightMode::Recent);
}

// The lattice dots' facing test on a 5x5x5 block seen from far along +x: exactly the i = 4
// face is kept (its outward direction has a +x part; every other boundary point's points away
// from the eye). Turned 90 degrees about z (x -> (-y, x, z)), the face that now looks along +x,
// j = 0, is the one kept: the test follows the deformed positions, not the rest lattice.
TEST_CASE("overlays: lattice dots keep the boundary points facing the eye", "[render][overlay]") {
    const Vec3i dims(5, 5, 5);
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, std::vector<unsigned char>(125, 1));
    const std::vector<Index> surface = boundaryPoints(lat);
    REQUIRE(surface.size() == std::size_t(125 - 27));
    std::vector<Vec3> x = restPositions(lat);
    const Vec3 eye(100, 2, 2);
    std::vector<Vec3> dots = latticeOverlayPoints(lat, x, surface, &eye);
    REQUIRE(dots.size() == 25);
    for (const Vec3& d : dots) CHECK(d.x() == 4.0);
    CHECK(latticeOverlayPoints(lat, x, surface, nullptr).size() == surface.size());
    CHECK(latticeOutward(lat, x, lat.pointAt(Vec3i(2, 2, 2))) == Vec3::Zero());
    CHECK(latticeOutward(lat, x, lat.pointAt(Vec3i(4, 4, 2))) == Vec3(1, 1, 0));
    for (Vec3& p : x) p = Vec3(-p.y() + 6, p.x(), p.z());
    dots = latticeOverlayPoints(lat, x, surface, &eye);
    REQUIRE(dots.size() == 25);
    for (const Vec3& d : dots) CHECK(d.x() == 6.0);  // j = 0 now lies at x = 6
}

// render.overlays.lattice: "boundary" draws the surface layer's points, "all" every point. The
// ball (resolution 14) seen from the camera: interior points project between the surface points,
// so "all" colours clearly more pixels; both leave the background untouched.
TEST_CASE("overlays: lattice dots, boundary layer or all points", "[render][overlay][e2e]") {
    test::TempDir dir("lattice_dots");
    auto dotPixels = [&](const std::string& set) {
        writeBallScene(dir.path(), "", 1, "",
                       R"(, "overlays": { "lattice": true, "lattice_set": ")" + set +
                           R"(", "lattice_color": [0, 1, 0], "point_size": 2 })");
        REQUIRE(e2e::runDgvIn(dir.path(), "-q render ball.json --out " + set).exitCode == 0);
        const Image img = readPng(dir.path() / set / "ball.0001.png");
        int n = 0;
        for (int y = 0; y < 128; ++y)
            for (int x = 0; x < 128; ++x) n += highlighted(img, x, y) ? 1 : 0;
        return n;
    };
    const int boundary = dotPixels("boundary");
    const int all = dotPixels("all");
    CHECK(boundary >= 200);
    CHECK(all > boundary + boundary / 5);
}

// Sphere colliders are drawn (src/app/collider_draw.cpp): a static box beside a sphere collider,
// the camera looking at the sphere's centre. With the collider the centre pixel is the
// collider's grey, lit (R, G and B within the albedo's 0.42-0.47 spread of each other); without
// it that pixel is empty (transparent background).
TEST_CASE("colliders: a sphere collider is drawn where it is", "[render][e2e]") {
    test::TempDir dir("sphere_collider");
    auto write = [&](const std::string& name, bool collider) {
        std::ofstream(dir.path() / name) << R"({ "name": "s", "frames": { "start": 1, "end": 1, "fps": 24 },
  "objects": [ { "name": "box", "primitive": { "type": "box", "size": [0.3, 0.3, 0.3] }, "resolution": 6,
                 "transform": { "translate": [-0.9, 0.5, 0] }, "color": [0.8, 0.1, 0.1] } ],
  "colliders": [ )" << (collider ? R"({ "type": "sphere", "centre": [0.3, 0.5, 0], "radius": 0.4 })" : "")
                                         << R"( ],
  "camera": { "type": "look_at", "eye": [0.3, 0.5, 3], "target": [0.3, 0.5, 0], "fov": 50 },
  "render": { "width": 96, "height": 96, "supersample": 1, "ground": false, "transparent": true } })";
    };
    write("with.json", true);
    write("without.json", false);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render with.json --out a").exitCode == 0);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render without.json --out b").exitCode == 0);
    const Image with = readPng(dir.path() / "a" / "s.0001.png");
    const Image without = readPng(dir.path() / "b" / "s.0001.png");
    const auto centre = with.pixel(48, 48);
    CHECK(centre[3] == 65535);             // opaque: something is drawn there
    CHECK(without.pixel(48, 48)[3] == 0);  // and nothing without the collider
    const int lo = std::min({centre[0], centre[1], centre[2]}), hi = std::max({centre[0], centre[1], centre[2]});
    CHECK(lo > 0);
    CHECK(hi - lo < 0.15 * hi);  // grey, not the box's red
    // A pixel inside the sphere's silhouette (radius 0.4 at distance 3, fov 50: 13.8 px) but off
    // its centre, and one outside it.
    CHECK(with.pixel(48 + 12, 48)[3] == 65535);
    CHECK(with.pixel(48 + 24, 48)[3] == 0);
}

TEST_CASE("contact highlight: the spread over the body falls off linearly with lattice hops", "[render][contact]") {
    // A 7 x 1 x 1 row with the highlight on its first point: hops 1..3 take 3/4, 2/4, 1/4 of it
    // (rings = 3), the rest keep their value; a second, weaker source nearer a point does not
    // win over a stronger one farther away unless its share is larger.
    const Lattice lat = buildLattice(Vec3::Zero(), 0.1, Vec3i(7, 1, 1), std::vector<unsigned char>(7, 1));
    std::vector<Real> s{0.8, -0.01, -0.01, -0.01, -0.01, -0.01, -0.01};
    spreadPointScalar(lat, s, 3);
    CHECK(s[0] == 0.8);
    CHECK(s[1] == Approx(0.6));
    CHECK(s[2] == Approx(0.4));
    CHECK(s[3] == Approx(0.2));
    CHECK(s[4] == -0.01);  // out of reach, and already above the rim's value (−0.05)
    std::vector<Real> recent{1.0, -1, -1, -1, -1, -1, -1};
    spreadPointScalar(lat, recent, 3);
    CHECK(recent[3] == Approx(0.25));
    CHECK(recent[4] == Approx(-0.0625));  // the rim: a quarter of the last ring's value below zero
    CHECK(recent[5] == -1);               // beyond it, unchanged
    std::vector<Real> two{0.8, -0.01, -0.01, -0.01, 0.1, -0.01, -0.01};
    spreadPointScalar(lat, two, 3);
    CHECK(two[3] == Approx(std::max(0.8 * 0.25, 0.1 * 0.75)));  // the strong source: 0.2 > 0.075
    CHECK(two[5] == Approx(0.075));                             // only the weak one reaches
    std::vector<Real> none = s;
    spreadPointScalar(lat, none, 0);  // rings 0: unchanged
    CHECK(none == s);
}

TEST_CASE("contact highlight: collider footprints fall off with the distance to the touching points",
          "[render][contact]") {
    const std::vector<Vec3> vertices{Vec3(0, 0, 0), Vec3(0.05, 0, 0), Vec3(0.1, 0, 0), Vec3(0.3, 0, 0)};
    const std::vector<Vec3> points{Vec3(0, 0.0, 0), Vec3(0.1, 0.05, 0), Vec3(5, 5, 5)};
    const std::vector<Real> value{1.0, 0.5, 0.0};  // the third is not highlighted
    std::vector<Real> v;
    footprintScalar(vertices, points, value, 0.1, 1e-3, v);
    REQUIRE(v.size() == 4);
    CHECK(v[0] == Approx(1.0));
    CHECK(v[1] == Approx(std::max(0.5, 0.5 * (1 - std::hypot(0.05, 0.05) / 0.1))));
    CHECK(v[2] == Approx(0.5 * 0.5));  // 0.05 from the second point; 0.1 from the first (its edge)
    CHECK(v[3] == -1e-3);              // out of reach: below zero, so the edge runs through triangles
}

TEST_CASE("contact highlight: the automatic colour contrasts with the surface", "[render][contact]") {
    // The default (warm) on cool and neutral surfaces; another pair on warm ones.
    CHECK(contrastingHighlight(Vec3(0.3, 0.6, 0.85)).high == Vec3(0.9, 0.05, 0.02));    // jelly_drop's blue
    CHECK(contrastingHighlight(Vec3(0.62, 0.66, 0.72)).high == Vec3(0.9, 0.05, 0.02));  // contact_ball's grey
    const Vec3 putty(0.85, 0.35, 0.2);  // ring_drop's putty, nearly the default red
    const Vec3 h = contrastingHighlight(putty).high;
    CHECK(h != Vec3(0.9, 0.05, 0.02));
    auto srgbDistance = [](const Vec3& a, const Vec3& b) {
        return Vec3(encodeSrgb(a.x()) - encodeSrgb(b.x()), encodeSrgb(a.y()) - encodeSrgb(b.y()),
                    encodeSrgb(a.z()) - encodeSrgb(b.z()))
            .norm();
    };
    CHECK(srgbDistance(h, putty) > 2 * srgbDistance(Vec3(0.9, 0.05, 0.02), putty));
}

TEST_CASE("render: ground marks colour the floor where they lie and nowhere else", "[render][contact]") {
    test::FpTrapsOff guard;  // llvmpipe's shaders
    RenderSettings rs;
    rs.width = 160;
    rs.height = 90;
    Renderer renderer(rs);
    FrameScene scene;
    DrawMesh ball;
    const TriangleMesh sphere = makeSphere(0.3, 32, 16);
    for (const Vec3& p : sphere.vertices) ball.positions.push_back(p + Vec3(0, 0.3, 0));
    ball.triangles = sphere.triangles;
    scene.meshes.push_back(ball);
    scene.groundHeight = 0.0;
    Camera cam;
    cam.eye = Vec3(0, 2.5, 2.5);
    cam.target = Vec3(0, 0, 0);
    const Image plain = renderer.render(scene, cam);
    // A mark in front of the ball (towards the camera), pure green, full strength.
    GroundMark mark;
    mark.x = 0;
    mark.z = 0.6;
    mark.radius = 0.15;
    mark.colour = Vec3(0.0, 1.0, 0.0);
    scene.groundMarks.push_back(mark);
    const Image marked = renderer.render(scene, cam);
    // The disc's bounding box on screen, from its rim points.
    const Mat4 clip = cam.clipFromView(Real(rs.width) / rs.height, 0.1, 10) * cam.viewFromWorld();
    Real sx0 = 1e9, sx1 = -1e9, sy0 = 1e9, sy1 = -1e9;
    for (int k = 0; k < 64; ++k) {
        const Real a = 2 * 3.14159265358979 * k / 64;
        const Eigen::Vector4d c =
            clip * Eigen::Vector4d(mark.radius * std::cos(a), 0, mark.z + mark.radius * std::sin(a), 1);
        const Real px = (c.x() / c.w() * 0.5 + 0.5) * rs.width, py = (0.5 - c.y() / c.w() * 0.5) * rs.height;
        sx0 = std::min(sx0, px), sx1 = std::max(sx1, px), sy0 = std::min(sy0, py), sy1 = std::max(sy1, py);
    }
    int greener = 0, outside = 0;
    for (int y = 0; y < plain.height; ++y)
        for (int x = 0; x < plain.width; ++x) {
            const std::uint16_t* a = plain.pixel(x, y);
            const std::uint16_t* b = marked.pixel(x, y);
            if (b[1] > a[1] + 2000 && b[0] < a[0]) ++greener;
            const bool changed = a[0] != b[0] || a[1] != b[1] || a[2] != b[2];
            if (changed && (x + 1.5 < sx0 || x - 0.5 > sx1 + 1 || y + 1.5 < sy0 || y - 0.5 > sy1 + 1)) ++outside;
        }
    CHECK(greener > 40);  // the disc, 0.3 m across, seen from 3.5 m: about 18 x 9 pixels
    CHECK(outside == 0);  // nothing changes off the disc
    // In shadow-catcher mode (transparent background) the marks are not drawn.
    RenderSettings catcher = rs;
    catcher.transparentBackground = true;
    Renderer r2(catcher);
    FrameScene noMarks = scene;
    noMarks.groundMarks.clear();
    CHECK(r2.render(scene, cam).rgba == r2.render(noMarks, cam).rgba);
}

TEST_CASE("render.pins draws a pinned body's pinned points and nothing else", "[render][e2e]") {
    test::TempDir dir("render_pins");
    auto scene = [&](const std::string& pins) {
        return R"({"name": "bar", "frames": {"start": 1, "end": 2},
          "objects": [{"primitive": {"type": "box", "size": [0.8, 0.16, 0.16]}, "resolution": 12,
                       "color": [0.3, 0.6, 0.85], "pin": {"min": [-0.5, -1, -1], "max": [-0.3, 1, 1]}}],
          "forces": [{"type": "gravity"}],
          "camera": {"type": "look_at", "eye": [0, 0.4, 2], "target": [0, 0, 0], "fov": 40},
          "render": {"width": 160, "height": 90)" +
               pins + "}}";
    };
    std::ofstream(dir.path() / "on.json") << scene(R"(, "pins": true)");
    std::ofstream(dir.path() / "off.json") << scene("");
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render on.json --out on").exitCode == 0);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q render off.json --out off").exitCode == 0);
    // Magenta dots (sRGB [0.93, 0.25, 0.89]) only on the pinned end, the left fifth of the bar.
    auto magenta = [](const Image& im, int& minX, int& maxX) {
        int n = 0;
        minX = im.width, maxX = -1;
        for (int y = 0; y < im.height; ++y)
            for (int x = 0; x < im.width; ++x) {
                const std::uint16_t* p = im.pixel(x, y);
                if (to8bit(p[0]) > 200 && to8bit(p[1]) < 100 && to8bit(p[2]) > 190) {
                    ++n;
                    minX = std::min(minX, x), maxX = std::max(maxX, x);
                }
            }
        return n;
    };
    int lo = 0, hi = 0;
    CHECK(magenta(readPng(dir.path() / "off" / "bar.0002.png"), lo, hi) == 0);
    CHECK(magenta(readPng(dir.path() / "on" / "bar.0002.png"), lo, hi) > 20);
    CHECK(hi < 160 / 2 - 10);  // the pinned end is the left one
}
