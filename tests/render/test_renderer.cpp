// Renderer behaviour through pixel probes (docs/rendering.md, "Golden images": probes at known
// pixels complement whole-image comparison).

#include "render/renderer.hpp"

#include "base/errors.hpp"
#include "io/png.hpp"
#include "test_meshes.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

using namespace dgv;

namespace {

std::uint16_t encodedBackground(double linear) {
    const double s = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
    return static_cast<std::uint16_t>(std::lround(65535 * s));
}

Camera frontCamera() {
    Camera cam;
    cam.eye = Vec3(0, 0, 5);
    cam.target = Vec3::Zero();
    cam.fovYDegrees = 35;
    return cam;
}

RenderSettings smallSettings() {
    RenderSettings s;
    s.width = 128;
    s.height = 128;
    return s;
}

FrameScene sphereScene(const Vec3& centre, bool ground) {
    FrameScene scene;
    scene.meshes.push_back(test::uvSphere(centre, 1.0));
    scene.meshes.back().colour = Vec3(0.8, 0.3, 0.2);
    scene.groundPlane = ground;
    return scene;
}

struct PixelBox {
    int minX = 1 << 30, minY = 1 << 30, maxX = -1, maxY = -1;
};

/// Bounding box of the pixels with alpha > 0.
PixelBox coverageBox(const Image& img) {
    PixelBox b;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            if (img.pixel(x, y)[3] > 0) {
                b.minX = std::min(b.minX, x);
                b.maxX = std::max(b.maxX, x);
                b.minY = std::min(b.minY, y);
                b.maxY = std::max(b.maxY, y);
            }
    return b;
}

/// Continuous bounding box (pixel units, y down) of the projected sphere, by dense sampling.
void projectedSphereBox(const Camera& cam, const Vec3& centre, Real radius, int w, int h, double box[4]) {
    const Mat4 clipFromWorld = cam.clipFromView(Real(w) / h, 0.1, 100) * cam.viewFromWorld();
    box[0] = box[1] = 1e30;
    box[2] = box[3] = -1e30;
    const Real pi = 3.14159265358979323846;
    for (int i = 0; i <= 400; ++i) {
        for (int j = 0; j < 800; ++j) {
            const Real t = pi * i / 400, p = 2 * pi * j / 800;
            const Vec3 q = centre + radius * Vec3(std::sin(t) * std::cos(p), std::cos(t), std::sin(t) * std::sin(p));
            const Vec4 c = clipFromWorld * q.homogeneous();
            const double px = (c.x() / c.w() + 1) / 2 * w, py = (1 - c.y() / c.w()) / 2 * h;
            box[0] = std::min(box[0], px);
            box[1] = std::min(box[1], py);
            box[2] = std::max(box[2], px);
            box[3] = std::max(box[3], py);
        }
    }
}

}  // namespace

TEST_CASE("renderer: a lit sphere in the centre, the background exactly in the corners", "[render]") {
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    Renderer renderer(settings);
    CHECK(renderer.glRenderer().find("llvmpipe") != std::string::npos);
    for (bool ground : {false, true}) {
        const Image img = renderer.render(sphereScene(Vec3::Zero(), ground), frontCamera());
        REQUIRE(img.width == 128);
        REQUIRE(img.height == 128);
        const std::uint16_t bg[3] = {encodedBackground(settings.background[0]),
                                     encodedBackground(settings.background[1]),
                                     encodedBackground(settings.background[2])};
        // With the ground on, its soft floor reaches the lower corners; the upper ones see the sky.
        const std::vector<std::pair<int, int>> corners =
            ground ? std::vector<std::pair<int, int>>{{0, 0}, {127, 0}}
                   : std::vector<std::pair<int, int>>{{0, 0}, {127, 0}, {0, 127}, {127, 127}};
        for (auto [x, y] : corners) {
            const std::uint16_t* p = img.pixel(x, y);
            INFO("ground " << ground << " corner " << x << "," << y);
            CHECK(p[0] == bg[0]);
            CHECK(p[1] == bg[1]);
            CHECK(p[2] == bg[2]);
            CHECK(p[3] == 65535);
        }
        // The centre shows the object's reddish albedo, lit: red dominates, well above the background.
        const std::uint16_t* c = img.pixel(64, 64);
        CHECK(c[0] > c[1] + 10000);
        CHECK(c[0] > c[2] + 10000);
        CHECK(c[0] > bg[0] + 15000);
        CHECK(c[3] == 65535);
    }
}

