#include "base/errors.hpp"
#include "io/png.hpp"
#include "io/scene_json.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

const char* kFull = R"({
  "name": "shot_010",
  "frames": { "start": 5, "end": 20, "fps": 30 },
  "substeps": 4,
  "objects": [
    { "name": "blob", "mesh": "meshes/blob.obj", "mesh_name": "Body",
      "transform": { "translate": [1, 2, 3], "rotate": [0, 90, 0], "scale": 2 },
      "voxel_size": 0.05, "color": [1, 0.5, 0], "deformable": true },
    { "primitive": { "type": "torus", "major_radius": 1, "minor_radius": 0.25 },
      "resolution": 40, "deformable": false }
  ],
  "forces": [
    { "type": "gravity" },
    { "type": "vortex", "position": [0, 1, 0], "axis": [0, 2, 0], "radius": 2,
      "strength": [[1, 0], [10, 5]] }
  ],
  "colliders": [ { "type": "ground", "height": -1 }, { "type": "sphere", "centre": [0, 0, 0], "radius": 0.5 } ],
  "camera": { "type": "look_at", "eye": [0, 1, 5], "target": [0, 0, 0], "fov": 40 },
  "render": { "width": 320, "height": 240, "supersample": 1, "background": [0.5, 0.5, 0.5],
              "transparent": true, "ground": false, "bit_depth": 16 },
  "output": { "dir": "//renders" }
})";

std::string errorOf(const std::string& text) {
    try {
        parseScene(text, "dir/scene.json");
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

}  // namespace

TEST_CASE("scene_json: a full scene maps onto the settings", "[io][scene]") {
    SceneDesc s = parseScene(kFull, "/projects/show/scene.json");
    CHECK(s.name == "shot_010");
    CHECK(s.frameStart == 5);
    CHECK(s.frameEnd == 20);
    CHECK(s.fps == 30);
    CHECK(s.substeps == 4);
    REQUIRE(s.objects.size() == 2);
    const ObjectDesc& blob = s.objects[0];
    CHECK(blob.meshPath == "/projects/show/meshes/blob.obj");  // relative to the scene's folder
    CHECK(blob.meshName == "Body");
    CHECK(blob.voxel.voxelSize == 0.05);
    CHECK(blob.transform.scale == Vec3(2, 2, 2));
    // rotate 90 degrees about Y maps +X to -Z
    Vec3 x = blob.transform.linear() * Vec3::UnitX();
    CHECK((x - Vec3(0, 0, -2)).norm() < 1e-12);
    // colours are given in sRGB and held linear
    CHECK(blob.color.x() == Approx(1.0));
    CHECK(blob.color.y() == Approx(0.21404).epsilon(1e-4));
    CHECK(blob.color.z() == 0.0);
    CHECK(s.objects[1].name == "object1");
    CHECK(s.objects[1].isPrimitive);
    CHECK(s.objects[1].primitive.type == PrimitiveType::Torus);
    CHECK(s.objects[1].voxel.resolution == 40);
    CHECK_FALSE(s.objects[1].deformable);
    REQUIRE(s.forces.size() == 2);
    CHECK(s.forces[0].strength.at(1) == Approx(9.81));
    CHECK(s.forces[1].axis == Vec3::UnitY());  // normalised
    CHECK(s.forces[1].strength.at(5.5) == Approx(2.5));
    CHECK(s.forces[1].strength.at(100) == Approx(5));
    CHECK(s.forces[1].falloff == 1);  // the vortex's default; an attractor's is 2
    REQUIRE(s.colliders.size() == 2);
    CHECK(s.colliders[0].height == -1);
    CHECK(s.camera.type == CameraType::LookAt);
    CHECK(s.render.bitDepth == 16);
    CHECK(s.render.transparent);
    CHECK(s.output.dir == "/projects/show/renders");  // "//" is relative to the scene's folder
}

TEST_CASE("scene_json: defaults for a minimal scene", "[io][scene]") {
    SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}]})", "a/b/minimal.json");
    CHECK(s.name == "minimal");
    CHECK(s.frameStart == 1);
    CHECK(s.frameEnd == 1);
    CHECK(s.objects[0].voxel.resolution == 48);
    CHECK(s.camera.type == CameraType::Turntable);
    CHECK(s.output.dir == (fs::current_path() / "out" / "minimal").string());
    CHECK(!s.maxSubstepsGiven);
    // Whole numbers written as floats (what a script's float gives) are those integers.
    const SceneDesc f = parseScene(
        R"({"objects": [{"primitive": {"type": "sphere"}, "resolution": 24.0}], "substeps": 4.0, "max_substeps": 1e2})",
        "f.json");
    CHECK(f.substeps == 4);
    CHECK(f.maxSubsteps == 100);
    CHECK(f.maxSubstepsGiven);
    CHECK(f.objects[0].voxel.resolution == 24);
}

