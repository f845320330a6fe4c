// Contact between deformable objects (src/sim/body_contact.hpp, scene key collision.objects):
// the deformed lattice surface each object is to the others, and two jelly balls thrown at each
// other, which squash, bounce apart and never pass into each other.
#include <catch2/catch.hpp>

#include "dynamics/lattices.hpp"
#include "e2e/e2e_run.hpp"
#include "geom/lattice.hpp"
#include "io/scene_json.hpp"
#include "sim/body_contact.hpp"
#include "sim/simulation.hpp"
#include "support/helpers.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <utility>

using namespace dgv;

namespace {

/// Signed volume enclosed by a triangle mesh (divergence theorem): positive when the
/// triangles run counter-clockwise seen from outside.
Real enclosedVolume(const TriangleMesh& m) {
    Real v = 0;
    for (const auto& t : m.triangles) v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]])) / 6;
    return v;
}

}  // namespace

TEST_CASE("body contact: a lattice's surface is closed, outward and encloses its cells", "[collide][body]") {
    // 4 x 3 x 3 points: 3 x 2 x 2 complete cells, plus one loose point that belongs to no cell.
    const Vec3i dims(5, 3, 3);
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 4; ++i) mask[static_cast<std::size_t>(i + 5 * (j + 3 * k))] = 1;
    mask[static_cast<std::size_t>(4 + 5 * (1 + 3 * 1))] = 1;  // (4, 1, 1): no complete cell
    const Real h = 0.1;
    const Lattice lat = buildLattice(Vec3(1, 2, 3), h, dims, mask);
    std::vector<Vec3> x = restPositions(lat);
    TriangleMesh s = latticeSurface(lat, x);
    // Faces: 2 (2 x 2 ends) + 2 (3 x 2) + 2 (3 x 2) = 8 + 12 + 12 = 32, two triangles each.
    REQUIRE(s.triangles.size() == 64);
    REQUIRE(s.vertices.size() == std::size_t(4 * 3 * 3 - 2));  // all points but the cube's two centre ones
    CHECK(enclosedVolume(s) == Approx(12 * h * h * h).epsilon(1e-12));
    // Closed and consistently oriented: every directed edge appears once, its reverse once.
    std::map<std::pair<int, int>, int> edges;
    for (const auto& t : s.triangles)
        for (int e = 0; e < 3; ++e) ++edges[{t[e], t[(e + 1) % 3]}];
    for (const auto& [e, count] : edges) {
        CHECK(count == 1);
        CHECK(edges.count({e.second, e.first}) == 1);
    }
    // It follows the deformed positions: a shear and a stretch of 2 along x (volume x 2).
    for (Vec3& p : x) p = Vec3(2 * p.x() + 0.3 * p.y(), p.y(), p.z());
    s = latticeSurface(lat, x);
    CHECK(enclosedVolume(s) == Approx(24 * h * h * h).epsilon(1e-12));
}

namespace {

/// Two jelly balls (0.3 m, 16 voxels across) 1 m apart, thrown at each other at 1.2 m/s each,
/// no gravity; `collision` is the scene's collision object.
void writeBlobs(const std::filesystem::path& dir, const std::string& collision) {
    std::ofstream(dir / "blobs.json")
        << R"({ "name": "blobs", "frames": { "start": 1, "end": 24, "fps": 24 }, "substeps": 4,
  "objects": [
    { "name": "left", "primitive": { "type": "sphere", "radius": 0.3 }, "resolution": 16,
      "transform": { "translate": [-0.5, 0.4, 0] }, "material": { "damping": 2, "stiffness": 100 },
      "velocity": [1.2, 0, 0] },
    { "name": "right", "primitive": { "type": "sphere", "radius": 0.3 }, "resolution": 16,
      "transform": { "translate": [0.5, 0.45, 0] }, "material": { "damping": 2, "stiffness": 100 },
      "velocity": [-1.2, 0, 0] } ],
  "collision": )"
        << collision << R"( })";
}

}  // namespace

