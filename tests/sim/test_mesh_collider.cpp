// Mesh colliders (scene collider type "mesh"): the mesh is imported when the scene is loaded and
// turned into a signed-distance grid (io/vdb_read.hpp, meshLevelSet). Checked: the distance and
// gradient of a torus mesh against the torus's closed form, outside near the surface and deep
// inside; a ball dropped on a box mesh rests where it rests on the analytic ground; bad meshes
// and settings are one-line input errors.

#include "base/errors.hpp"
#include "geom/primitives.hpp"
#include "io/scene_json.hpp"
#include "sim/levelset_collider.hpp"
#include "sim/simulation.hpp"
#include "support/helpers.hpp"
#include "dynamics/lattices.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

void writeObj(const fs::path& p, const TriangleMesh& m, bool flip = false) {
    std::ofstream f(p);
    for (const Vec3& v : m.vertices) f << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const auto& t : m.triangles)
        f << "f " << t[0] + 1 << ' ' << (flip ? t[2] : t[1]) + 1 << ' ' << (flip ? t[1] : t[2]) + 1 << '\n';
}

std::string problemOf(const std::string& json, const fs::path& file) {
    try {
        parseScene(json, file);
    } catch (const InputError& e) {
        CHECK(std::string(e.what()).find('\n') == std::string::npos);
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST_CASE("mesh collider: the distance to a torus mesh is the torus's, outside and deep inside",
          "[io][vdb][meshcollider]") {
    test::TempDir dir("mesh-collider-torus");
    const Real R = 0.5, r = 0.15;
    const int major = 192, minor = 96;
    writeObj(dir.path() / "torus.obj", makeTorus(R, r, major, minor));
    // Placed by the collider's transform: up 0.6 and turned 90 degrees about x (its hole along z).
    const SceneDesc s = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
        "colliders": [{"type": "mesh", "mesh": "torus.obj", "transform": {"translate": [0, 0.6, 0], "rotate": [90, 0, 0]}}]})",
                                   dir.path() / "s.json");
    REQUIRE(s.colliders.size() == 1);
    const ColliderDesc& c = s.colliders[0];
    REQUIRE(c.levelSet);
    REQUIRE(c.worldMesh);
    const Real h = c.levelSet->spacing;
    CHECK(h == Approx(2 * (R + r) / 128));                           // the default voxel: the longest edge / 128
    const auto phi = levelSetDistance(c.levelSet, TransformDesc{});  // already in world space
    // The closed form in the torus's own frame (y = its axis): p = Rx(-90°)(x - (0, 0.6, 0)).
    auto exact = [&](const Vec3& x, Vec3* grad) {
        const Vec3 d = x - Vec3(0, 0.6, 0);
        const Vec3 p(d.x(), -d.z(), d.y());  // rotate by -90 degrees about x: (x, y, z) -> (x, z, -y) inverse
        const Real q = std::hypot(p.x(), p.z());
        const Vec3 toTube = Vec3(p.x() * (1 - R / q), p.y(), p.z() * (1 - R / q));
        if (grad) {
            const Vec3 gp = toTube.normalized();
            *grad = Vec3(gp.x(), gp.z(), -gp.y());
        }
        return toTube.norm() - r;
    };
    // Error budget: the polygon lies inside the true torus by at most its sag, r (1 - cos(pi/minor))
    // + R (1 - cos(pi/major)) = 1.2e-4; trilinear interpolation of a distance field bending with
    // radius >= r - |phi| adds at most h^2 / (8 (r - 3h)) = 1.5e-4 for h = 0.0102, float samples 1e-7.
    const Real bound =
        r * (1 - std::cos(M_PI / minor)) + R * (1 - std::cos(M_PI / major)) + h * h / (8 * (r - 3 * h)) + 1e-6;
    // Near the surface (|phi| < h: the 8 samples around the point are within the 3-voxel
    // exterior band, not clamped) the field is the polygon's exact distance, interpolated. Deeper
    // inside, OpenVDB fills the interior by a sweep that is not exact: there only the sign, the
    // size within 5 % and the direction back out are asserted.
    std::mt19937 rng(7);
    std::uniform_real_distribution<Real> u(-1, 1);
    Real worstNear = 0, worstGrad = 0, worstDeep = 0, worstDeepGrad = 0;
    int near = 0, deep = 0;
    while (near < 400 || deep < 400) {
        const Vec3 x = Vec3(0, 0.6, 0) + Vec3(u(rng) * 0.7, u(rng) * 0.7, u(rng) * 0.2);
        Vec3 ge;
        const Real d = exact(x, &ge);
        Vec3 g;
        const Real p = phi(x, &g);
        if (std::abs(d) < h && near < 400) {
            ++near;
            worstNear = std::max(worstNear, std::abs(p - d));
            worstGrad = std::max(worstGrad, (g.normalized() - ge).norm());
        } else if (d < -3 * h && d > -0.8 * r && deep < 400) {
            ++deep;
            worstDeep = std::max(worstDeep, std::abs(p / d - 1));
            worstDeepGrad = std::max(worstDeepGrad, (g.normalized() - ge).norm());
        }
    }
    INFO("voxel " << h << ", bound " << bound << ": worst near the surface " << worstNear << " (gradient direction "
                  << worstGrad << "), deep inside relative " << worstDeep << " (gradient direction " << worstDeepGrad
                  << ")");
    CHECK(worstNear < bound);
    // the direction of a trilinear field's gradient is off by up to about h / (2 (r - h)) = 0.04
    CHECK(worstGrad < 0.05);
    CHECK(worstDeep < 0.05);
    CHECK(worstDeepGrad < 0.25);
    // The deepest point, the tube's centre line, is inside by about r.
    CHECK(phi(Vec3(R, 0.6, 0), nullptr) == Approx(-r).epsilon(0.05));
    // The drawn mesh is the transformed one.
    const Box3 b = [&] {
        Box3 bb;
        for (const Vec3& v : c.worldMesh->vertices) bb.extend(v);
        return bb;
    }();
    CHECK(b.max.y() == Approx(0.6 + R + r).margin(1e-9));
    CHECK(b.max.z() == Approx(r).margin(1e-9));
}