TEST_CASE("scene_json: every bad input names the file, the JSON path and the problem", "[io][scene]") {
    struct Case {
        const char* text;
        const char* expected;
    };
    const Case cases[] = {
        {"", "dir/scene.json: malformed JSON: the file is empty"},
        {"{\"objects\": [\n  {\"primitive\": {\"type\": \"sphere\"},}\n]}", "line 2, column"},
        {"[1, 2]", "dir/scene.json: (top level): expected an object, got an array"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "fram": {}})",
         "dir/scene.json: fram: unknown key (did you mean 'frames'?)"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "colour": [1,0,0]}]})",
         "objects[0].colour: unknown key (did you mean 'color'?)"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "voxel_size": -1}]})",
         "dir/scene.json: objects[0].voxel_size: expected a positive number, got -1"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "voxel_size": 0.1, "resolution": 8}]})",
         "objects[0].voxel_size: give voxel_size or resolution, not both"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "resolution": 1.5}]})",
         "objects[0].resolution: expected an integer, got 1.5"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "resolution": 100000}]})",
         "objects[0].resolution: expected an integer in [2, 2048], got 100000"},
        // A whole number written as a float is range-checked as the integer it is.
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "substeps": 1e5})",
         "substeps: expected an integer in [1, 1000], got 100000.0"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "substeps": 1e300})",
         "substeps: expected an integer in [1, 1000], got 1e+300"},
        {R"({"objects": [{"primitive": {"type": "cone"}}]})",
         "objects[0].primitive.type: expected one of 'sphere', 'box', 'torus', 'capsule', got \"cone\""},
        {R"({"objects": [{"primitive": {"type": "sphere", "radius": "big"}}]})",
         "objects[0].primitive.radius: expected a number, got \"big\""},
        {R"({"objects": [{"name": "a"}]})", "objects[0]: give exactly one of 'mesh' (a file) or 'primitive'"},
        {R"({"objects": []})", "objects: a scene needs at least one object"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"volume_tolerance": 0}}]})",
         "objects[0].material.volume_tolerance: expected a number in [1e-12, 0.1], got 0"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "name": "a"}, {"primitive": {"type": "box"}, "name": "a"}]})",
         "objects[1].name: duplicate object name \"a\""},
        {R"({"objects": [{"primitive": {"type": "torus", "major_radius": 0.2, "minor_radius": 0.3}}]})",
         "objects[0].primitive.minor_radius: must be smaller than major_radius"},
        {R"({"objects": [{"primitive": {"type": "box", "size": [1, 0, 1]}}]})",
         "objects[0].primitive.size[1]: expected a positive edge length"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "color": [1, 2, 0]}]})",
         "objects[0].color[1]: expected a number in [0, 1], got 2"},
        {R"({"objects": [{"primitive": {"type": "sphere"}, "transform": {"translate": [0, 0]}}]})",
         "objects[0].transform.translate: expected an array of 3 numbers, got an array"},
        {R"({"frames": {"start": 10, "end": 2}, "objects": [{"primitive": {"type": "sphere"}}]})",
         "frames.end: must be >= start (10)"},
        {R"({"name": "my shot", "objects": [{"primitive": {"type": "sphere"}}]})", "name: use letters, digits"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "camera": {"type": "look_at", "eye": [0, 5, 0], "target": [0, 0, 0]}})",
         "camera.up: must not be parallel to the view direction"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"bit_depth": 12}})",
         "render.bit_depth: expected 8 or 16"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"width": 0}})",
         "render.width: expected an integer in [16, 16384], got 0"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "forces": [{"type": "vortex", "strength": [[5, 1], [2, 1]]}]})",
         "forces[0].strength[1]: key frames must increase"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "forces": [{"type": "gravity", "direction": [0, 0, 0]}]})",
         "forces[0].direction: expected a non-zero direction"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "forces": [{"type": "attractor", "softening": 0}]})",
         "forces[0].softening: expected a positive number, got 0"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "forces": [{"type": "vortex", "falloff": 5}]})",
         "forces[0].falloff: expected a number in [0, 4], got 5"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "colliders": [{"type": "mesh"}]})",
         "colliders[0].mesh: missing; a mesh collider needs a mesh file"},
        {R"({"objects": [{"primitive": {"type": "sphere"}}], "substeps": 0})",
         "substeps: expected an integer in [1, 1000], got 0"},
    };
    for (const Case& c : cases) {
        INFO("scene: " << c.text);
        std::string msg = errorOf(c.text);
        CHECK_THAT(msg, Catch::Contains(c.expected));
        CHECK(msg.find('\n') == std::string::npos);  // one line
    }
}