TEST_CASE("body contact: two jelly balls thrown at each other squash, bounce apart and never interpenetrate",
          "[collide][body][e2e][slow]") {
    test::TempDir dir("blobs");
    // Without contact between objects they pass through each other: kinetic energy unchanged.
    writeBlobs(dir.path(), R"({ "objects": false })");
    REQUIRE(e2e::runDgvIn(dir.path(), "-q simulate blobs.json --out off").exitCode == 0);
    const auto off = e2e::readStatsCsv(dir.path() / "off" / "stats.csv");
    REQUIRE(off.size() == 24);
    const Real ke0 = off.front().at("kinetic_energy");
    for (const auto& row : off) CHECK(row.at("kinetic_energy") == Approx(ke0).epsilon(1e-6));
    // sdf and gln with the default exact distance to the other body's surface; "grid": the sdf
    // detection with that distance sampled on a grid (collide/sampled_distance).
    for (const std::string detect : {"sdf", "gln", "grid"}) {
        INFO(detect);
        writeBlobs(dir.path(), detect == "grid" ? std::string(R"({ "restitution": 0.3, "distance": "grid" })")
                                                : R"({ "restitution": 0.3, "detect": ")" + detect + R"(" })");
        const e2e::Run run = e2e::runDgvIn(dir.path(), "-q simulate blobs.json --out " + detect);
        REQUIRE(run.exitCode == 0);
        const auto rows = e2e::readStatsCsv(dir.path() / detect / "stats.csv");
        REQUIRE(rows.size() == 24);
        Real lowest = ke0, maxPen = 0, maxErr = 0, maxDrift = 0;
        int lowestFrame = 0, contactFrames = 0;
        for (const auto& row : rows) {
            if (row.at("kinetic_energy") < lowest)
                lowest = row.at("kinetic_energy"), lowestFrame = int(row.at("frame"));
            maxPen = std::max(maxPen, row.at("max_penetration"));
            maxErr = std::max(maxErr, row.at("max_cell_volume_error"));
            maxDrift = std::max(maxDrift, std::abs(row.at("total_volume_drift")));
            contactFrames += row.at("contacts") > 0 ? 1 : 0;
            CHECK(row.at("inverted_cells") == 0);
        }
        const Real last = rows.back().at("kinetic_energy");
        // The balls meet after ~0.17 s (frame 5) and stop each other: nearly all the motion goes
        // into the squash, then the shape memory and the restitution push them apart again.
        CHECK(lowest < 0.05 * ke0);
        CHECK(lowestFrame > 5);
        CHECK(lowestFrame < 16);
        CHECK(last > 0.2 * ke0);
        CHECK(last < ke0);
        CHECK(contactFrames >= 2);
        CHECK(maxPen < 0.1);  // voxels, against the other object's surface (and margin)
        CHECK(maxErr <= 1e-4);
        CHECK(maxDrift <= 1e-6);
    }
}

