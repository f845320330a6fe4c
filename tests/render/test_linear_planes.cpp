// The frame for compositing (Renderer::render's LinearImage, RenderSettings::linearPlanes): its
// colour against the PNG image, its depth against closed forms (a sphere's nearest point, the
// ground plane's ray), its contact matte against the highlighted mesh, and the colour image left
// as it was when the planes are kept.

#include "render/renderer.hpp"

#include "test_meshes.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <optional>

using namespace dgv;

namespace {

Camera frontCamera() {
    Camera cam;
    cam.eye = Vec3(0, 0.6, 5);
    cam.target = Vec3(0, 0, 0);
    cam.fovYDegrees = 35;
    return cam;
}

RenderSettings planeSettings(bool planes) {
    RenderSettings s;
    s.width = 160;
    s.height = 120;
    s.linearPlanes = planes;
    return s;
}

/// A highlighted ball (its scalar > 0 everywhere) on the left, a plain one on the right, a ground
/// at y = -1.2, and optionally a see-through box in front and a line overlay (the passes that
/// switch the contact target off and on).
FrameScene twoBalls(bool extras) {
    FrameScene scene;
    scene.meshes.push_back(test::uvSphere(Vec3(-1.2, 0, 0), 0.8));
    scene.meshes.back().colour = Vec3(0.3, 0.6, 0.8);
    scene.meshes.back().scalar.assign(scene.meshes.back().positions.size(), 0.5);
    scene.meshes.push_back(test::uvSphere(Vec3(1.2, 0, 0), 0.8));
    scene.meshes.back().colour = Vec3(0.8, 0.3, 0.2);
    scene.groundHeight = -1.2;
    if (extras) {
        scene.meshes.push_back(test::box(Vec3(0, -0.5, 1.5), Vec3(0.8, 0.8, 0.3), 3));
        scene.meshes.back().opacity = 0.5;
        Polyline line;
        line.points = {Vec3(-2, 1, 0), Vec3(2, 1, 0)};
        line.closed = false;
        scene.lines.push_back(line);
    }
    return scene;
}

/// The view ray through the point (x, y) of the image (pixels, top row 0, pixel centres at
/// + 0.5) as a world direction of view depth 1.
Vec3 pixelRay(const Camera& cam, Real x, Real y, int w, int h) {
    const Real ty = std::tan(0.5 * cam.fovYDegrees * 3.14159265358979323846 / 180), tx = ty * w / h;
    const Vec3 viewDir((2 * x / w - 1) * tx, (1 - 2 * y / h) * ty, -1);
    return cam.viewFromWorld().inverse().block<3, 3>(0, 0) * viewDir;
}

/// The view depth at which the ray eye + s d first meets the sphere (c, r), if it does.
std::optional<Real> sphereHit(const Vec3& eye, const Vec3& d, const Vec3& c, Real r) {
    const Vec3 m = eye - c;
    const Real a = d.squaredNorm(), b = m.dot(d), q = m.squaredNorm() - r * r, disc = b * b - a * q;
    if (disc < 0) return std::nullopt;
    return (-b - std::sqrt(disc)) / a;
}

}  // namespace