TEST_CASE("scene_json: a camera's lens in millimetres, on the camera and on its keys", "[io][scene][render]") {
    const SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
      "camera": {"type": "keyframed", "focal_length": 50, "sensor": 24, "keys": [
        {"frame": 1, "eye": [0, 1, 5], "target": [0, 0, 0]},
        {"frame": 12, "eye": [0, 1, 4], "target": [0, 0, 0], "focal_length": 85},
        {"frame": 24, "eye": [5, 1, 0], "target": [0, 0.5, 0], "fov": 20}]}})",
                                   "lens.json");
    REQUIRE(s.camera.lens);
    CHECK(s.camera.lens->focalLengthMm == 50);
    CHECK(s.camera.lens->sensorMm == 24);
    REQUIRE(s.camera.keys.size() == 3);
    REQUIRE(s.camera.keys[0].lens);  // a key without its own takes the camera's lens
    CHECK(s.camera.keys[0].lens->focalLengthMm == 50);
    REQUIRE(s.camera.keys[1].lens);  // its own focal length, the camera's sensor
    CHECK(s.camera.keys[1].lens->focalLengthMm == 85);
    CHECK(s.camera.keys[1].lens->sensorMm == 24);
    CHECK(!s.camera.keys[2].lens);  // a key's fov overrides the camera's lens
    CHECK(s.camera.keys[2].vertical(16.0 / 9) == 20);
    // The closed form: the sensor spans the longer side. 36 mm at 50 mm: 39.60° across a 16:9
    // frame, so 2 atan(0.36 * 9 / 16) = 22.90° vertically; on a portrait frame the sensor is
    // the height: 39.60°.
    const Lens normal{50, 36};
    CHECK(lensVerticalFovDegrees(normal, 16.0 / 9) == Approx(2 * std::atan(0.36 * 9 / 16) * 180 / M_PI));
    CHECK(lensVerticalFovDegrees(normal, 16.0 / 9) == Approx(22.895).margin(1e-3));
    CHECK(lensVerticalFovDegrees(normal, 9.0 / 16) == Approx(39.598).margin(1e-3));
    CHECK(s.camera.vertical(1.0) == Approx(2 * std::atan(0.24) * 180 / M_PI));
}

TEST_CASE("scene_json: keyframed camera and crease angle", "[io][scene][render]") {
    const SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
      "camera": {"type": "keyframed", "fov": 30, "keys": [
        {"frame": 1, "eye": [0, 1, 5], "target": [0, 0, 0]},
        {"frame": 24, "eye": [5, 1, 0], "target": [0, 0.5, 0], "fov": 20}]},
      "render": {"crease_degrees": 60, "shadow_softness": 5, "collider_opacity": 0.3}})",
                                   "k.json");
    REQUIRE(s.camera.type == CameraType::Keyframed);
    REQUIRE(s.camera.keys.size() == 2);
    CHECK(s.camera.keys[0].fovDegrees == 30);  // the camera's fov is the keys' default
    CHECK(s.camera.keys[1].frame == 24);
    CHECK(s.camera.keys[1].target.y() == 0.5);
    CHECK(s.camera.keys[1].fovDegrees == 20);
    CHECK(s.render.creaseDegrees == 60);
    CHECK(s.render.shadowSoftness == 5);
    CHECK(s.render.colliderOpacity == 0.3);
    CHECK(parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}]})", "d.json").render.shadowSoftness == 3);
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "camera": {"type": "keyframed"}})"),
               Catch::Contains("camera.keys: missing"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "camera": {"type": "keyframed",
               "keys": [{"frame": 1, "eye": [0, 5, 0], "target": [0, 0, 0]}]}})"),
               Catch::Contains("camera.keys[0].eye: the view direction must not be parallel to up"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"crease_degrees": 200}})"),
               Catch::Contains("render.crease_degrees"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"shadow_softness": 20}})"),
               Catch::Contains("render.shadow_softness"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"collider_opacity": 1.5}})"),
               Catch::Contains("render.collider_opacity"));
}

