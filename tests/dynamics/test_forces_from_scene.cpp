// Tests of the scene's forces as the field (src/sim/forces_from_scene.hpp): every scene force
// type and key reaches the field's terms, keyframed strength interpolates the file's keys, and
// the field of a scene equals the sum of its terms.
#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "io/scene_json.hpp"
#include "sim/forces_from_scene.hpp"

#include <cmath>

using namespace dgv;

namespace {

const char* kScene = R"({
  "objects": [ { "primitive": { "type": "sphere" } } ],
  "forces": [
    { "type": "gravity", "direction": [0, 0, -2], "strength": 4 },
    { "type": "attractor", "position": [1, 0, 0], "radius": 2, "softening": 0.3, "falloff": 1,
      "strength": [[1, 0], [11, -5]] },
    { "type": "vortex", "position": [0, 1, 0], "axis": [1, 1, 0], "radius": 0.5, "falloff": 2, "strength": 3 },
    { "type": "burst", "position": [0, 0, 1], "radius": 0.7, "strength": [[10, 0], [11, 40], [14, 0]] },
    { "type": "wind", "direction": [0, 1, 0], "strength": 2, "turbulence": 0.5, "scale": 0.4, "seed": 12, "modes": 20 }
  ]
})";

}  // namespace

TEST_CASE("forces_from_scene: every key of every force type reaches the field", "[dynamics][forces][scene]") {
    const SceneDesc s = parseScene(kScene, "dir/forces.json");
    REQUIRE(s.forces.size() == 5);
    const ForceField f = forceFieldFromScene(s.forces);
    REQUIRE(f.terms().size() == 5);
    const auto& t = f.terms();
    CHECK(t[0].kind == ForceKind::Gravity);
    CHECK((t[0].direction - Vec3(0, 0, -1)).norm() < 1e-15);
    CHECK(t[1].kind == ForceKind::Attractor);
    CHECK(t[1].centre == Vec3(1, 0, 0));
    CHECK(t[1].radius == 2);
    CHECK(t[1].softening == 0.3);
    CHECK(t[1].falloff == 1);
    CHECK(t[2].kind == ForceKind::Vortex);
    CHECK((t[2].axis - Vec3(1, 1, 0).normalized()).norm() < 1e-15);
    CHECK(t[2].falloff == 2);
    CHECK(t[3].kind == ForceKind::Burst);
    CHECK(t[3].radius == 0.7);
    CHECK(t[4].kind == ForceKind::Wind);
    CHECK(t[4].turbulence == 0.5);
    CHECK(t[4].scale == 0.4);
    CHECK(t[4].seed == 12u);
    CHECK(t[4].modes == 20);

    // Strength: the file's keys, linear between them and held outside, at integer and
    // fractional (substep) frames; a single number is constant.
    for (Real frame : {0.0, 1.0, 3.25, 10.0, 10.5, 11.0, 12.75, 14.0, 100.0}) {
        CHECK(t[0].strength.at(frame) == 4);
        CHECK(t[2].strength.at(frame) == 3);
        CHECK(t[4].strength.at(frame) == 2);
    }
    CHECK(t[1].strength.at(0) == 0);
    CHECK(t[1].strength.at(3.25) == Approx(-1.125).epsilon(1e-15));
    CHECK(t[1].strength.at(11) == -5);
    CHECK(t[1].strength.at(100) == -5);
    CHECK(t[3].strength.at(9) == 0);
    CHECK(t[3].strength.at(10.5) == Approx(20).epsilon(1e-15));
    CHECK(t[3].strength.at(12.5) == Approx(20).epsilon(1e-15));
    CHECK(t[3].strength.at(14) == 0);

    // The defaults the parser fills in: softening = radius/4, attractor falloff 2, vortex 1.
    const SceneDesc d = parseScene(R"({"objects": [{"primitive": {"type": "sphere"}}],
        "forces": [{"type": "attractor", "radius": 2}, {"type": "vortex"}]})",
                                   "d.json");
    const ForceField fd = forceFieldFromScene(d.forces);
    CHECK(fd.terms()[0].softening == 0.5);
    CHECK(fd.terms()[0].falloff == 2);
    CHECK(fd.terms()[1].falloff == 1);
}

TEST_CASE("forces_from_scene: the scene's field is the sum of its forces at every frame", "[dynamics][forces][scene]") {
    const SceneDesc s = parseScene(kScene, "dir/forces.json");
    const ForceField all = forceFieldFromScene(s.forces);
    const Vec3 x(0.4, 0.3, 0.6);
    for (Real frame : {1.0, 6.0, 10.5, 12.0}) {
        Vec3 sum = Vec3::Zero();
        Mat3 grad = Mat3::Zero();
        for (const ForceTerm& d : s.forces) {
            ForceField one;
            one.add(d);
            const ForceSample v = one.sample(x, frame);
            sum += v.value;
            grad += v.gradient;
        }
        const ForceSample a = all.sample(x, frame);
        CHECK((a.value - sum).norm() <= 1e-14 * (1 + sum.norm()));
        CHECK((a.gradient - grad).norm() <= 1e-14 * (1 + grad.norm()));
    }
    // The burst fires between frames 10 and 14 only.
    ForceField burst;
    burst.add(s.forces[3]);
    CHECK(burst.value(x, 9).norm() == 0);
    CHECK(burst.value(x, 11).norm() > 1);
    CHECK(burst.value(x, 15).norm() == 0);
    CHECK(forceFieldFromScene({}).empty());
}

TEST_CASE("forces_from_scene: a force the parser did not validate is reported by scene path",
          "[dynamics][forces][scene]") {
    ForceTerm d;
    d.kind = ForceKind::Attractor;
    d.softening = 0;
    try {
        forceFieldFromScene({ForceTerm{}, d}, "a.json");
        FAIL("no error");
    } catch (const InputError& e) {
        CHECK(std::string(e.what()) == "a.json: forces[1].softening: expected a positive number, got 0");
    }
}