TEST_CASE("renderer: transparent background gives alpha 0 outside and 1 on the object", "[render]") {
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    settings.transparentBackground = true;
    Renderer renderer(settings);
    const Image img = renderer.render(sphereScene(Vec3::Zero(), false), frontCamera());
    for (auto [x, y] : {std::pair{0, 0}, {127, 0}, {0, 127}, {127, 127}}) {
        const std::uint16_t* p = img.pixel(x, y);
        CHECK(p[0] == 0);
        CHECK(p[1] == 0);
        CHECK(p[2] == 0);
        CHECK(p[3] == 0);
    }
    CHECK(img.pixel(64, 64)[3] == 65535);
    // Straight alpha: an edge pixel with partial coverage keeps the object's colour, not a darkened one.
    const PixelBox box = coverageBox(img);
    const std::uint16_t* edge = img.pixel(box.minX, 64);
    CHECK(edge[3] > 0);
    CHECK(edge[3] < 65535);
    CHECK(edge[0] > edge[1]);
}

TEST_CASE("renderer: the object appears where the camera projects it", "[render]") {
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    settings.width = 160;  // a non-square aspect checks the projection too
    settings.transparentBackground = true;
    Renderer renderer(settings);
    for (const Vec3& centre : {Vec3(0, 0, 0), Vec3(0.9, -0.4, 0.5)}) {
        Camera cam = frontCamera();
        cam.eye = Vec3(1.5, 1.0, 6);
        const Image img = renderer.render(sphereScene(centre, false), cam);
        double expected[4];
        projectedSphereBox(cam, centre, 1.0, settings.width, settings.height, expected);
        const PixelBox got = coverageBox(img);
        INFO("expected x " << expected[0] << ".." << expected[2] << " y " << expected[1] << ".." << expected[3]);
        INFO("got x " << got.minX << ".." << got.maxX << " y " << got.minY << ".." << got.maxY);
        // A covered pixel index i spans [i, i+1): the extreme covered indices are within a pixel
        // of the continuous silhouette bounds.
        CHECK(std::abs(got.minX - expected[0]) <= 1.0);
        CHECK(std::abs(got.maxX + 1 - expected[2]) <= 1.0);
        CHECK(std::abs(got.minY - expected[1]) <= 1.0);
        CHECK(std::abs(got.maxY + 1 - expected[3]) <= 1.0);
    }
}

TEST_CASE("renderer: the same input gives identical pixels, a moved object changes them", "[render][determinism]") {
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    Renderer renderer(settings);
    const FrameScene scene = sphereScene(Vec3::Zero(), true);
    const Image a = renderer.render(scene, frontCamera());
    const Image b = renderer.render(scene, frontCamera());
    CHECK(a.rgba == b.rgba);

    const Image moved = renderer.render(sphereScene(Vec3(0.3, 0, 0), true), frontCamera());
    long changed = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) changed += a.rgba[i] != moved.rgba[i];
    CHECK(changed > 500);

    // Buffers reused across frames hold no stale state: back to the first scene, same pixels,
    // and a second renderer (a fresh context) agrees too.
    const Image again = renderer.render(scene, frontCamera());
    CHECK(again.rgba == a.rgba);
    Renderer other(settings);
    CHECK(other.render(scene, frontCamera()).rgba == a.rgba);
}