TEST_CASE("body contact: a small ball thrown at a resting heavy one hands over its momentum",
          "[collide][body][sim][slow]") {
    // A 4-voxel ball at 1.5 m/s into a resting 7-voxel ball (6.3 times its mass), no forces.
    // The two meet where both are going (predicted positions), each pushes its own points out
    // of the other, and the pair's momentum is then put right as a whole (one velocity shift):
    // total momentum is kept to round-off (before: each body stopped its own approach, 4.31 →
    // −0.15 kg m/s). The heavy ball leaves with between the perfectly inelastic share
    // m_a/(m_a + m_b) of the momentum and the perfectly elastic one, twice that. Again with a
    // ground far below that neither ball touches: were every point inside the other ball also
    // counted as touching the ground, the pair would be taken for one held by a static
    // collider, and its momentum would not be put right.
    test::TempDir dir("blobs-momentum");
    const Real h = 0.025;
    const Lattice small = test::sphereLattice(4, h, Vec3(-0.4, 0, 0) - Vec3::Constant(4 * h));
    const Lattice heavy = test::sphereLattice(7, h, Vec3(0, 0.03, 0) - Vec3::Constant(7 * h));
    for (const auto& [e, ground] : {std::pair<Real, bool>{0.0, false}, {0.6, false}, {0.0, true}}) {
        const SceneDesc scene = parseScene(
            R"({"frames": {"start": 1, "end": 24, "fps": 24}, "substeps": 4,
            "objects": [
              {"name": "small", "primitive": {"type": "sphere", "radius": 0.1}, "velocity": [1.5, 0, 0],
               "material": {"damping": 2, "stiffness": 100}},
              {"name": "heavy", "primitive": {"type": "sphere", "radius": 0.175},
               "material": {"damping": 2, "stiffness": 100}}],
            "collision": {"restitution": )" +
                std::to_string(e) + "}" + (ground ? R"(, "colliders": [{"type": "ground", "height": -5}])" : "") + "}",
            dir.path() / "s.json");
        Simulation sim(scene, {&small, &heavy});
        const DeformableBody& a = *sim.body(0);
        const DeformableBody& b = *sim.body(1);
        const Real ma = a.totalMass(), mb = b.totalMass();
        REQUIRE(mb / ma == Approx(6.3).epsilon(0.01));
        const Real p0 = ma * 1.5;
        auto pointMomentum = [](const DeformableBody& body) {
            Vec3 p = Vec3::Zero();
            for (std::size_t k = 0; k < body.masses().size(); ++k) p += body.masses()[k] * body.velocities()[k];
            return p;
        };
        Real worst = 0, maxPen = 0;
        int contactFrames = 0;
        for (int f = 2; f <= 24; ++f) {
            const FrameStats st = sim.advanceTo(f);
            maxPen = std::max(maxPen, st.maxPenetration);
            contactFrames += st.contacts > 0 ? 1 : 0;
            // the centres' momentum (the points' also carries one step's push while in contact)
            const Vec3 total = ma * a.centreVelocity() + mb * b.centreVelocity();
            worst = std::max(worst, (total - Vec3(p0, 0, 0)).norm());
        }
        const Vec3 pa = pointMomentum(a), pb = pointMomentum(b);
        const Real inelastic = p0 * mb / (ma + mb);
        INFO("e " << e << (ground ? ", ground below" : "") << ": momentum " << p0 << " -> small " << pa.x()
                  << " + heavy " << pb.x() << " (inelastic " << inelastic << "), worst centre error " << worst
                  << ", max penetration " << maxPen << " voxels, " << contactFrames << " frames in contact");
        CHECK(worst < 1e-9 * p0);
        // After the contact the points' momentum agrees too, to what the volume projection's
        // small shifts of the points leave (measured 4e-6 of it).
        CHECK((pa + pb - Vec3(p0, 0, 0)).norm() < 1e-4 * p0);
        CHECK(pb.x() > 0.95 * inelastic);
        CHECK(pb.x() < 2 * inelastic);
        CHECK(pa.x() / ma < pb.x() / mb);  // apart, not through
        CHECK(contactFrames >= 3);         // a soft contact: the jelly squashes and springs back
        CHECK(maxPen < 0.1);
    }
}

