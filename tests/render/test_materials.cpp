// Materials from the file (DrawMesh::materials, triangleMaterials, cornerUvs; docs/rendering.md,
// "Materials from the file"): a texture's texels where its coordinates put them, a white texture
// and a default material exactly the plain colour, a UV seam that splits no normal, one mesh in
// several materials, roughness and metalness against the plain highlight, and the lists checked.

#include "render/renderer.hpp"

#include "test_meshes.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <memory>

using namespace dgv;

namespace {

RenderSettings materialSettings() {
    RenderSettings s;
    s.width = 128;
    s.height = 128;
    return s;
}

Camera frontCamera(Real distance = 5) {
    Camera cam;
    cam.eye = Vec3(0, 0, distance);
    cam.target = Vec3::Zero();
    cam.fovYDegrees = 35;
    return cam;
}

/// A square of side 2 in the z = 0 plane facing +z (the camera), two triangles, its corners'
/// texture coordinates u = (x + 1)/2, v = (y + 1)/2.
DrawMesh square() {
    DrawMesh m;
    m.positions = {Vec3(-1, -1, 0), Vec3(1, -1, 0), Vec3(1, 1, 0), Vec3(-1, 1, 0)};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    auto uv = [&](int i) {
        const Vec3& p = m.positions[static_cast<std::size_t>(i)];
        return Eigen::Vector2f(static_cast<float>((p.x() + 1) / 2), static_cast<float>((p.y() + 1) / 2));
    };
    for (const auto& t : m.triangles) m.cornerUvs.push_back({uv(t[0]), uv(t[1]), uv(t[2])});
    m.triangleMaterials.assign(m.triangles.size(), 0);
    return m;
}

std::shared_ptr<const TextureImage> texture(int w, int h, const std::vector<std::uint8_t>& rgba) {
    auto t = std::make_shared<TextureImage>();
    t->width = w;
    t->height = h;
    t->rgba = rgba;
    t->source = "test";
    return t;
}

SurfaceMaterial material(const Vec3& colour, std::shared_ptr<const TextureImage> map = nullptr) {
    SurfaceMaterial m;
    m.baseColour = colour;
    m.baseColourMap = std::move(map);
    return m;
}

/// The pixel at the world point p of the plane z = 0 seen by frontCamera at 128x128.
const std::uint16_t* pixelAt(const Image& img, const Camera& cam, Real x, Real y) {
    const Real halfHeight = cam.eye.z() * std::tan(cam.fovYDegrees * 3.14159265358979323846 / 360);
    const int px = static_cast<int>(std::floor((x / halfHeight + 1) / 2 * img.width));
    const int py = static_cast<int>(std::floor((1 - y / halfHeight) / 2 * img.height));
    return img.pixel(px, py);
}

int maxCodeDifference(const std::uint16_t* a, const std::uint16_t* b) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(static_cast<int>(to8bit(a[c])) - to8bit(b[c])));
    return d;
}

}  // namespace

TEST_CASE("materials: a texture's texels show where the texture coordinates put them", "[render][materials]") {
    test::FpTrapsOff guard;
    Renderer renderer(materialSettings());
    const Camera cam = frontCamera();
    // 8x8 texels in four blocks of one colour, rows from the top: red, green over blue, white.
    // The square's quarter points sample the middle of a block: its colour, unblended.
    std::vector<std::uint8_t> texels;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            const bool right = x >= 4, bottom = y >= 4;
            const std::uint8_t r = !bottom && !right ? 255 : (bottom && right ? 255 : 0);
            const std::uint8_t g = !bottom && right ? 255 : (bottom && right ? 255 : 0);
            const std::uint8_t b = bottom ? 255 : 0;
            texels.insert(texels.end(), {r, g, b, 255});
        }
    FrameScene textured;
    textured.groundPlane = false;
    textured.meshes.push_back(square());
    textured.meshes[0].materials = {material(Vec3::Ones(), texture(8, 8, texels))};
    const Image img = renderer.render(textured, cam);
    // Each quarter against the square drawn in that texel's colour without a texture.
    const struct {
        Real x, y;
        Vec3 colour;
    } quarters[] = {{-0.5, 0.5, Vec3(1, 0, 0)}, {0.5, 0.5, Vec3(0, 1, 0)}, {-0.5, -0.5, Vec3(0, 0, 1)},
                    {0.5, -0.5, Vec3(1, 1, 1)}};
    for (const auto& q : quarters) {
        INFO("at " << q.x << ", " << q.y);
        FrameScene plain = textured;
        plain.meshes[0].materials = {material(q.colour)};
        const Image ref = renderer.render(plain, cam);
        CHECK(maxCodeDifference(pixelAt(img, cam, q.x, q.y), pixelAt(ref, cam, q.x, q.y)) <= 1);
    }
    // and the texture really varies: red's quarter has no blue, blue's no red
    CHECK(to8bit(pixelAt(img, cam, -0.5, 0.5)[2]) < 20);
    CHECK(to8bit(pixelAt(img, cam, -0.5, -0.5)[0]) < 20);
}