TEST_CASE("scene_json: missing, folder and unreadable scene files", "[io][scene]") {
    test::TempDir dir("scene_json");
    CHECK_THROWS_WITH(loadScene(dir.path() / "nope.json"), Catch::Contains("nope.json: no such file"));
    CHECK_THROWS_WITH(loadScene(dir.path()), Catch::Contains("is a folder, not a scene file"));
    std::ofstream(dir.path() / "ok.json") << R"({"objects": [{"primitive": {"type": "box"}}]})";
    CHECK(loadScene(dir.path() / "ok.json").objects.size() == 1);
}

TEST_CASE("scene_json: every shipped scene loads", "[io][scene]") {
    int count = 0;
    for (const auto& entry : fs::directory_iterator(test::sourcePath("scenes"))) {
        if (entry.path().extension() != ".json") continue;
        INFO(entry.path());
        SceneDesc s = loadScene(entry.path());
        CHECK((!s.objects.empty() || s.curves.size() == 2));  // volumes, or the GLN figures' curves
        for (const ObjectDesc& o : s.objects)
            if (!o.isPrimitive) CHECK(fs::exists(o.meshPath));
        ++count;
    }
    CHECK(count >= 2);
}

TEST_CASE("scene_json: curves (the GLN figures) map onto the settings and are validated", "[io][scene][gln]") {
    const SceneDesc s = parseScene(R"({
      "curves": [ { "name": "a", "ring": { "centre": [1, 2, 3], "normal": [0, 0, 2], "radius": 0.5, "segments": 64 },
                    "color": [1, 1, 1], "tube_radius": 0.1 },
                  { "file": "b.txt", "motion": [[1, [0, 0, 0]], [11, [10, 0, 0]]] } ],
      "gln": { "seed_tolerances": [4, 0.5] } })",
                                   "dir/scene.json");
    REQUIRE(s.curves.size() == 2);
    CHECK(s.objects.empty());
    CHECK(s.curves[0].centre == Vec3(1, 2, 3));
    CHECK(s.curves[0].normal == Vec3(0, 0, 1));
    CHECK(s.curves[0].segments == 64);
    CHECK(s.curves[0].tubeRadius == 0.1);
    CHECK(s.curves[0].curvePath.empty());
    CHECK(fs::path(s.curves[1].curvePath).filename() == "b.txt");
    CHECK(s.curves[1].name == "curve1");
    CHECK(s.curves[1].offsetAt(6) == Vec3(5, 0, 0));
    CHECK(s.curves[1].offsetAt(-3) == Vec3(0, 0, 0));
    CHECK(s.curves[1].offsetAt(20) == Vec3(10, 0, 0));
    CHECK(s.gln.seedTolerances == std::vector<Real>{4, 0.5});
    const std::string ring = R"({"ring": {"radius": 1}})";
    const std::pair<std::string, std::string> bad[] = {
        {"{\"curves\": [" + ring + "]}", "curves: expected exactly 2 curves"},
        {"{\"curves\": [" + ring + ", {}]}", "curves[1]: give exactly one of 'file' (a curve file) or 'ring'"},
        {"{\"curves\": [" + ring + R"(, {"ring": {"radius": -1}}]})",
         "curves[1].ring.radius: expected a positive number"},
        {"{\"curves\": [" + ring + R"(, {"ring": {"segments": 2}}]})",
         "curves[1].ring.segments: expected an integer in [3"},
        {"{\"curves\": [" + ring + R"(, {"ring": {}, "motion": [[2, [0, 0, 0]], [1, [1, 1, 1]]]}]})",
         "curves[1].motion[1]: key frames must increase"},
        {"{\"curves\": [" + ring + R"(, {"ring": {}, "motion": [[2, [0, 0]]]}]})",
         "curves[1].motion[0]: expected a [frame, [x, y, z]] key"},
        {"{\"curves\": [" + ring + ", " + ring + R"(], "gln": {"seed_tolerances": [0]}})",
         "gln.seed_tolerances[0]: expected a number in (0"},
        {"{\"curves\": [" + ring + ", " + ring + R"(], "objects": [{"primitive": {"type": "sphere"}}]})",
         "curves: a scene has either objects or curves"},
        {R"({"curves": [{"name": "x", "ring": {}}, {"name": "x", "ring": {}}]})",
         "curves[1].name: duplicate curve name"},
    };
    for (const auto& [text, expected] : bad) {
        INFO(text);
        CHECK_THAT(errorOf(text), Catch::Contains(expected));
    }
}