TEST_CASE("renderer: the linear planes hold the PNG's colour, each pixel's depth and the contact matte",
          "[render][exr]") {
    test::FpTrapsOff guard;
    const RenderSettings settings = planeSettings(true);
    Renderer renderer(settings);
    const Camera cam = frontCamera();
    LinearImage linear;
    const Image image = renderer.render(twoBalls(false), cam, &linear);
    const int w = settings.width, h = settings.height;
    REQUIRE(linear.width == w);
    REQUIRE(linear.height == h);

    // Colour: the PNG is the same resolve's halves through the exact sRGB table, so the planes
    // encode to it within one 16-bit code.
    const Image encoded = encodedImageOf(linear);
    int worstCode = 0;
    for (std::size_t i = 0; i < image.rgba.size(); ++i)
        worstCode = std::max(worstCode, std::abs(int(image.rgba[i]) - int(encoded.rgba[i])));
    CHECK(worstCode <= 1);

    // Depth: the nearest of the pixel's 2x2 samples. A tessellated sphere (32 rings, 64 segments)
    // lies within r (1 − cos(π/32)) (0.4 % of r) of the true one along either direction; the
    // ground, drawn at output size, is the exact plane along the pixel's central ray.
    const Vec3 left(-1.2, 0, 0), right(1.2, 0, 0);
    const Real r = 0.8, near = 0.03;  // a sample within `near` of a ball's outline is left out
    int ballPixels = 0, groundPixels = 0, skyPixels = 0;
    double worstBall = 0, worstGround = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t o = static_cast<std::size_t>(y) * w + x;
            int onLeft = 0, onRight = 0, nearBall = 0;
            Real nearest = 1e30;
            for (int k = 0; k < 4; ++k) {
                const Vec3 d = pixelRay(cam, x + 0.25 + 0.5 * (k & 1), y + 0.25 + 0.5 * (k >> 1), w, h);
                const std::optional<Real> hl = sphereHit(cam.eye, d, left, r), hr = sphereHit(cam.eye, d, right, r);
                onLeft += sphereHit(cam.eye, d, left, r - near) ? 1 : 0;
                onRight += sphereHit(cam.eye, d, right, r - near) ? 1 : 0;
                nearBall += sphereHit(cam.eye, d, left, r + near) || sphereHit(cam.eye, d, right, r + near) ? 1 : 0;
                if (hl) nearest = std::min(nearest, *hl);
                if (hr) nearest = std::min(nearest, *hr);
            }
            if (onLeft == 4 || onRight == 4) {
                worstBall = std::max(worstBall, std::abs(linear.depth[o] - nearest));
                ++ballPixels;
                CHECK(linear.contact[o] == (onLeft == 4 ? 1.0f : 0.0f));
                continue;
            }
            if (nearBall > 0) continue;  // the outlines: a mix of samples
            CHECK(linear.contact[o] == 0.0f);
            const Vec3 d = pixelRay(cam, x + 0.5, y + 0.5, w, h);
            const Real t = d.y() < 0 ? (-1.2 - cam.eye.y()) / d.y() : -1;
            const Vec3 hit = cam.eye + t * d;
            // The floor fades out radially from 1.2 to 4 bounding radii of the balls' centre (2.8
            // to 9.2 m here): where it is surely drawn its depth is the ray's; the sky has none.
            if (t > 0 && Vec3(hit.x(), 0, hit.z()).norm() < 8) {
                worstGround = std::max(worstGround, std::abs(linear.depth[o] - t) / t);
                ++groundPixels;
            } else if (d.y() > 0) {
                CHECK(linear.depth[o] == LinearImage::kNoDepth);
                ++skyPixels;
            }
        }
    INFO("ball pixels " << ballPixels << ", ground " << groundPixels << ", sky " << skyPixels);
    CHECK(ballPixels > 2000);
    CHECK(groundPixels > 1000);
    CHECK(skyPixels > 1000);
    CHECK(worstBall < 2 * 0.0048 * r + 1e-3);  // the tessellation both ways, and the 24-bit depth
    CHECK(worstGround < 1e-4);

    // The outline of the highlighted ball: a matte between 0 and 1.
    int partial = 0;
    for (float c : linear.contact) partial += c > 0.05f && c < 0.95f ? 1 : 0;
    CHECK(partial > 20);
}

