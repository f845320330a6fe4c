// Golden-image tests: small scenes rendered and compared on decoded pixels
// with the references in tests/golden/ by the golden-image rule (render/image_compare.hpp:
// a pixel differs when a channel is off by more than 4/255; at most 0.5% may differ), plus
// probes at known pixels so that a small local defect (a missing highlight) cannot hide in
// the 0.5%. On failure the figures are printed and <name>.new.png and <name>.diff.png (|diff|
// x 16) are written to <build>/golden-out/, never into tests/golden/.
//
// DGV_UPDATE_GOLDEN=1 rewrites the references that are missing or fail (and says which); it
// refuses when CI=true. Without it a missing reference is a failure. See tests/golden/README.md.

#include "render/image_compare.hpp"
#include "render/renderer.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/mesh_import.hpp"
#include "io/png.hpp"
#include "support/helpers.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

constexpr int kSize = 256;

struct GoldenScene {
    std::string name;
    RenderSettings settings;
    FrameScene scene;
    Camera camera;
    PngWriteOptions png;
};

Box3 boundsOf(const FrameScene& scene) {
    Box3 b;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.positions) b.extend(p);
    return b;
}

/// A box (crease-split normals) beside a torus on the ground, one turntable frame, 8-bit RGB.
GoldenScene primitiveTurntable(Real boxYawDegrees = 0) {
    GoldenScene g;
    g.name = "primitive_turntable";
    g.settings.width = kSize;
    g.settings.height = kSize;
    DrawMesh box = test::box(Vec3(-0.8, 0.0, 0.0), Vec3(1.0, 1.0, 1.0), 4);
    const Eigen::AngleAxis<Real> yaw(boxYawDegrees * 3.14159265358979323846 / 180, Vec3::UnitY());
    for (Vec3& p : box.positions) p = Vec3(-0.8, 0, 0) + yaw * (p - Vec3(-0.8, 0, 0));
    box.colour = Vec3(0.75, 0.22, 0.12);
    g.scene.meshes.push_back(box);
    DrawMesh ring = test::torus(Vec3(0.8, -0.3, 0.1), 0.55, 0.2, 64, 32);
    ring.colour = Vec3(0.25, 0.4, 0.7);
    g.scene.meshes.push_back(ring);
    g.scene.groundPlane = true;
    g.camera = turntableCamera(boundsOf(g.scene), 30, 25, 35, 1.0);
    g.png.alpha = false;
    return g;
}

/// A sphere over a transparent background (shadow catcher on the ground), 8-bit RGBA.
GoldenScene transparentFrame() {
    GoldenScene g;
    g.name = "transparent_background";
    g.settings.width = kSize;
    g.settings.height = kSize;
    g.settings.transparentBackground = true;
    DrawMesh sphere = test::uvSphere(Vec3(0, 0, 0), 1.0, 32, 64);
    sphere.colour = Vec3(0.2, 0.6, 0.25);
    g.scene.meshes.push_back(sphere);
    g.scene.groundPlane = true;
    g.camera = turntableCamera(boundsOf(g.scene), 0, 20, 35, 1.0);
    g.png.alpha = true;
    return g;
}

/// A torus with a contact-style scalar ramp on its lower half, 16-bit RGB.
GoldenScene sixteenBitFrame() {
    GoldenScene g;
    g.name = "sixteen_bit_ramp";
    g.settings.width = kSize;
    g.settings.height = kSize;
    DrawMesh ring = test::torus(Vec3(0, 0, 0), 0.9, 0.35, 96, 48);
    ring.colour = Vec3(0.6, 0.6, 0.62);
    ring.scalar.resize(ring.positions.size());
    for (std::size_t i = 0; i < ring.positions.size(); ++i)
        ring.scalar[i] = std::max(0.0, -ring.positions[i].x() / 1.25);  // 0 .. 1 towards -x
    g.scene.meshes.push_back(ring);
    g.scene.groundPlane = true;
    g.camera = turntableCamera(boundsOf(g.scene), 0, 35, 35, 1.0);
    g.png.alpha = false;
    g.png.bitDepth = 16;
    return g;
}

/// assimp's BoxTextured GLB (its PNG texture inside the file) in its own material, as a scene
/// without `color` draws it: one turntable frame on the ground, 8-bit RGB.
GoldenScene texturedAsset() {
    GoldenScene g;
    g.name = "textured_asset";
    g.settings.width = kSize;
    g.settings.height = kSize;
    MeshImportOptions o;
    o.materials = true;
    const TriangleMesh box = importMesh("/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb", o);
    REQUIRE(box.hasMaterials());
    DrawMesh m;
    m.positions = box.vertices;
    m.triangles = box.triangles;
    m.materials = box.materials;
    m.triangleMaterials = box.triangleMaterials;
    m.cornerUvs = box.cornerUvs;
    g.scene.meshes.push_back(m);
    g.scene.groundPlane = true;
    g.camera = turntableCamera(boundsOf(g.scene), 35, 25, 35, 1.0);
    g.png.alpha = false;
    return g;
}