TEST_CASE("scene_json: material keys map onto the object", "[io][scene]") {
    const SceneDesc s = parseScene(
        R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"density": 500, "damping": 2, "stiffness": 10,
             "max_delta_gamma": 0.1, "volume_tolerance": 2e-6}}]})",
        "dir/scene.json");
    REQUIRE(s.objects.size() == 1);
    const auto& m = s.objects[0].material;
    CHECK(m.density == 500);
    CHECK(m.damping == 2);
    CHECK(m.stiffness == 10);
    CHECK(m.stiffnessFrom == MaterialDesc::StiffnessFrom::Value);
    CHECK(m.wobbles == 0);  // damping given
    CHECK(m.maxDeltaGamma == Approx(0.1));
    CHECK(m.volumeTolerance == Approx(2e-6));
    CHECK(m.yield == 0);  // elastic unless asked
    CHECK(m.pinnedLoad);  // a pinned body sags unless asked not to
    CHECK_FALSE(parseScene(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"pinned_load": false}}]})",
                           "dir/scene.json")
                    .objects[0]
                    .material.pinnedLoad);
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"pinned_load": 1}}]})"),
               Catch::Contains("objects[0].material.pinned_load: expected true or false"));
    const SceneDesc putty =
        parseScene(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"stiffness": 1000, "yield": 0.1}}]})",
                   "dir/scene.json");
    CHECK(putty.objects[0].material.yield == Approx(0.1));
    // goo cannot yield: it has no rest shape
    CHECK_THAT(
        errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"stiffness": 0, "yield": 0.1}}]})"),
        Catch::Contains("objects[0].material.yield: needs a 'stiffness' > 0"));
    CHECK_THAT(
        errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"stiffness": 5, "yield": -1}}]})"),
        Catch::Contains("objects[0].material.yield:"));
}

TEST_CASE("scene_json: a body without material settings is jelly, and the presets, wobble_hz, sag and wobbles",
          "[io][scene]") {
    auto material = [](const std::string& m) {
        return parseScene(R"({"objects": [{"primitive": {"type": "sphere"})" + m + "}]}", "dir/scene.json")
            .objects[0]
            .material;
    };
    const MaterialDesc jelly = material("");
    CHECK(jelly.stiffnessFrom == MaterialDesc::StiffnessFrom::Sag);
    CHECK(jelly.sag == 0.1);
    CHECK(jelly.wobbles == 3);
    CHECK(jelly.yield == 0);
    // k = 5 g/(sag r): a ball of half height 0.5 m at sag 0.1 → 981/s²; twice the size, half the k.
    CHECK(resolvedStiffness(jelly, 0.5) == Approx(981));
    CHECK(resolvedStiffness(jelly, 1.0) == Approx(490.5));
    // damping = √k ln 10/(π wobbles): the amplitude e^(−ζt/2) is a tenth after 3 periods 2π/√k.
    const Real k = 981, zeta = resolvedDamping(jelly, k);
    CHECK(std::exp(-0.5 * zeta * 3 * 2 * 3.141592653589793 / std::sqrt(k)) == Approx(0.1));
    const MaterialDesc goo = material(R"(, "material": {"preset": "goo"})");
    CHECK(resolvedStiffness(goo, 0.5) == 0);
    CHECK(resolvedDamping(goo, 0) == 0);
    CHECK(goo.viscosity == 1);
    const MaterialDesc putty = material(R"(, "material": {"preset": "putty"})");
    CHECK(putty.yield == Approx(0.1));
    CHECK(resolvedStiffness(putty, 0.5) == Approx(981));
    CHECK(putty.wobbles == 1);
    const MaterialDesc hz = material(R"(, "material": {"wobble_hz": 2, "damping": 3})");
    CHECK(resolvedStiffness(hz, 123) == Approx(std::pow(4 * 3.141592653589793, 2)));  // size-independent
    CHECK(resolvedDamping(hz, resolvedStiffness(hz, 1)) == 3);                        // damping given: wobbles off
    CHECK(resolvedStiffness(material(R"(, "material": {"stiffness": 300})"), 0.5) == 300);
    CHECK(material(R"(, "material": {"stiffness": 300})").wobbles == 3);  // the preset's damping rule stays
    CHECK(resolvedStiffness(material(R"(, "material": {"preset": "goo", "sag": 0.2})"), 0.5) == Approx(490.5));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"stiffness": 5, "sag": 0.1}}]})"),
               Catch::Contains("objects[0].material.sag: give one of 'stiffness', 'wobble_hz' and 'sag'"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"damping": 1, "wobbles": 2}}]})"),
               Catch::Contains("objects[0].material.wobbles: give 'damping' or 'wobbles'"));
    CHECK_THAT(
        errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"preset": "goo", "wobbles": 2}}]})"),
        Catch::Contains("objects[0].material.wobbles: needs a stiffness"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"preset": "clay"}}]})"),
               Catch::Contains("objects[0].material.preset"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}, "material": {"wobble_hz": 0}}]})"),
               Catch::Contains("objects[0].material.wobble_hz"));
}

