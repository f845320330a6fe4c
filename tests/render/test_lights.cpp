// The light rig (RenderSettings::lights, render.lights; docs/rendering.md, "Lights"): world lights
// against camera-attached ones under an orbiting camera, a point light's inverse-square falloff
// against its closed form (read from the linear planes), the studio rig written out as lights
// against the built-in one, and what the settings refuse.

#include "render/renderer.hpp"

#include "test_meshes.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace dgv;

namespace {

RenderSettings lightSettings(std::vector<Light> lights) {
    RenderSettings s;
    s.width = 96;
    s.height = 96;
    s.linearPlanes = true;
    s.lights = std::move(lights);
    return s;
}

Light directional(const Vec3& towards, bool cameraRelative) {
    Light l;
    l.vector = towards;
    l.cameraRelative = cameraRelative;
    return l;
}

/// The linear luminance summed over the surface's pixels in the left and the right half of the
/// image (what a ball lit from one side shows there).
std::pair<double, double> halves(const LinearImage& img) {
    double left = 0, right = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const std::size_t o = static_cast<std::size_t>(y) * img.width + x;
            if (img.depth[o] == LinearImage::kNoDepth) continue;  // the background
            const float* p = &img.rgba[o * 4];
            const double lum = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            (x < img.width / 2 ? left : right) += lum;
        }
    return {left, right};
}

}  // namespace

TEST_CASE("lights: a world light stays put while the camera orbits, a camera light turns with it", "[render][lights]") {
    test::FpTrapsOff guard;
    FrameScene scene;
    scene.groundPlane = false;
    scene.meshes.push_back(test::uvSphere(Vec3::Zero(), 1.0));
    for (bool cameraRelative : {false, true}) {
        INFO("camera-relative " << cameraRelative);
        // From +x: in the world, the right of a camera on +z and the left of one on -z.
        Renderer renderer(lightSettings({directional(Vec3(1, 0.2, 0), cameraRelative)}));
        LinearImage front, back;
        Camera cam;
        cam.eye = Vec3(0, 0, 5);
        renderer.render(scene, cam, &front);
        cam.eye = Vec3(0, 0, -5);
        renderer.render(scene, cam, &back);
        const auto [frontLeft, frontRight] = halves(front);
        const auto [backLeft, backRight] = halves(back);
        CHECK(frontRight > 3 * frontLeft);
        if (cameraRelative)
            CHECK(backRight > 3 * backLeft);
        else
            CHECK(backLeft > 3 * backRight);
    }
}

TEST_CASE("lights: a point light's irradiance is its intensity over the squared distance", "[render][lights]") {
    // A matte slab lit from straight above by a point light of intensity I at height d: the
    // linear colour under it is albedo (I / d² + sky), the sky being the hemisphere's colour
    // from above (a render with I = 0).
    test::FpTrapsOff guard;
    FrameScene scene;
    scene.groundPlane = false;
    scene.meshes.push_back(test::box(Vec3(0, -0.05, 0), Vec3(6, 0.1, 6), 3));
    const Vec3 albedo(0.6, 0.5, 0.4);
    scene.meshes.back().colour = albedo;
    Camera cam;
    cam.eye = Vec3(0, 6, 0);
    cam.up = Vec3(0, 0, -1);
    auto centre = [&](Real height, Real intensity) {
        Light l;
        l.type = Light::Type::Point;
        l.vector = Vec3(0.0, height, 0.0);
        l.colour = Vec3::Constant(intensity);
        Renderer renderer(lightSettings({l}));
        LinearImage img;
        renderer.render(scene, cam, &img);
        const float* p = &img.rgba[(static_cast<std::size_t>(img.height / 2) * img.width + img.width / 2) * 4];
        return Vec3(p[0], p[1], p[2]);
    };
    const Vec3 sky = centre(1, 0);
    for (Real d : {1.0, 2.0, 3.0}) {
        INFO("height " << d);
        const Vec3 lit = centre(d, 4.0) - sky;
        for (int c = 0; c < 3; ++c) CHECK(lit[c] == Approx(albedo[c] * 4.0 / (d * d)).epsilon(0.005));
    }
}

TEST_CASE("lights: the studio rig written out as lights renders as the built-in one", "[render][lights]") {
    // The built-in rig has its own unrolled sums (shaders/mesh.frag, DGV_STUDIO_RIG); the same
    // three lights through the general loop (the key's shadow, the rim kept off the floor, the
    // highlights' exponents) must give the same picture, to rounding.
    test::FpTrapsOff guard;
    FrameScene scene;
    scene.meshes.push_back(test::uvSphere(Vec3(0, 1, 0), 1.0));
    scene.meshes.back().colour = Vec3(0.8, 0.3, 0.2);
    scene.meshes.push_back(test::box(Vec3(1.6, 0.5, 0.6), Vec3(1, 1, 1), 3));
    Camera cam;
    cam.eye = Vec3(2, 3, 6);
    cam.target = Vec3(0.5, 0.7, 0);
    RenderSettings builtIn = lightSettings({}), written = lightSettings(defaultLightRig());
    const Image a = Renderer(builtIn).render(scene, cam);
    const Image b = Renderer(written).render(scene, cam);
    int worst = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) worst = std::max(worst, std::abs(int(a.rgba[i]) - int(b.rgba[i])));
    CHECK(worst <= 257);  // one 8-bit code
    // And without the rim on the floor the floor is darker than with it.
    std::vector<Light> rimOnFloor = defaultLightRig();
    rimOnFloor[2].floor = true;
    const Image c = Renderer(lightSettings(rimOnFloor)).render(scene, cam);
    CHECK(c.pixel(5, 90)[0] > b.pixel(5, 90)[0]);
}

TEST_CASE("lights: settings a rig cannot have are refused by name", "[render][lights]") {
    auto problems = [](std::vector<Light> lights) {
        RenderSettings s;
        s.lights = std::move(lights);
        std::string all;
        for (const std::string& p : s.validate()) all += p + "; ";
        return all;
    };
    Light point;
    point.type = Light::Type::Point;
    point.shadows = true;
    CHECK_THAT(problems({point}), Catch::Contains("lights[0]: only a directional light casts shadows"));
    Light a = directional(Vec3(0, 1, 0), false), b = a;
    a.shadows = b.shadows = true;
    CHECK_THAT(problems({a, b}), Catch::Contains("one light casts shadows, 2 ask to"));
    Light below = directional(Vec3(0, -1, 0), false);
    below.shadows = true;
    CHECK_THAT(problems({below}), Catch::Contains("must shine from above"));
    CHECK_THAT(problems({directional(Vec3::Zero(), false)}), Catch::Contains("nonzero, finite direction"));
    CHECK_THAT(problems(std::vector<Light>(9, directional(Vec3(0, 1, 0), false))), Catch::Contains("at most 8"));
    CHECK(problems(defaultLightRig()).empty());
}