TEST_CASE("renderer: keeping the linear planes leaves the colour image as it was", "[render][exr]") {
    // The contact target is written beside the colour only in the planes' shader variant, and
    // the see-through box and the overlay switch it off and on: the colour must not see either.
    test::FpTrapsOff guard;
    const Camera cam = frontCamera();
    for (bool transparent : {false, true}) {
        INFO("transparent " << transparent);
        RenderSettings plain = planeSettings(false), planes = planeSettings(true);
        plain.transparentBackground = planes.transparentBackground = transparent;
        Renderer a(plain), b(planes);
        LinearImage linear;
        const Image before = a.render(twoBalls(true), cam);
        const Image after = b.render(twoBalls(true), cam, &linear);
        CHECK(before.rgba == after.rgba);
        // Premultiplied: alpha as the PNG's, colour back to it within one code where it is seen.
        const Image encoded = encodedImageOf(linear);
        int worst = 0;
        for (std::size_t p = 0; p < before.rgba.size(); p += 4) {
            worst = std::max(worst, std::abs(int(before.rgba[p + 3]) - int(encoded.rgba[p + 3])));
            if (before.rgba[p + 3] > 65535 / 20)
                for (std::size_t c = 0; c < 3; ++c)
                    worst = std::max(worst, std::abs(int(before.rgba[p + c]) - int(encoded.rgba[p + c])));
        }
        CHECK(worst <= 1);
    }
    // Without the setting, asking for the planes is a caller's bug.
    Renderer plain(planeSettings(false));
    LinearImage linear;
    CHECK_THROWS_AS(plain.render(twoBalls(false), cam, &linear), std::logic_error);
}

TEST_CASE("renderer: the contact matte holds the ground marks, on a ground drawn at output size and in the scene pass",
          "[render][exr]") {
    // A ball above the ground and a mark (strength 0.8) on the ground in front of it; a second
    // scene puts the ball's bottom below the ground height, so the ground is drawn in the scene
    // pass. In both the matte at the mark's centre is its coverage, 0.8 less the marks' raster
    // (texels of a quarter radius: the nearest texel centres lie 0.18 radius out, where the
    // smoothstep has taken 8 % off), and 0 on bare floor; the two paths agree.
    test::FpTrapsOff guard;
    std::vector<float> atCentre;
    for (const Real ballY : {0.0, -1.0}) {
        INFO("ball at y " << ballY << (ballY < -0.5 ? " (ground in the scene pass)" : " (ground at output size)"));
        FrameScene scene;
        scene.meshes.push_back(test::uvSphere(Vec3(0, ballY, -1), 0.6));
        scene.groundHeight = -1.2;
        GroundMark mark;
        mark.x = 0;
        mark.z = 0;  // within the floor's unfaded disc (1.2 bounding radii around the ball)
        mark.radius = 0.3;
        mark.strength = 0.8;
        scene.groundMarks.push_back(mark);
        Camera cam = frontCamera();
        cam.eye = Vec3(0, 1.5, 5);
        cam.target = Vec3(0, -1, 0);
        Renderer renderer(planeSettings(true));
        LinearImage planes;
        renderer.render(scene, cam, &planes);
        // the pixel that sees the mark's centre, and one that sees bare floor 1.5 m to its side
        auto pixelOf = [&](const Vec3& p) {
            const Vec4 c = cam.clipFromView(160.0 / 120.0, 0.1, 100) * cam.viewFromWorld() * Vec4(p.x(), p.y(), p.z(), 1);
            const int x = static_cast<int>((c.x() / c.w() + 1) / 2 * 160), y = static_cast<int>((1 - c.y() / c.w()) / 2 * 120);
            REQUIRE((x >= 0 && x < 160 && y >= 0 && y < 120));
            return static_cast<std::size_t>(y) * 160 + x;
        };
        atCentre.push_back(planes.contact[pixelOf(Vec3(0, -1.2, 0))]);
        CHECK(atCentre.back() == Approx(0.8 * (1 - 0.18 * 0.18 * (3 - 2 * 0.18))).margin(0.03));
        CHECK(planes.contact[pixelOf(Vec3(1.5, -1.2, 0))] == 0);
    }
    CHECK(atCentre[0] == Approx(atCentre[1]).margin(0.03));
}