TEST_CASE("renderer: a mesh without a highlight scalar looks as one whose scalar is all zero", "[render]") {
    // Meshes without a scalar are drawn by the shader variant without the vScalar varying
    // (DGV_SCALAR 0); it must give the same pixels as the full shader where the ramp is off.
    // The second sphere has a ramp on one vertex, so both programs are used in one frame.
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    Renderer renderer(settings);
    FrameScene plain = sphereScene(Vec3(-1.2, 0, 0), true);
    plain.meshes.push_back(test::uvSphere(Vec3(1.2, 0, 0), 1.0));
    plain.meshes.back().colour = Vec3(0.3, 0.5, 0.8);
    plain.meshes.back().scalar.assign(plain.meshes.back().positions.size(), 0.0);
    plain.meshes.back().scalar[0] = 1.0;  // the pole: a ramped spot
    FrameScene zero = plain;
    zero.meshes[0].scalar.assign(zero.meshes[0].positions.size(), 0.0);
    Camera cam = frontCamera();
    cam.eye = Vec3(0, 0, 8);
    const Image a = renderer.render(plain, cam);
    const Image b = renderer.render(zero, cam);
    CHECK(a.rgba == b.rgba);
    FrameScene ramped = zero;
    ramped.meshes[0].scalar.assign(ramped.meshes[0].positions.size(), 1.0);
    long changed = 0;
    const Image c = renderer.render(ramped, cam);
    for (std::size_t i = 0; i < a.rgba.size(); ++i) changed += a.rgba[i] != c.rgba[i];
    CHECK(changed > 500);  // the scalar does reach the full shader
}

TEST_CASE("renderer: a given ground height stays put while the object falls", "[render]") {
    // FrameScene::groundHeight (a ground collider's height): the floor is drawn there, not under
    // the lowest point, so a falling ball approaches a fixed floor. A probe on the floor, away
    // from the ball and its shadow, keeps its value; without the height the floor follows the
    // ball and the probe changes.
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    Renderer renderer(settings);
    Camera cam;
    cam.eye = Vec3(0, 2.5, 9);
    cam.target = Vec3(0, 1.5, 0);
    cam.fovYDegrees = 35;
    auto render = [&](Real height, bool fixedGround) {
        FrameScene scene = sphereScene(Vec3(0, height, 0), true);
        if (fixedGround) scene.groundHeight = 0.0;
        return renderer.render(scene, cam);
    };
    auto probe = [](const Image& img) {  // low on the left: floor, clear of the ball's shadow
        const std::uint16_t* p = img.pixel(10, 118);
        return std::array<std::uint16_t, 4>{p[0], p[1], p[2], p[3]};
    };
    const Image high = render(3.0, true), low = render(1.5, true);
    CHECK(probe(high) == probe(low));
    const std::uint16_t bg = encodedBackground(settings.background[0]);
    CHECK(probe(high)[0] != bg);  // the probe is on the floor
    // The ground is below the lowest point either way, so it is composited at output size.
    const Image followHigh = render(3.0, false), followLow = render(1.5, false);
    CHECK(probe(followHigh) != probe(followLow));
    // A ground height above the ball's lowest point: the floor is drawn depth-tested and hides
    // the part below it (the bottom rows of the ball's silhouette become floor).
    FrameScene sunk = sphereScene(Vec3(0, 1.5, 0), true);
    sunk.groundHeight = 1.0;
    const Image s = renderer.render(sunk, cam);
    long changed = 0;
    for (std::size_t i = 0; i < s.rgba.size(); ++i) changed += s.rgba[i] != low.rgba[i];
    CHECK(changed > 200);
}

TEST_CASE("renderer: a low camera sees the floor up to the bottom edge of the frame", "[render]") {
    // The automatic near plane also covers the ground's nearest visible point (where the view's
    // corner rays meet it); before, a camera 0.3 above the floor clipped the floor in front of it
    // and the bottom rows showed the background.
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    Renderer renderer(settings);
    Camera cam;
    cam.eye = Vec3(0, -0.7, 4);  // the sphere's lowest point, hence the floor, is at y = -1
    cam.target = Vec3(0, -0.7, 0);
    cam.fovYDegrees = 35;
    const Image img = renderer.render(sphereScene(Vec3::Zero(), true), cam);
    const std::uint16_t bg = encodedBackground(settings.background[0]);
    for (int x : {0, 64, 127}) {
        INFO("x " << x);
        CHECK(img.pixel(x, 127)[0] != bg);  // floor, not background
        CHECK(img.pixel(x, 127)[0] > bg);   // the floor is lighter than the background
    }
}