TEST_CASE(
    "body contact: a jelly dropped off-centre onto a resting one bounces off and rolls away, the struck one rolls off "
    "the other way",
    "[collide][body][sim][slow]") {
    // A 0.25 m ball dropped from 1.1 m onto a 0.3 m one resting on the ground, 8 cm off its axis
    // (k = 3000/s², damping 2/s, friction 0.5; docs/math.md, "Friction acts on the patch's
    // slip"). With the friction on the centre instead of the contact patch's slip the upper ball
    // left spinning, landed and spun on the spot with the lower one until the lattice folded (frame
    // 33 of the same pair at 12 and 10 voxels across in `dgv simulate`).
    test::TempDir dir("stack");
    const Real h = 0.05;
    const Lattice lower = test::sphereLattice(6, h, Vec3(0, 0.32, 0) - Vec3::Constant(6 * h));
    const Lattice upper = test::sphereLattice(5, h, Vec3(0.08, 1.1, 0) - Vec3::Constant(5 * h));
    const SceneDesc scene = parseScene(R"({"frames": {"start": 1, "end": 48, "fps": 24}, "substeps": 4,
        "objects": [
          {"name": "lower", "primitive": {"type": "sphere", "radius": 0.3}, "material": {"damping": 2, "stiffness": 3000}},
          {"name": "upper", "primitive": {"type": "sphere", "radius": 0.25}, "material": {"damping": 2, "stiffness": 3000}}],
        "forces": [{"type": "gravity"}],
        "collision": {"objects": true, "friction": 0.5},
        "colliders": [{"type": "ground", "height": 0, "friction": 0.5}]})",
                                       dir.path() / "s.json");
    Simulation sim(scene, {&lower, &upper});
    Real maxErr = 0, maxPen = 0;
    Index inverted = 0;
    // The lower ball when it rolls fastest (it is knocked off, rolls and, rocking on its
    // facets, slows: measured 0.34 m off by frame 48 with the exact distance between them).
    Vec3 va = Vec3::Zero(), aAtFastest = Vec3::Zero();
    Real spinA = 0;
    for (int f = 2; f <= 48; ++f) {
        const FrameStats st = sim.advanceTo(f);  // throws on a fault
        maxErr = std::max(maxErr, st.maxCellVolumeError);
        maxPen = std::max(maxPen, st.maxPenetration);
        inverted += st.invertedCells;
        if (std::abs(sim.body(0)->centreVelocity().x()) > std::abs(va.x())) {
            va = sim.body(0)->centreVelocity();
            aAtFastest = sim.body(0)->centre();
            const Mat3 L = sim.body(0)->flexVelocity() * sim.body(0)->flex().inverse();
            spinA = Real(0.5) * (L(1, 0) - L(0, 1));
        }
    }
    const Vec3 a = sim.body(0)->centre(), b = sim.body(1)->centre();
    const Vec3 vb = sim.body(1)->centreVelocity();
    INFO("lower at " << a.transpose() << " moving " << va.transpose() << ", upper at " << b.transpose() << " moving "
                     << vb.transpose() << ", max cell error " << maxErr << ", max penetration " << maxPen << " voxels");
    CHECK(inverted == 0);
    CHECK(maxErr <= 1e-4);
    CHECK(b.x() - a.x() > 0.55 + 0.5);   // apart on the ground, not stacked: measured 1.77 m
    CHECK(vb.x() > 0.3);                 // rolling on, away: measured 0.77 m/s
    CHECK(std::abs(a.y() - 0.3) < 0.1);  // both on the ground (sagging a little)
    CHECK(std::abs(b.y() - 0.25) < 0.1);
    // The lower one is struck 8 cm off its axis: the blow's sideways part (sin θ ≈ 0.08 / 0.55)
    // pushes it off along −x and turns it, and on the rough ground it rolls away (its contact
    // point does not slip: v_x + ω_z y = 0). Measured: 0.61 m off at 0.44 m/s, spin 1.50 rad/s,
    // slip −5e-3 m/s, when it landed inelastically; landing elastically (docs/math.md,
    // "Velocities after contact") it rolls at up to 0.42 m/s (spin 1.48 rad/s, slip −4e-4 m/s)
    // and is 0.42 m off at frame 48, slowed by its rocking on its facets (all with the OpenVDB
    // distance grid between the bodies; with the exact distance: up to 0.44 m/s, spin 1.55 rad/s,
    // slip −2e-4 m/s, 0.34 m off).
    // (With a flex that loses its spin every step it stays within 3.5 cm of its spot, at rest;
    // docs/math.md, "The flex keeps its spin".)
    const Real slipA = va.x() + spinA * aAtFastest.y();
    INFO("lower ball: fastest at " << va.x() << " m/s, spin " << spinA << " rad/s, slip " << slipA << " m/s");
    if (std::getenv("DGV_TEST_VERBOSE"))
        std::printf("struck ball: %.3f m off at frame 48, fastest %.3f m/s (spin %.3f rad/s, slip %.2e m/s)\n", a.x(),
                    va.x(), spinA, slipA);
    CHECK(a.x() < -0.1);
    CHECK(va.x() < -0.1);
    CHECK(std::abs(va.z()) < 0.2 * std::abs(va.x()));  // along the blow
    CHECK(std::abs(slipA) < 0.1 * std::abs(va.x()));   // rolling, not sliding
    CHECK(maxPen < 0.5);
}