/// Renders and round-trips through the PNG encoder (what a user's file holds), decoded.
struct Rendered {
    std::vector<unsigned char> bytes;
    Image decoded;
};

Rendered renderGolden(const GoldenScene& g, const fs::path& scratch) {
    Renderer renderer(g.settings);
    Rendered r;
    const Image img = renderer.render(g.scene, g.camera);
    r.bytes = encodePng(img, g.png);
    writePng(scratch / (g.name + ".png"), img, g.png);
    r.decoded = readPng(scratch / (g.name + ".png"));
    return r;
}

fs::path goldenDir() { return test::sourcePath("tests/golden"); }
fs::path outDir() { return fs::path(DGV_TEST_BINARY_DIR) / "golden-out"; }

bool envOn(const char* name) {
    const char* v = std::getenv(name);
    return v && *v && std::string(v) != "0" && std::string(v) != "false";
}

/// Probes: the reference's brightest pixel (the specular highlight) and a fixed 5x5 grid; each
/// must match within the per-pixel threshold, whatever the whole-image fraction says.
std::vector<std::string> probeFailures(const Image& ref, const Image& got, double threshold) {
    std::vector<std::pair<int, int>> probes;
    for (int j = 1; j <= 5; ++j)
        for (int i = 1; i <= 5; ++i) probes.emplace_back(i * ref.width / 6, j * ref.height / 6);
    long best = -1;
    int bx = 0, by = 0;
    for (int y = 0; y < ref.height; ++y)
        for (int x = 0; x < ref.width; ++x) {
            const std::uint16_t* p = ref.pixel(x, y);
            const long lum = long(p[0]) + p[1] + p[2];
            if (p[3] > 0 && lum > best) {
                best = lum;
                bx = x;
                by = y;
            }
        }
    probes.emplace_back(bx, by);
    std::vector<std::string> failures;
    for (auto [x, y] : probes) {
        const std::uint16_t* a = ref.pixel(x, y);
        const std::uint16_t* b = got.pixel(x, y);
        for (int c = 0; c < 4; ++c) {
            const double d = std::abs(double(a[c]) - double(b[c])) * 255.0 / 65535.0;
            if (d > threshold) {
                failures.push_back("probe (" + std::to_string(x) + ", " + std::to_string(y) + ") channel " +
                                   std::to_string(c) + " off by " + std::to_string(d) + "/255");
                break;
            }
        }
    }
    return failures;
}

struct Verdict {
    bool pass = false;
    bool referenceMissing = false;
    std::string message;
};

/// Compares a rendering with tests/golden/<name>.png; on failure writes .new/.diff images to
/// <build>/golden-out/. Never touches tests/golden/.
Verdict compareWithGolden(const std::string& name, const Image& got) {
    Verdict v;
    const fs::path ref = goldenDir() / (name + ".png");
    if (!fs::exists(ref)) {
        v.referenceMissing = true;
        v.message = "no reference " + ref.string() + "; run with DGV_UPDATE_GOLDEN=1 and review the image";
        return v;
    }
    const Image reference = readPng(ref);
    const ImageCompareSettings settings;  // 4/255 per pixel, 0.5% of the pixels
    const ImageCompareResult r = compareImages(reference, got, settings);
    const std::vector<std::string> probes =
        r.sizeMismatch ? std::vector<std::string>{} : probeFailures(reference, got, settings.threshold);
    v.pass = r.pass && probes.empty();
    v.message = name + ": " + r.summary();
    for (const std::string& p : probes) v.message += "; " + p;
    if (!v.pass && !r.sizeMismatch) {
        ensureDirectory(outDir().string());
        const fs::path newPath = outDir() / (name + ".new.png");
        const fs::path diffPath = outDir() / (name + ".diff.png");
        writePng(newPath, got);
        writePng(diffPath, differenceImage(reference, got));
        v.message += "; wrote " + newPath.string() + " and " + diffPath.string();
    }
    return v;
}

void checkGolden(const GoldenScene& g) {
    test::FpTrapsOff guard;
    test::TempDir scratch("golden-" + g.name);
    const Rendered r = renderGolden(g, scratch.path());
    const Verdict v = compareWithGolden(g.name, r.decoded);
    if (v.pass) {
        SUCCEED(v.message);
        return;
    }
    if (envOn("DGV_UPDATE_GOLDEN")) {
        if (envOn("CI")) FAIL("DGV_UPDATE_GOLDEN=1 refused because CI=true (" << v.message << ")");
        const fs::path ref = goldenDir() / (g.name + ".png");
        writeTextAtomically(ref, std::string(r.bytes.begin(), r.bytes.end()));
        WARN("updated " << ref.string() << " (" << v.message << "); review it before committing");
        return;
    }
    FAIL(v.message);
}

}  // namespace