TEST_CASE("renderer: the ground shows the key light's shadow", "[render]") {
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    settings.width = 192;
    Renderer renderer(settings);
    FrameScene scene = sphereScene(Vec3::Zero(), true);
    const Camera cam = turntableCamera(Box3{Vec3(-2, -1, -2), Vec3(2, 1, 2)}, 0, 25, 35, 1.5);
    const Image with = renderer.render(scene, cam);
    // The same view of an empty floor: take the floor as the scene's only "mesh", a tiny speck
    // far away would change the framing, so compare against the ground lit without shadow by
    // moving the sphere up (shadow moves away from the contact region below it).
    FrameScene lifted = sphereScene(Vec3(0, 0, 0), true);
    lifted.meshes.push_back(test::uvSphere(Vec3(0, -1.0, 0), 0.01, 4, 8));  // keeps the ground at y=-1
    for (Vec3& p : lifted.meshes[0].positions) p.y() += 2.5;
    const Image without = renderer.render(lifted, cam);
    // Just below and behind the sphere's contact point the floor is darker with the sphere there.
    const Mat4 clipFromWorld = cam.clipFromView(1.5, 0.1, 100) * cam.viewFromWorld();
    double darker = 0;
    int probes = 0;
    for (const Vec3& g : {Vec3(0.2, -1, -0.9), Vec3(0.4, -1, -1.2), Vec3(0.3, -1, -1.05)}) {
        const Vec4 c = clipFromWorld * g.homogeneous();
        const int px = static_cast<int>((c.x() / c.w() + 1) / 2 * settings.width);
        const int py = static_cast<int>((1 - c.y() / c.w()) / 2 * settings.height);
        if (px < 0 || py < 0 || px >= settings.width || py >= settings.height) continue;
        darker += double(without.pixel(px, py)[1]) - double(with.pixel(px, py)[1]);
        ++probes;
    }
    REQUIRE(probes > 0);
    CHECK(darker / probes > 3000);
}

