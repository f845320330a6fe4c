// FrameView (view/frame_view.hpp): what a render draws of the simulation's state, checked on the
// frame scene itself (no GL context): a ball on the ground highlighted where it touches, and the
// ground marked under it; the objects, colliders, dots and pins in their places.

#include "view/frame_view.hpp"

#include "dynamics/lattices.hpp"
#include "geom/embedding.hpp"
#include "geom/geometric_state.hpp"
#include "sim/body_contact.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace dgv;

namespace {

// A ball of 4 voxels' radius (h = 0.05 m) drawn with its own lattice surface as the mesh (every
// vertex on a lattice point), its lowest points `lift` above the ground.
struct DrawnBall {
    static constexpr Real h = 0.05;
    Lattice lat;
    TriangleMesh mesh;
    MeshEmbedding emb;
    GeometricState state;
    explicit DrawnBall(Real lift) : lat(test::sphereLattice(4, h, Vec3(-4 * h, lift, -4 * h))) {
        Real lowest = 1e9;
        for (const Vec3& x : restPositions(lat)) lowest = std::min(lowest, x.y());
        lat = test::sphereLattice(4, h, Vec3(-4 * h, 2 * lift - lowest, -4 * h));
        mesh = latticeSurface(lat, restPositions(lat));
        emb = embedVertices(lat, mesh.vertices);
        computeGeometricState(lat, restPositions(lat), state);
    }
    ViewObject object() const { return {&mesh, &lat, &emb, &state, Vec3(0.2, 0.4, 0.9)}; }
};

SceneDesc groundScene() {
    SceneDesc scene;
    ColliderDesc ground;
    ground.type = ColliderType::Ground;
    ground.height = 0;
    scene.colliders.push_back(ground);
    return scene;
}

}  // namespace

TEST_CASE("view: a ball landing on the ground is highlighted where it touches and marks the ground under it",
          "[view][contact]") {
    const DrawnBall ball(0.01);
    DynamicsSettings set;
    set.shapeStiffness = 300;
    set.damping = 2;
    DeformableBody body(ball.lat, restPositions(ball.lat), set);
    body.setAffineVelocity(Vec3(0, -1, 0), Mat3::Zero());
    const ForceField g = test::gravityField();
    const std::vector<Collider> colliders = {test::groundPlane()};
    int steps = 0;
    while (steps < 96 && std::count(body.contact().begin(), body.contact().end(), 1) == 0) {
        REQUIRE(body.step(g, 1, 1.0 / 96, colliders).fault.empty());
        ++steps;
    }
    REQUIRE(std::count(body.contact().begin(), body.contact().end(), 1) > 0);
    ContactHistory history;
    history.observe(body.contact());

    SceneDesc scene = groundScene();
    scene.render.contactMode = ContactHighlightMode::Depth;
    FrameView view(scene, {ball.object()}, {});
    const Camera camera;
    const FrameScene& frame = view.update({{&body, &ball.mesh, &ball.emb, &history.age()}}, camera);

    REQUIRE(frame.meshes.size() == 1);
    REQUIRE(frame.groundHeight.has_value());
    CHECK(*frame.groundHeight == 0);
    // The drawn vertices are the body's lattice points now (the mesh's vertices lie on them).
    const DrawMesh& m = frame.meshes[0];
    std::vector<Vec3> expected;
    deformVertices(ball.emb, body.state(), expected);
    REQUIRE(m.positions.size() == expected.size());
    for (std::size_t v = 0; v < expected.size(); ++v) CHECK((m.positions[v] - expected[v]).norm() == 0);
    // Highlighted (scalar > 0): only the bottom, within the spread and smoothing's reach of the
    // points in R (all on the ground), and some of it.
    REQUIRE(m.scalar.size() == m.positions.size());
    Real lowest = 1e9, highestLit = -1e9;
    int lit = 0;
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        lowest = std::min(lowest, m.positions[v].y());
        if (m.scalar[v] > 0) {
            ++lit;
            highestLit = std::max(highestLit, m.positions[v].y());
        }
    }
    CHECK(lit > 0);
    CHECK(highestLit < lowest + (2 + scene.render.contactSpread) * DrawnBall::h);
    CHECK(m.ramp.high == contrastingHighlight(ball.object().colour).high);
    // The ground is marked under the ball (its footprint), each mark at a point in R.
    REQUIRE(!frame.groundMarks.empty());
    for (const GroundMark& mark : frame.groundMarks) {
        CHECK(std::hypot(mark.x, mark.z) <= 4.5 * DrawnBall::h);
        CHECK(mark.colour == m.ramp.high);
    }
    // Off: neither.
    scene.render.contactMode = ContactHighlightMode::Off;
    FrameView plain(scene, {ball.object()}, {});
    const FrameScene& off = plain.update({{&body, &ball.mesh, &ball.emb, &history.age()}}, camera);
    CHECK(off.groundMarks.empty());
    CHECK(std::none_of(off.meshes[0].scalar.begin(), off.meshes[0].scalar.end(), [](Real s) { return s > 0; }));
}