TEST_CASE("golden: primitive turntable frame (box with crease normals, torus, ground)", "[render][golden]") {
    checkGolden(primitiveTurntable());
}

TEST_CASE("golden: transparent background frame", "[render][golden]") {
    GoldenScene g = transparentFrame();
    checkGolden(g);
    // Probes that need no reference: alpha 0 in the sky corners, opaque on the sphere.
    test::FpTrapsOff guard;
    test::TempDir scratch("golden-probe");
    const Image img = renderGolden(g, scratch.path()).decoded;
    CHECK(img.pixel(0, 0)[3] == 0);
    CHECK(img.pixel(kSize - 1, 0)[3] == 0);
    CHECK(img.pixel(kSize / 2, kSize / 2)[3] == 65535);
    const std::uint16_t* c = img.pixel(kSize / 2, kSize / 2);
    CHECK(c[1] > c[0]);
    CHECK(c[1] > c[2]);
}

TEST_CASE("golden: 16-bit frame with a scalar ramp", "[render][golden]") {
    GoldenScene g = sixteenBitFrame();
    checkGolden(g);
    // 16 bits are meaningful: the smooth shading uses codes that are not multiples of 257.
    test::FpTrapsOff guard;
    test::TempDir scratch("golden-16");
    const Image img = renderGolden(g, scratch.path()).decoded;
    long notEightBit = 0;
    for (std::uint16_t s : img.rgba) notEightBit += s % 257 != 0;
    CHECK(notEightBit > static_cast<long>(img.rgba.size() / 4));
}

TEST_CASE("golden: a textured asset in its file's material", "[render][golden][materials]") {
    test::FpTrapsOff guard;
    checkGolden(texturedAsset());
}

TEST_CASE("golden: a deliberately changed scene fails the comparison", "[render][golden]") {
    test::FpTrapsOff guard;
    const fs::path ref = goldenDir() / "primitive_turntable.png";
    REQUIRE(fs::exists(ref));
    test::TempDir scratch("golden-changed");
    for (int variant = 0; variant < 2; ++variant) {
        GoldenScene g = primitiveTurntable(variant == 0 ? 10.0 : 0.0);      // box turned 10 degrees
        if (variant == 1) g.scene.meshes[1].colour = Vec3(0.25, 0.7, 0.4);  // or the torus recoloured
        g.name = "changed_" + std::to_string(variant);
        const Image got = renderGolden(g, scratch.path()).decoded;
        const Image reference = readPng(ref);
        const ImageCompareResult r = compareImages(reference, got);
        INFO(r.summary());
        CHECK_FALSE(r.pass);
        CHECK(r.differing > 0);
    }
    // A missing reference is a failure, not a pass.
    const Verdict missing = compareWithGolden("no_such_reference", Image(4, 4));
    CHECK_FALSE(missing.pass);
    CHECK(missing.referenceMissing);
    CHECK(missing.message.find("DGV_UPDATE_GOLDEN=1") != std::string::npos);
}

TEST_CASE("golden: rendering the same scene twice gives identical PNG bytes", "[render][golden][determinism]") {
    test::FpTrapsOff guard;
    test::TempDir scratch("golden-bytes");
    for (const GoldenScene& g : {primitiveTurntable(), sixteenBitFrame()}) {
        const Rendered a = renderGolden(g, scratch.path());
        const Rendered b = renderGolden(g, scratch.path());
        INFO(g.name);
        CHECK(a.bytes == b.bytes);
    }
}

TEST_CASE("renderer: crease normals keep a box's faces flat, 180 degrees rounds its edges", "[render]") {
    test::FpTrapsOff guard;
    FrameScene scene;
    scene.meshes.push_back(test::box(Vec3::Zero(), Vec3(2, 2, 2), 4));
    scene.meshes.back().colour = Vec3(0.7, 0.7, 0.7);
    scene.groundPlane = false;
    Camera cam;
    cam.eye = Vec3(0.0, 0.0, 6.0);  // looking straight at the +Z face
    cam.target = Vec3::Zero();
    auto faceSpread = [&](double crease) {
        RenderSettings s;
        s.width = s.height = 128;
        s.creaseDegrees = crease;
        Renderer renderer(s);
        const Image img = renderer.render(scene, cam);
        // The +Z face (z = 1, 5 units away, fov 35) spans x, y in about 23.4..104.6; its edge
        // quads are 20 pixels wide. Compare pixels 4.6 pixels inside each edge with the centre.
        // The largest change over the four edges and the three colour channels.
        double spread = 0;
        for (auto [x, y] : {std::pair{28, 64}, {100, 64}, {64, 28}, {64, 100}})
            for (int c = 0; c < 3; ++c)
                spread = std::max(spread, std::abs(double(img.pixel(64, 64)[c]) - double(img.pixel(x, y)[c])));
        return spread / 65535.0;
    };
    const double crisp = faceSpread(40), smooth = faceSpread(180);
    INFO("crisp " << crisp << " smooth " << smooth);
    CHECK(crisp < 0.02);
    CHECK(smooth > 0.05);
    RenderSettings bad;
    bad.creaseDegrees = 200;
    CHECK(bad.validate().size() == 1);
    bad.shadowSoftness = -1;
    CHECK(bad.validate().size() == 2);
}