TEST_CASE("renderer: soft shadows widen with the distance from their blocker, hard shadows do not", "[render]") {
    // RenderSettings::shadowSoftness: the key light is a disc of angular radius theta, so a
    // blocker at distance d along the light casts a penumbra 2 d tan(theta) wide (perpendicular
    // to the light), from fully lit to umbra. A ball of radius R held D above a slab, the
    // camera straight above the ball's shadow (the ball no more than in a corner): the band of the
    // slab where the visibility is between 0.1 and 0.9 is a ring around the shadow's ellipse.
    // Across a straight edge a uniform disc's covered share passes 0.1 and 0.9 at +-0.687 of
    // its radius, so the band is 2 * 0.687 * d tan(theta) wide, d = D / cos(i) (i the light's
    // angle from the vertical), and stretched by 1 / cos(i) along the light's ground direction
    // with the ellipse: its area is 4 pi R * 0.687 d tan(theta) / cos(i). With softness 0 the
    // penumbra is the hard kernel's few texels at any height.
    test::FpTrapsOff guard;
    const Real R = 0.5;
    auto scene = [&](Real D) {
        FrameScene s;
        s.meshes.push_back(test::box(Vec3(0, -0.1, 0), Vec3(10.0, 0.2, 10.0), 4));
        s.meshes.back().colour = Vec3(0.7, 0.7, 0.7);
        s.meshes.push_back(test::uvSphere(Vec3(0, D, 0), R, 48, 96));
        s.meshes.back().colour = Vec3(0.7, 0.3, 0.2);
        s.meshes.push_back(test::uvSphere(Vec3(4.9, 5.0, 4.9), 0.01, 4, 8));  // fixes the bounds
        s.groundPlane = false;
        return s;
    };
    // The rig's key light for a camera looking straight down (renderer.cpp: backH = +Z,
    // rightH = +X): towards (-0.55, 1, 0.65).
    const Vec3 key = Vec3(-0.55, 1.0, 0.65).normalized();
    const Real cosI = key.y();
    const int size = 256;
    const Real height = 20, halfView = 1.15;  // the view spans 2.3 m of the slab
    const Real pixel = 2 * halfView / size;
    struct Band {
        double pixels = 0, lit = 0, umbra = 0;
    };
    auto band = [&](Real softness, Real D) {
        RenderSettings s;
        s.width = s.height = size;
        s.shadowSoftness = softness;
        Renderer renderer(s);
        const Vec3 shadowCentre = Vec3(0, D, 0) - key * (D / key.y());
        Camera cam;
        cam.eye = shadowCentre + Vec3(0, height, 0);
        cam.target = shadowCentre;
        cam.up = -Vec3::UnitZ();
        cam.fovYDegrees = 2 * std::atan(halfView / height) * 180 / 3.14159265358979323846;
        const Image img = renderer.render(scene(D), cam);
        auto linear = [&](int x, int y) { return decodeSrgb(img.pixel(x, y)[1] / 65535.0); };
        Band b;
        b.umbra = linear(size / 2, size / 2);
        b.lit = linear(2, 2);  // a corner far from the shadow
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const std::uint16_t* c = img.pixel(x, y);
                if (std::abs(int(c[0]) - int(c[1])) > 2000) continue;  // the ball in a corner, not the slab
                const double v = (linear(x, y) - b.umbra) / (b.lit - b.umbra);
                b.pixels += v > 0.1 && v < 0.9;
            }
        return b;
    };
    const Real theta = 3 * 3.14159265358979323846 / 180;
    for (Real D : {2.0, 4.0}) {
        const Band soft = band(3, D);
        const Real d = D / cosI;
        const double expected = 4 * 3.14159265358979323846 * R * 0.687 * d * std::tan(theta) / cosI / (pixel * pixel);
        INFO("D " << D << ": lit " << soft.lit << ", umbra " << soft.umbra << ", band " << soft.pixels
                  << " pixels, expected " << expected);
        CHECK(soft.umbra < 0.5 * soft.lit);    // the shadow's centre is umbra
        CHECK(soft.pixels > 0.85 * expected);  // measured 1.02 (D 2) and 0.91 (D 4) of it
        CHECK(soft.pixels < 1.15 * expected);
    }
    const Band hard2 = band(0, 2), hard4 = band(0, 4);
    INFO("hard: " << hard2.pixels << " and " << hard4.pixels << " pixels");
    CHECK(std::abs(hard4.pixels - hard2.pixels) < 0.15 * hard2.pixels);
    CHECK(hard2.pixels < 0.3 * band(3, 2).pixels);  // measured 0.11
}

TEST_CASE("renderer: a see-through mesh blends over what lies behind it by its opacity", "[render]") {
    // DrawMesh::opacity: a box in front of a ball, drawn at opacity 1 (it hides the ball), 0
    // (the ball as if the box were glass of no colour; the box still shades it) and 0.4. In
    // linear light the premultiplied "over" gives exactly 0.4 of the first plus 0.6 of the
    // second, over the ball and over the background alike, to the half-float target's precision.
    test::FpTrapsOff guard;
    RenderSettings settings = smallSettings();
    Renderer renderer(settings);
    Camera cam;
    cam.eye = Vec3(0, 0.3, 5);
    cam.target = Vec3::Zero();
    auto render = [&](Real opacity) {
        FrameScene scene;
        scene.groundPlane = false;
        scene.meshes.push_back(test::uvSphere(Vec3(0, 0, -1.0), 0.8, 32, 64));
        scene.meshes.back().colour = Vec3(0.8, 0.2, 0.1);
        scene.meshes.push_back(test::box(Vec3(0.3, 0, 1.0), Vec3(1.2, 1.2, 0.4), 3));
        scene.meshes.back().colour = Vec3(0.5, 0.55, 0.6);
        scene.meshes.back().opacity = opacity;
        return renderer.render(scene, cam);
    };
    const Image solid = render(1), clear = render(0), part = render(0.4);
    auto lin = [](const Image& img, int x, int y, int c) { return decodeSrgb(img.pixel(x, y)[c] / 65535.0); };
    double worst = 0;
    int overBall = 0, overBackground = 0, changed = 0;
    for (int y = 0; y < settings.height; ++y)
        for (int x = 0; x < settings.width; ++x) {
            bool differs = false;
            for (int c = 0; c < 3; ++c) {
                const double expected = 0.4 * lin(solid, x, y, c) + 0.6 * lin(clear, x, y, c);
                // Not where the output clips (the ball's highlight): clipping is not linear.
                if (std::max({lin(solid, x, y, c), lin(clear, x, y, c), lin(part, x, y, c)}) < 0.999)
                    worst = std::max(worst, std::abs(lin(part, x, y, c) - expected));
                differs = differs || solid.pixel(x, y)[c] != clear.pixel(x, y)[c];
            }
            if (!differs) continue;
            ++changed;
            // Where the box covers the ball the opaque render shows grey and the clear one red.
            const bool ballBehind = clear.pixel(x, y)[0] > clear.pixel(x, y)[2] + 8000;
            (ballBehind ? overBall : overBackground) += 1;
        }
    INFO("worst " << worst << ", box pixels over the ball " << overBall << ", over the background " << overBackground);
    CHECK(changed > 1000);  // the box covers a good part of the view
    CHECK(overBall > 200);
    CHECK(overBackground > 200);
    CHECK(worst < 2e-3);
}