TEST_CASE("scene_json: render.lights reads a rig, the first directional light casting the shadows", "[io][scene][lights]") {
    const SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
      "render": {"lights": [
        {"direction": [1, 2, 0], "color": [1, 1, 1], "intensity": 2},
        {"type": "point", "position": [0, 3, 1], "attach": "camera", "specular": 0, "floor": false},
        {"direction": [0, 1, -1], "shadows": false}]}})",
                                   "d.json");
    REQUIRE(s.render.lights.size() == 3);
    const Light& key = s.render.lights[0];
    CHECK(key.type == Light::Type::Directional);
    CHECK(key.shadows);
    CHECK_FALSE(key.cameraRelative);
    CHECK(key.colour.isApprox(Vec3::Constant(2)));
    CHECK(key.shininess == 32);
    const Light& point = s.render.lights[1];
    CHECK(point.type == Light::Type::Point);
    CHECK(point.vector.isApprox(Vec3(0, 3, 1)));
    CHECK(point.cameraRelative);
    CHECK_FALSE(point.shadows);
    CHECK(point.shininess == 0);
    CHECK_FALSE(point.floor);
    CHECK_FALSE(s.render.lights[2].shadows);
    CHECK(parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}]})", "d.json").render.lights.empty());

    auto lights = [](const std::string& list) {
        return errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"lights": )" + list + "}}");
    };
    CHECK_THAT(lights(R"([{"type": "point", "position": [0, 1, 0], "shadows": true}])"),
               Catch::Contains("render.lights[0].shadows") && Catch::Contains("only a directional light"));
    CHECK_THAT(lights(R"([{"direction": [0, 1, 0]}, {"direction": [1, 1, 0], "shadows": true}])"),
               Catch::Contains("render.lights[1].shadows") && Catch::Contains("lights[0] already does"));
    CHECK_THAT(lights(R"([{"direction": [0, -1, 0]}])"), Catch::Contains("must shine from above"));
    CHECK_THAT(lights(R"([{"type": "point", "direction": [0, 1, 0]}])"), Catch::Contains("'position', not a direction"));
    CHECK_THAT(lights(R"([{"type": "point"}])"), Catch::Contains("render.lights[0].position") && Catch::Contains("missing"));
    CHECK_THAT(lights(R"([{"direction": [0, 0, 0]}])"), Catch::Contains("must not be [0, 0, 0]"));
    CHECK_THAT(lights("[]"), Catch::Contains("at least one light"));
    CHECK_THAT(lights(R"([{"direction": [0, 1, 0], "attach": "camra"}])"), Catch::Contains("render.lights[0].attach"));
}