TEST_CASE("renderer: EGL and OSMesa give bit-identical images", "[render][egl]") {
    test::FpTrapsOff guard;
    const GoldenScene g = primitiveTurntable();
    std::vector<std::uint16_t> pixels[2];
    for (int i = 0; i < 2; ++i) {
        RenderSettings s = g.settings;
        s.backend = i == 0 ? GlBackend::OsMesa : GlBackend::Egl;
        try {
            Renderer renderer(s);  // one at a time: the backends share Mesa's dispatch
            CHECK(renderer.backend() == s.backend);
            CHECK(renderer.glRenderer().find("llvmpipe") != std::string::npos);
            pixels[i] = renderer.render(g.scene, g.camera).rgba;
        } catch (const RuntimeError& e) {
            if (i == 0) throw;
            WARN("SKIPPED: EGL cannot initialise here: " << e.what());
            return;
        }
    }
    CHECK(pixels[0] == pixels[1]);
}

TEST_CASE("renderer: a closed mesh wound inside out looks the same as the right way round", "[render]") {
    test::FpTrapsOff guard;
    RenderSettings s;
    s.width = s.height = 96;
    Renderer renderer(s);
    Camera cam;
    cam.eye = Vec3(1.0, 1.5, 5.0);
    cam.target = Vec3::Zero();
    FrameScene scene;
    scene.meshes.push_back(test::box(Vec3::Zero(), Vec3(1.5, 1.5, 1.5), 3));
    const Image outward = renderer.render(scene, cam);
    for (auto& t : scene.meshes[0].triangles) std::swap(t[1], t[2]);  // CW from outside
    const Image inward = renderer.render(scene, cam);
    // Same silhouette and shading (normals flip back in the shader): the golden rule passes.
    const ImageCompareResult r = compareImages(outward, inward);
    INFO(r.summary());
    CHECK(r.pass);
    CHECK(r.maxError < 2.0);
}

TEST_CASE("renderer: shared shadow taps match four taps per subsample", "[render]") {
    // RenderSettings::sharedShadowTaps: the 2x2 fragment quads of the supersampled mesh pass
    // share their PCF taps (two each instead of four, summed with fine derivatives). Taps on
    // the wrong corners, or a sum over half a quad, show all over a wide penumbra (checked by
    // breaking the shader: 2 and 4 failed assertions); the sharing itself differs from the 16
    // taps only on hard shadow edges (the default trefoil at 1080p: 56 pixels over 4/255).
    // A ball over a wide slab, seen close up: its shadow falls on the slab (mesh on mesh; the
    // ground's own shadow is drawn at output size with four taps per pixel either way), and
    // the shadow map, spread over the slab's bounding sphere, is magnified to about 4 pixels
    // a texel, so the penumbra is some 15 pixels wide instead of the usual one or two.
    test::FpTrapsOff guard;
    FrameScene scene;
    scene.meshes.push_back(test::box(Vec3(0, -0.1, 0), Vec3(40.0, 0.2, 40.0), 4));
    scene.meshes.back().colour = Vec3(0.7, 0.7, 0.7);
    scene.meshes.push_back(test::uvSphere(Vec3(0.0, 0.8, 0.0), 0.5, 32, 64));
    scene.meshes.back().colour = Vec3(0.7, 0.3, 0.2);
    scene.groundPlane = false;
    Camera camera;
    camera.eye = Vec3(0.0, 2.5, 3.5);
    camera.target = Vec3(0.0, 0.3, 0.0);
    for (int factor : {2, 4}) {
        Image img[2];
        for (int i = 0; i < 2; ++i) {
            RenderSettings s;
            s.width = s.height = kSize;
            s.supersample = factor;
            s.sharedShadowTaps = i == 0;
            Renderer renderer(s);
            img[i] = renderer.render(scene, camera);
        }
        ImageCompareSettings rule;
        rule.threshold = 4;
        rule.maxFraction = 0.001;
        const ImageCompareResult r = compareImages(img[1], img[0], rule);
        INFO("factor " << factor << ": " << r.summary());
        CHECK(r.pass);
        CHECK(r.maxError <= 8);
        CHECK(img[0].rgba != img[1].rgba);  // the shared taps are in use
    }
}