TEST_CASE("view: objects, then colliders framed with them, then lattice dots and pins per object", "[view][overlay]") {
    const DrawnBall ball(0.3);
    SceneDesc scene = groundScene();
    scene.render.colliderOpacity = 0.5;
    scene.render.overlayLattice = true;
    scene.render.overlayLatticeSet = LatticeDotSet::All;
    scene.render.pins = true;
    DrawMesh collider;
    collider.positions = {Vec3(2, 0, 0), Vec3(3, 0, 0), Vec3(2, 1, 0)};
    collider.triangles = {{0, 1, 2}};
    FrameView view(scene, {ball.object()}, {collider});
    // Framed: the ball at rest and the collider.
    CHECK(view.bounds().max.x() == 3);
    CHECK(view.bounds().min.x() == Approx(-4 * DrawnBall::h).margin(1e-12));
    const FrameScene& frame = view.update({ViewBody{}}, Camera());
    REQUIRE(frame.meshes.size() == 2);
    CHECK(frame.meshes[0].triangles == ball.mesh.triangles);
    CHECK(frame.meshes[1].opacity == 0.5);  // render.collider_opacity
    CHECK(frame.meshes[1].positions == collider.positions);
    // Dots: every lattice point of the object at rest ("all"), then its pin set (none at rest).
    REQUIRE(frame.points.size() == 2);
    CHECK(frame.points[0].points == restPositions(ball.lat));
    CHECK(frame.points[1].points.empty());
    CHECK(frame.points[1].colour == scene.render.pinColour);
}

TEST_CASE("view: the floor of a moving shot without a ground collider does not follow the bodies", "[view]") {
    // A floor under each frame's lowest point followed floating goo, as if it slid on a table.
    const DrawnBall ball(0.3);
    ObjectDesc moving;
    moving.velocity = Vec3(0, 0, 1);
    SceneDesc still;  // no forces, no motion: a turntable's studio floor under the meshes, as before
    still.objects.push_back(ObjectDesc());
    {
        FrameView view(still, {ball.object()}, {});
        const FrameScene& frame = view.update({ViewBody{}}, Camera());
        CHECK(frame.groundPlane);
        CHECK(!frame.groundHeight);
    }
    SceneDesc floating;  // moving, no ground collider: no floor
    floating.objects.push_back(moving);
    {
        FrameView view(floating, {ball.object()}, {});
        const FrameScene& frame = view.update({ViewBody{}}, Camera());
        CHECK(!frame.groundPlane);
    }
    // render.ground set: a floor fixed for the whole shot under the shapes at rest.
    floating.render.ground = true;
    floating.render.groundGiven = true;
    {
        FrameView view(floating, {ball.object()}, {});
        const FrameScene& frame = view.update({ViewBody{}}, Camera());
        CHECK(frame.groundPlane);
        REQUIRE(frame.groundHeight);
        CHECK(*frame.groundHeight == Approx(view.bounds().min.y()));
        CHECK(*frame.groundHeight == Approx(0.3).margin(1e-12));  // the ball's lowest point at rest
    }
    // A ground collider: the floor at its height, moving or not.
    SceneDesc grounded = groundScene();
    grounded.objects.push_back(moving);
    {
        FrameView view(grounded, {ball.object()}, {});
        const FrameScene& frame = view.update({ViewBody{}}, Camera());
        CHECK(frame.groundPlane);
        REQUIRE(frame.groundHeight);
        CHECK(*frame.groundHeight == 0);
    }
}