TEST_CASE("renderer: invalid settings and missing shaders are reported", "[render]") {
    test::FpTrapsOff guard;
    RenderSettings bad;
    bad.width = 0;
    bad.supersample = 7;
    const auto problems = bad.validate();
    REQUIRE(problems.size() == 2);
    CHECK(problems[0].rfind("width", 0) == 0);
    CHECK(problems[1].rfind("supersample", 0) == 0);
    CHECK_THROWS_AS(Renderer(bad), InputError);

    test::TempDir dir("render-no-shaders");
    RenderSettings s = smallSettings();
    s.shaderDir = dir.path().string();
    try {
        Renderer r(s);
        FAIL("expected a RuntimeError");
    } catch (const RuntimeError& e) {
        CHECK(std::string(e.what()).find("mesh.vert") != std::string::npos);
    }

    // A shader that does not compile: the error names the file and quotes the compiler log.
    for (const auto& entry : std::filesystem::directory_iterator(findShaderDir()))
        std::filesystem::copy_file(entry.path(), dir.path() / entry.path().filename());
    { std::ofstream(dir.path() / "resolve.frag") << "#version 330 core\nvoid main() { undefinedThing = 1; }\n"; }
    try {
        Renderer r(s);
        FAIL("expected a RuntimeError");
    } catch (const RuntimeError& e) {
        const std::string what = e.what();
        CHECK(what.find("resolve.frag") != std::string::npos);
        CHECK(what.find("undefinedThing") != std::string::npos);
    }
}

// Not run by default: writes frames to look at ($DGV_LOOK_DIR or /tmp).
TEST_CASE("renderer: look frames", "[.look]") {
    test::FpTrapsOff guard;
    const char* env = std::getenv("DGV_LOOK_DIR");
    const std::filesystem::path dir = env ? env : "/tmp";
    RenderSettings settings;
    settings.width = 640;
    settings.height = 360;
    Renderer renderer(settings);
    FrameScene scene;
    scene.meshes.push_back(test::uvSphere(Vec3(-1.3, 0, 0), 1.0, 64, 128));
    scene.meshes.back().colour = Vec3(0.7, 0.25, 0.15);
    scene.meshes.push_back(test::torus(Vec3(1.4, -0.6, 0.2), 0.9, 0.4, 128, 64));
    scene.meshes.back().colour = Vec3(0.55, 0.55, 0.6);
    Box3 bounds;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.positions) bounds.extend(p);
    for (int angle : {0, 60, 150}) {
        const Camera cam = turntableCamera(bounds, angle, 20, 35, 640.0 / 360.0);
        writePng(dir / ("dgv_look_" + std::to_string(angle) + ".png"), renderer.render(scene, cam));
    }
    settings.transparentBackground = true;
    Renderer transparent(settings);
    writePng(dir / "dgv_look_transparent.png",
             transparent.render(scene, turntableCamera(bounds, 30, 20, 35, 640.0 / 360.0)));
}
