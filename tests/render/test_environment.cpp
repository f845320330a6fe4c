// The environment's ambient light (render/environment.hpp; render.environment): its nine
// coefficients against closed forms (a uniform colour, a sky over a ground, an equirectangular
// image of either, a bright patch turned with the image), and rendered: the studio hemisphere
// written as an environment draws what it draws, and a uniform one lights a ball evenly.

#include "render/environment.hpp"
#include "render/renderer.hpp"

#include "test_meshes.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace dgv;

namespace {

const std::vector<Vec3> kNormals = {Vec3(0, 1, 0),  Vec3(0, -1, 0), Vec3(1, 0, 0),    Vec3(0, 0, -1),
                                    Vec3(1, 1, 1).normalized(), Vec3(-0.3, -0.8, 0.52).normalized()};

/// A width x height equirectangular image: `up` on the rows above the horizon, `down` below.
std::vector<Vec3> horizonImage(int width, int height, const Vec3& up, const Vec3& down) {
    std::vector<Vec3> img(static_cast<std::size_t>(width) * height);
    for (int r = 0; r < height; ++r)
        for (int c = 0; c < width; ++c) img[static_cast<std::size_t>(r) * width + c] = r < height / 2 ? up : down;
    return img;
}

}  // namespace

TEST_CASE("environment: the coefficients against closed forms", "[render][environment]") {
    const Vec3 c(0.3, 0.5, 0.9), sky(0.8, 0.9, 1.0), ground(0.2, 0.15, 0.1);
    for (const Vec3& n : kNormals) {
        INFO("n = " << n.transpose());
        CHECK(ambientAt(uniformEnvironment(c), n).isApprox(c, 1e-12));
        // a sky over a ground: (sky + ground)/2 + (sky − ground)/2 n_y, exactly
        const Vec3 expect = 0.5 * (sky + ground) + 0.5 * (sky - ground) * n.y();
        CHECK(ambientAt(skyEnvironment(sky, ground), n).isApprox(expect, 1e-5));
        // the same from images, within their pixels' quadrature
        CHECK((ambientAt(equirectEnvironment(horizonImage(256, 128, c, c), 256, 128), n) - c).norm() < 1e-4);
        CHECK((ambientAt(equirectEnvironment(horizonImage(256, 128, sky, ground), 256, 128), n) - expect).norm() < 2e-3);
    }
    // A bright patch at the image's centre column lights what faces −z; turned 180 degrees, +z.
    std::vector<Vec3> patch(64 * 32, Vec3::Zero());
    for (int r = 12; r < 20; ++r)
        for (int col = 28; col < 36; ++col) patch[static_cast<std::size_t>(r) * 64 + col] = Vec3::Ones();
    const Environment front = equirectEnvironment(patch, 64, 32), back = equirectEnvironment(patch, 64, 32, 180);
    CHECK(ambientAt(front, Vec3(0, 0, -1)).x() > 5 * ambientAt(front, Vec3(0, 0, 1)).x());
    CHECK(ambientAt(back, Vec3(0, 0, 1)).x() == Approx(ambientAt(front, Vec3(0, 0, -1)).x()).epsilon(1e-9));
}

TEST_CASE("environment: the studio hemisphere as an environment draws the studio's frame, a uniform one an even ball",
          "[render][environment]") {
    test::FpTrapsOff guard;
    Camera cam;
    cam.eye = Vec3(0, 1.5, 6);
    cam.target = Vec3(0, 0.5, 0);
    FrameScene scene;
    scene.meshes.push_back(test::uvSphere(Vec3(0, 0.5, 0), 1.0));
    scene.meshes[0].colour = Vec3(0.8, 0.3, 0.2);
    RenderSettings s;
    s.width = 128;
    s.height = 96;
    const Image studio = Renderer(s).render(scene, cam);
    // the renderer's sky and bounce (renderer.cpp, setLighting)
    s.environment = skyEnvironment(Vec3(0.80, 0.87, 1.00) * 0.20, Vec3(1.00, 0.95, 0.90) * 0.06);
    const Image sky = Renderer(s).render(scene, cam);
    int worst = 0;
    for (std::size_t i = 0; i < studio.rgba.size(); ++i)
        worst = std::max(worst, std::abs(static_cast<int>(to8bit(studio.rgba[i])) - to8bit(sky.rgba[i])));
    CHECK(worst <= 1);

    // No light but a uniform environment: every pixel of the ball is albedo × c.
    Light dark;
    dark.colour = Vec3::Zero();
    dark.shininess = 0;
    s.lights = {dark};
    s.environment = uniformEnvironment(Vec3(0.5, 0.5, 0.5));
    scene.groundPlane = false;
    const Image even = Renderer(s).render(scene, cam);
    const std::uint16_t* centre = even.pixel(64, 40);
    for (int c = 0; c < 3; ++c) {
        const double expect = encodeSrgb(0.5 * scene.meshes[0].colour[c]);
        CHECK(to8bit(centre[c]) == Approx(255 * expect).margin(1));
    }
    int spread = 0;
    for (int y = 30; y < 50; ++y)
        for (int x = 54; x < 74; ++x) spread = std::max(spread, std::abs(to8bit(even.pixel(x, y)[0]) - to8bit(centre[0])));
    CHECK(spread <= 1);
}