TEST_CASE("body contact: two one-solve jellies thrown head-on are solved as one system",
          "[collide][body][sim][one_solve][slow]") {
    // Two 4-voxel balls closing at 2 m/s, no forces, material.solver "one": the two are one
    // minimisation while they are near (dynamics/cell_solve.hpp, BodyContact), the contact one
    // energy of both bodies' points. A collision makes no energy (the kinetic energy never rises
    // above the start's), the pair's momentum is what it was (to round-off), the balls stop each
    // other and part again along the line they came (apart, not through), and no point of one
    // is found inside the other's surface.
    test::TempDir dir("blobs-one");
    const Real h = 0.025;
    const Lattice left = test::sphereLattice(4, h, Vec3(-0.15, 0, 0) - Vec3::Constant(4 * h));
    const Lattice right = test::sphereLattice(4, h, Vec3(0.15, 0.01, 0) - Vec3::Constant(4 * h));
    const SceneDesc scene = parseScene(
        R"({"frames": {"start": 1, "end": 14, "fps": 24}, "substeps": 4,
            "objects": [
              {"name": "left", "primitive": {"type": "sphere", "radius": 0.1}, "velocity": [1, 0, 0],
               "material": {"damping": 2, "stiffness": 300, "solver": "one"}},
              {"name": "right", "primitive": {"type": "sphere", "radius": 0.1}, "velocity": [-1, 0, 0],
               "material": {"damping": 2, "stiffness": 300, "solver": "one"}}],
            "collision": {"restitution": 0.3, "friction": 0.5}})",
        dir.path() / "s.json");
    Simulation sim(scene, {&left, &right});
    const DeformableBody& a = *sim.body(0);
    const DeformableBody& b = *sim.body(1);
    const Real ma = a.totalMass(), mb = b.totalMass();
    const Real ke0 = 0.5 * (ma + mb);
    Real worstMomentum = 0, maxPen = 0, maxKe = 0, lowest = ke0, maxErr = 0;
    int contactFrames = 0;
    for (int f = 2; f <= 14; ++f) {
        const FrameStats st = sim.advanceTo(f);
        maxPen = std::max(maxPen, st.maxPenetration);
        maxKe = std::max(maxKe, st.kineticEnergy);
        lowest = std::min(lowest, st.kineticEnergy);
        maxErr = std::max(maxErr, st.maxCellVolumeError);
        contactFrames += st.contacts > 0 ? 1 : 0;
        CHECK(st.invertedCells == 0);
        Vec3 total = Vec3::Zero();
        for (const DeformableBody* body : {&a, &b})
            for (std::size_t k = 0; k < body->masses().size(); ++k) total += body->masses()[k] * body->velocities()[k];
        worstMomentum = std::max(worstMomentum, total.norm());
    }
    INFO("ke0 " << ke0 << ", max " << maxKe << ", lowest " << lowest << ", momentum error " << worstMomentum
                << ", max penetration " << maxPen << " voxels, " << contactFrames << " frames in contact, velocities "
                << a.centreVelocity().x() << " " << b.centreVelocity().x());
    CHECK(maxKe <= ke0 * (1 + 1e-9));
    CHECK(lowest < 0.3 * ke0);
    CHECK(worstMomentum < 1e-9 * ma);
    CHECK(contactFrames >= 3);
    CHECK(maxPen < 0.1);  // voxels inside the margin (measured 0.04)
    CHECK(maxErr <= 1e-4);
    CHECK(a.centreVelocity().x() < 0);  // bounced back: apart, not through
    CHECK(b.centreVelocity().x() > 0);
}