TEST_CASE("mesh collider: a ball dropped on a box mesh rests where it rests on the ground",
          "[io][vdb][meshcollider][sim]") {
    test::TempDir dir("mesh-collider-drop");
    TriangleMesh slab = makeBox(Vec3(2, 0.5, 2));
    for (Vec3& v : slab.vertices) v.y() -= 0.25;  // top face at y = 0
    writeObj(dir.path() / "slab.obj", slab);
    auto drop = [&](const std::string& collider) {
        const SceneDesc scene = parseScene(R"({"frames": {"start": 1, "end": 16, "fps": 24}, "substeps": 4,
            "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.3}, "velocity": [0, -1.5, 0],
                         "material": {"damping": 2}}],
            "forces": [{"type": "gravity"}], "colliders": [)" +
                                               collider + "]}",
                                           dir.path() / "s.json");
        const Lattice lat = test::sphereLattice(6, 0.05, Vec3(-0.3, 0.02, -0.3));
        Simulation sim(scene, {&lat});
        REQUIRE(sim.active());
        for (int f = 2; f <= 10; ++f) sim.advanceTo(f);
        Real minY = HUGE_VAL, meanY = 0;
        for (const Vec3& p : sim.body(0)->positions()) {
            minY = std::min(minY, p.y());
            meanY += p.y() / static_cast<Real>(sim.body(0)->positions().size());
        }
        return std::make_pair(minY, meanY);
    };
    const auto ground = drop(R"({"type": "ground", "height": 0})");
    const auto mesh = drop(R"({"type": "mesh", "mesh": "slab.obj", "voxel_size": 0.025})");
    INFO("ground: min y " << ground.first << ", mean y " << ground.second << "; mesh: min y " << mesh.first
                          << ", mean y " << mesh.second);
    // On the flat top the distance field is linear, so exact up to float samples: within a
    // hundredth of the level set's voxel of the analytic ground.
    CHECK(std::abs(mesh.first - ground.first) < 2.5e-4);
    CHECK(std::abs(mesh.second - ground.second) < 2.5e-4);
    CHECK(mesh.first > -2.5e-4);
}

TEST_CASE("mesh collider: bad meshes and settings are one-line input errors", "[io][meshcollider][slow][sanitize]") {
    test::TempDir dir("mesh-collider-bad");
    writeObj(dir.path() / "box.obj", makeBox(Vec3(1, 1, 1)));
    writeObj(dir.path() / "flipped.obj", makeBox(Vec3(1, 1, 1)), true);
    std::ofstream(dir.path() / "open.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n";
    const fs::path file = dir.path() / "s.json";
    auto scene = [](const std::string& collider) {
        return R"({"objects": [{"primitive": {"type": "sphere"}}], "colliders": [)" + collider + "]}";
    };
    CHECK(problemOf(scene(R"({"type": "mesh", "mesh": "box.obj"})"), file) == "no error");
    CHECK_THAT(problemOf(scene(R"({"type": "mesh"})"), file),
               Catch::Contains("colliders[0].mesh") && Catch::Contains("missing"));
    CHECK_THAT(problemOf(scene(R"({"type": "mesh", "mesh": "absent.obj"})"), file),
               Catch::Contains("colliders[0].mesh") && Catch::Contains("absent.obj") && Catch::Contains("not found"));
    CHECK_THAT(problemOf(scene(R"({"type": "mesh", "mesh": "open.obj"})"), file),
               Catch::Contains("open.obj") && Catch::Contains("must be closed") && Catch::Contains("3 open edges"));
    // An inside-out mesh is turned around on import (with a warning), and collides as the box does.
    CHECK(problemOf(scene(R"({"type": "mesh", "mesh": "flipped.obj"})"), file) == "no error");
    CHECK_THAT(problemOf(scene(R"({"type": "mesh", "mesh": "box.obj", "transform": {"scale": [1, 0, 1]}})"), file),
               Catch::Contains("colliders[0].transform") && Catch::Contains("zero scale"));
    CHECK_THAT(problemOf(scene(R"({"type": "mesh", "mesh": "box.obj", "voxel_size": -1})"), file),
               Catch::Contains("colliders[0].voxel_size"));
    CHECK_THAT(problemOf(scene(R"({"type": "mesh", "mesh": "box.obj", "voxel_size": 1e-5})"), file),
               Catch::Contains("box.obj") && Catch::Contains("larger voxel_size"));
}