TEST_CASE("materials: a white texture, or a material of the mesh's colour, draws exactly the plain mesh",
          "[render][materials]") {
    test::FpTrapsOff guard;
    Renderer renderer(materialSettings());
    const Camera cam = frontCamera(8);
    const Vec3 colour(0.8, 0.3, 0.2);
    FrameScene plain;
    plain.meshes.push_back(test::uvSphere(Vec3::Zero(), 1.0));
    plain.meshes[0].colour = colour;
    const Image reference = renderer.render(plain, cam);

    // Texture coordinates from longitude and latitude: the last column of each ring wraps to
    // u = 1 while its neighbours' corners say 0, so every vertex on that meridian is split; its
    // normal must not be (a seam that showed would change pixels).
    DrawMesh& sphere = plain.meshes[0];
    const int segments = 64, rings = 32;
    for (const auto& t : sphere.triangles) {
        std::array<Eigen::Vector2f, 3> uv;
        const int base = std::min({t[0], t[1], t[2]}) % segments;
        for (int k = 0; k < 3; ++k) {
            int j = t[static_cast<std::size_t>(k)] % segments;
            if (base == segments - 1 && j == 0) j = segments;  // the wrap
            uv[static_cast<std::size_t>(k)] =
                Eigen::Vector2f(static_cast<float>(j) / segments,
                                1.0f - static_cast<float>(t[static_cast<std::size_t>(k)] / segments) / rings);
        }
        sphere.cornerUvs.push_back(uv);
    }
    sphere.triangleMaterials.assign(sphere.triangles.size(), 0);
    SECTION("a white texture times the colour") {
        sphere.materials = {material(colour, texture(1, 1, {255, 255, 255, 255}))};
        CHECK(renderer.render(plain, cam).rgba == reference.rgba);
    }
    SECTION("a material at its defaults, of the mesh's colour") {
        sphere.materials = {material(colour)};
        CHECK(renderer.render(plain, cam).rgba == reference.rgba);
    }
    SECTION("the triangles' material -1: the mesh's colour") {
        sphere.materials = {material(Vec3(0, 1, 0))};
        sphere.triangleMaterials.assign(sphere.triangles.size(), -1);
        CHECK(renderer.render(plain, cam).rgba == reference.rgba);
    }
}

TEST_CASE("materials: one mesh in several materials", "[render][materials]") {
    test::FpTrapsOff guard;
    Renderer renderer(materialSettings());
    const Camera cam = frontCamera();
    FrameScene scene;
    scene.groundPlane = false;
    scene.meshes.push_back(square());
    DrawMesh& m = scene.meshes[0];
    // Triangle 0 is the lower right half (x > y), triangle 1 the upper left.
    m.materials = {material(Vec3(0.9, 0.1, 0.1)), material(Vec3(0.1, 0.1, 0.9))};
    m.triangleMaterials = {1, 0};
    const Image img = renderer.render(scene, cam);
    const std::uint16_t* lowerRight = pixelAt(img, cam, 0.6, -0.6);
    const std::uint16_t* upperLeft = pixelAt(img, cam, -0.6, 0.6);
    CHECK(lowerRight[2] > 2 * lowerRight[0]);  // blue (0.9 against 0.1 linear: 0.95 against 0.35 encoded)
    CHECK(upperLeft[0] > 2 * upperLeft[2]);    // red
}