TEST_CASE("scene_json: render.motion_blur reads true, false or a shutter and samples, and refuses the rest",
          "[io][scene][motion_blur]") {
    auto blur = [](const std::string& value) {
        return parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"motion_blur": )" + value + "}}",
                          "d.json")
            .render;
    };
    const RenderDesc off = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}]})", "d.json").render;
    CHECK_FALSE(off.motionBlur);
    CHECK(blur("true").motionBlur);
    CHECK(blur("true").motionBlurShutter == 180);
    CHECK(blur("true").motionBlurSamples == 8);
    CHECK_FALSE(blur("false").motionBlur);
    const RenderDesc set = blur(R"({"shutter": 90, "samples": 16})");
    CHECK(set.motionBlur);
    CHECK(set.motionBlurShutter == 90);
    CHECK(set.motionBlurSamples == 16);
    auto error = [](const std::string& value) {
        return errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"motion_blur": )" + value + "}}");
    };
    CHECK_THAT(error(R"({"shutter": 0})"), Catch::Contains("render.motion_blur.shutter"));
    CHECK_THAT(error(R"({"shutter": 400})"), Catch::Contains("render.motion_blur.shutter"));
    CHECK_THAT(error(R"({"samples": 1})"), Catch::Contains("render.motion_blur.samples"));
    CHECK_THAT(error(R"({"samples": 65})"), Catch::Contains("render.motion_blur.samples"));
    CHECK_THAT(error(R"({"shuter": 90})"), Catch::Contains("render.motion_blur.shuter") && Catch::Contains("shutter"));
    CHECK_THAT(error("180"), Catch::Contains("render.motion_blur: expected true, false or an object"));
}

TEST_CASE("scene_json: render.environment reads a colour, a sky or an image, and refuses the rest by name",
          "[io][scene][environment]") {
    test::TempDir dir("scene_environment");
    Image img(4, 2);
    for (std::uint16_t& v : img.rgba) v = 65535;
    writePng(dir.path() / "env.png", img);
    auto scene = [&](const std::string& env) {
        const fs::path p = dir.path() / "s.json";
        std::ofstream(p) << R"({"objects": [{"primitive": {"type": "sphere"}}], "render": {"environment": )" + env + "}}";
        return loadScene(p.string());
    };
    CHECK(scene(R"({"color": [1, 1, 1]})").render.environment == RenderDesc::Environment::Colour);
    const RenderDesc sky = scene(R"({"sky": [1, 1, 1], "ground": [0, 0, 0], "intensity": 2})").render;
    CHECK(sky.environment == RenderDesc::Environment::Sky);
    CHECK(sky.environmentIntensity == 2);
    const RenderDesc image = scene(R"({"image": "env.png", "rotation": 90})").render;
    CHECK(image.environment == RenderDesc::Environment::Image);
    CHECK(image.environmentWidth == 4);
    CHECK(image.environmentHeight == 2);
    REQUIRE(image.environmentPixels);
    CHECK((*image.environmentPixels)[0].isApprox(Vec3::Ones()));
    auto error = [&](const std::string& env) {
        try {
            scene(env);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    CHECK_THAT(error(R"({"image": "none.hdr"})"), Catch::Contains("render.environment.image") && Catch::Contains("no such file"));
    CHECK_THAT(error(R"({"color": [1, 1, 1], "sky": [1, 1, 1]})"), Catch::Contains("render.environment: give one of"));
    CHECK_THAT(error(R"({"ground": [1, 1, 1], "color": [1, 1, 1]})"), Catch::Contains("render.environment.ground"));
    CHECK_THAT(error(R"({"color": [1, 1, 1], "rotation": 3})"), Catch::Contains("render.environment.rotation"));
    CHECK_THAT(error(R"({"color": [1, 1, 1], "intensity": -1})"), Catch::Contains("render.environment.intensity"));
}

TEST_CASE("scene_json: a plane collider reads its point, normal and drawn size", "[io][scene][collider]") {
    const SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
      "colliders": [{"type": "plane", "point": [1, 0, 0], "normal": [-2, 0, 0], "size": 3}]})",
                                   "d.json");
    REQUIRE(s.colliders.size() == 1);
    CHECK(s.colliders[0].type == ColliderType::Plane);
    CHECK(s.colliders[0].centre == Vec3(1, 0, 0));
    CHECK(s.colliders[0].normal.isApprox(Vec3(-1, 0, 0)));
    CHECK(s.colliders[0].size == 3);
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}], "colliders": [{"type": "plane"}]})"),
               Catch::Contains("colliders[0].normal: missing"));
    CHECK_THAT(errorOf(R"({"objects": [{"primitive": {"type": "sphere"}}],
                          "colliders": [{"type": "plane", "normal": [0, 0, 0]}]})"),
               Catch::Contains("colliders[0].normal"));
}