TEST_CASE("materials: roughness narrows or widens the highlight, metalness tints it and drops the diffuse",
          "[render][materials]") {
    test::FpTrapsOff guard;
    Renderer renderer(materialSettings());
    const Camera cam = frontCamera(8);
    auto ballWith = [&](Real roughness, Real metallic) {
        FrameScene scene;
        scene.groundPlane = false;
        scene.meshes.push_back(test::uvSphere(Vec3::Zero(), 1.0));
        DrawMesh& m = scene.meshes[0];
        m.triangleMaterials.assign(m.triangles.size(), 0);
        SurfaceMaterial mat = material(Vec3(0.9, 0.6, 0.1));
        mat.roughness = roughness;
        mat.metallic = metallic;
        m.materials = {mat};
        return renderer.render(scene, cam);
    };
    // The brightest pixel and the number of pixels within 90 % of it (the highlight's size).
    auto peak = [](const Image& img, int& spot) {
        double best = 0;
        std::vector<double> lum;
        for (std::size_t p = 0; p < img.rgba.size(); p += 4) {
            lum.push_back(0.2126 * img.rgba[p] + 0.7152 * img.rgba[p + 1] + 0.0722 * img.rgba[p + 2]);
            best = std::max(best, lum.back());
        }
        spot = 0;
        for (double l : lum) spot += l > 0.9 * best;
        return best;
    };
    int smoothSpot = 0, roughSpot = 0;
    const double smoothPeak = peak(ballWith(0.15, 0), smoothSpot);
    const double roughPeak = peak(ballWith(0.7, 0), roughSpot);
    CHECK(smoothPeak > roughPeak);
    CHECK(smoothSpot < roughSpot);
    // A metal of the same colour: its diffuse is gone, so the side turned from the key is darker,
    // and its highlight takes the albedo's colour (more red than blue).
    const Image dielectric = ballWith(0.4, 0);
    const Image metal = ballWith(0.4, 1);
    const std::uint16_t* shadeD = dielectric.pixel(78, 64);
    const std::uint16_t* shadeM = metal.pixel(78, 64);
    CHECK(shadeM[0] + shadeM[1] + shadeM[2] < shadeD[0] + shadeD[1] + shadeD[2]);
    int spot = 0;
    peak(metal, spot);
    std::size_t brightest = 0;
    for (std::size_t p = 0; p < metal.rgba.size(); p += 4)
        if (metal.rgba[p] + metal.rgba[p + 1] > metal.rgba[brightest] + metal.rgba[brightest + 1]) brightest = p;
    CHECK(metal.rgba[brightest] > metal.rgba[brightest + 2] + 5000);
}

TEST_CASE("materials: lists of the wrong length and unknown materials are refused", "[render][materials]") {
    test::FpTrapsOff guard;
    Renderer renderer(materialSettings());
    FrameScene scene;
    scene.meshes.push_back(square());
    scene.meshes[0].materials = {material(Vec3::Ones())};
    SECTION("a material index past the list") {
        scene.meshes[0].triangleMaterials[1] = 1;
        CHECK_THROWS_WITH(renderer.render(scene, frontCamera()), Catch::Contains("refers to material 1"));
    }
    SECTION("texture coordinates for fewer triangles") {
        scene.meshes[0].cornerUvs.pop_back();
        CHECK_THROWS_WITH(renderer.render(scene, frontCamera()), Catch::Contains("texture coordinates have 1"));
    }
    SECTION("materials for more triangles") {
        scene.meshes[0].triangleMaterials.push_back(0);
        CHECK_THROWS_WITH(renderer.render(scene, frontCamera()), Catch::Contains("materials have 3 entries"));
    }
}
