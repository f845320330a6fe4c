// Level-set colliders (scene collider type "levelset"): a .vdb level set of an analytic shape,
// written here with OpenVDB, loaded through the scene reader; its distance and gradient against
// the closed form, its mesh, a ball dropped on it against the same drop on the analytic
// collider, and the bad inputs of the scene key.

#include "base/errors.hpp"
#include "dynamics/stepper.hpp"
#include "e2e/e2e_run.hpp"
#include "io/scene_json.hpp"
#include "io/vdb_mesh.hpp"
#include "sim/levelset_collider.hpp"
#include "sim/simulation.hpp"
#include "support/helpers.hpp"
#include "dynamics/lattices.hpp"

#include <catch2/catch.hpp>
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/MeshToVolume.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

void writeGrids(const fs::path& p, openvdb::GridPtrVec grids) {
    openvdb::io::File f(p.string());
    f.write(grids);
    f.close();
}

/// A level-set sphere of radius r (world units) about c, voxel h, half width 3 voxels, as grid `name`.
openvdb::FloatGrid::Ptr sphereGrid(float r, const openvdb::Vec3f& c, float h, const std::string& name) {
    openvdb::initialize();
    openvdb::FloatGrid::Ptr g = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(r, c, h, 3.0f);
    g->setName(name);
    return g;
}

/// A level-set box [lo, hi] (exact distances to the box surface in the band), voxel h.
openvdb::FloatGrid::Ptr boxGrid(const openvdb::Vec3d& lo, const openvdb::Vec3d& hi, double h, const std::string& name) {
    openvdb::initialize();
    const openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(h);
    openvdb::FloatGrid::Ptr g =
        openvdb::tools::createLevelSetBox<openvdb::FloatGrid>(openvdb::math::BBox<openvdb::Vec3d>(lo, hi), *xf, 3.0);
    g->setName(name);
    return g;
}

/// The scene's only collider's signed distance.
std::function<Real(const Vec3&, Vec3*)> colliderPhi(const SceneDesc& s) {
    REQUIRE(s.colliders.size() == 1);
    REQUIRE(s.colliders[0].levelSet);
    return levelSetDistance(s.colliders[0].levelSet, s.colliders[0].transform);
}

const std::string kObject = R"("objects": [{"primitive": {"type": "sphere", "radius": 0.3}}])";

}  // namespace

namespace {

/// A fog volume "density" with one active voxel: a float grid that is not a level set.
openvdb::FloatGrid::Ptr oneVoxelFog() {
    openvdb::FloatGrid::Ptr fog = openvdb::FloatGrid::create(0.0f);
    fog->setName("density");
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    fog->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
    return fog;
}

}  // namespace

TEST_CASE("levelset collider: distance and gradient of a moved sphere match the closed form", "[io][vdb][levelset]") {
    test::TempDir dir("levelset-sphere");
    // local: radius 0.5 about c, voxel 0.02; the collider scales by 2, rotates and translates it
    const float R = 0.5f, h = 0.02f;
    const openvdb::Vec3f c(0.1f, 0.2f, -0.3f);
    writeGrids(dir.path() / "ball.vdb", {sphereGrid(R, c, h, "ball")});
    const SceneDesc s = parseScene("{" + kObject + R"(, "colliders": [{"type": "levelset", "file": "ball.vdb",
        "grid": "ball", "transform": {"translate": [1, 0, 0.5], "rotate": [20, 30, 10], "scale": 2}}]})",
                                   dir.path() / "scene.json");
    CHECK(s.colliders[0].type == ColliderType::LevelSet);
    CHECK(s.colliders[0].levelSetPath == (dir.path() / "ball.vdb").lexically_normal().string());
    const auto phi = colliderPhi(s);
    const Real k = 2, Rw = k * R, hw = k * h, band = 3 * hw;
    const Mat3 A = s.colliders[0].transform.linear();
    const Vec3 C = A * Vec3(c.x(), c.y(), c.z()) + Vec3(1, 0, 0.5);

    // Near the surface (offsets within 1.2 voxels, so the 8 samples of the point's cell, at most
    // sqrt(3) voxels away, all lie within the 3-voxel band and hold exact distances):
    //  - value: trilinear interpolation errs by at most (h²/8) Σ_a max|∂²f/∂x_a²| over the cell;
    //    for f = |x − C| − R the diagonal second derivatives sum to the Hessian's trace 2/r, so the
    //    error is below h²/(4 r_min), r_min = R − (1.2 + √3) h the smallest radius in any cell used;
    //  - gradient: each component of the interpolant's gradient is a weighted mean of edge
    //    differences (f(a + h e) − f(a))/h, each equal to ∂f at a point of the cell (mean value
    //    theorem) at most √3 h from x; the Hessian's norm is 1/r, so each component errs by at
    //    most √3 h / r_min, the vector by 3 h / r_min.
    // Both bounds are scale-invariant in h/r, so they hold in world units with h, R scaled by 2.
    // 1e-5 covers the float samples (|values| < 0.12, float ulp ~ 1e-8) and OpenVDB's float
    // arithmetic when it rasterised the sphere.
    const Real rMin = Rw - (1.2 + std::sqrt(3.0)) * hw;
    const Real valueTol = hw * hw / (4 * rMin) + 1e-5, gradTol = 3 * hw / rMin + 1e-4;
    Real worst = 0, worstGrad = 0;
    for (int i = 0; i < 500; ++i) {
        const Real th = std::acos(1 - 2 * (i + 0.5) / 500), ph = i * 2.399963;
        const Vec3 n(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
        const Real off = 1.2 * hw * ((i % 7) - 3) / 3.0;
        const Vec3 x = C + (Rw + off) * n;
        Vec3 g;
        const Real d = phi(x, &g);
        worst = std::max(worst, std::abs(d - off));
        worstGrad = std::max(worstGrad, (g - n).norm());
        Vec3 g2;
        CHECK(phi(x, nullptr) == d);
        (void)phi(x, &g2);
        CHECK(g2 == g);
    }
    INFO("max value error " << worst << " (bound " << valueTol << "), max gradient error " << worstGrad << " (bound "
                            << gradTol << ")");
    CHECK(worst < valueTol);
    CHECK(worstGrad < gradTol);
    std::printf(
        "levelset sphere (world voxel %.3f): max |phi - d| %.2e (bound %.2e), max |grad - n| %.3f (bound %.3f)\n", hw,
        worst, valueTol, worstGrad, gradTol);

    // Beyond the band: outside reads as outside (at least the band, positive), inside as inside.
    for (const Real dist : {band + std::sqrt(3.0) * hw, 0.3, 2.0, 10.0}) {
        const Vec3 x = C + (Rw + dist) * Vec3(0.6, 0.0, 0.8);
        CHECK(phi(x, nullptr) >= std::min(dist, band) - 1e-6);
    }
    CHECK(phi(C, nullptr) <= -band + 1e-6);
    // far away (outside the dense box) the distance keeps growing like a distance
    CHECK(phi(C + Vec3(0, 20, 0), nullptr) > 15);
}

TEST_CASE("levelset collider: the first level set is the default grid, its mesh is the sphere", "[io][vdb][levelset]") {
    test::TempDir dir("levelset-default");
    const float R = 0.4f, h = 0.025f;
    openvdb::initialize();
    // a fog grid first: skipped, the first *level set* is taken
    openvdb::FloatGrid::Ptr fog = oneVoxelFog();
    fs::create_directories(dir.path() / "sub");
    writeGrids(dir.path() / "s.vdb", {fog, sphereGrid(R, openvdb::Vec3f(0, 0, 0), h, "surface")});
    const SceneDesc s = parseScene("{" + kObject + R"(, "colliders": [{"type": "levelset", "file": "sub/../s.vdb"}]})",
                                   dir.path() / "scene.json");
    Vec3 g;
    CHECK(colliderPhi(s)(Vec3(R, 0, 0), &g) == Approx(0).margin(1e-6));
    CHECK(g.x() == Approx(1).margin(0.05));

    // The mesh: dual contouring puts each vertex inside the voxel it meshes, where the
    // interpolated distance is zero; the true distance there is within the interpolation error
    // and the vertex's own placement error (a fraction of a voxel): |r − R| < h/2 is a loose,
    // sure bound, tight enough to tell the surface from a neighbour layer of voxels.
    const TriangleMesh m = levelSetMesh(*s.colliders[0].levelSet);
    REQUIRE(m.triangles.size() > 1000);
    Real worst = 0, volume = 0;
    for (const Vec3& v : m.vertices) worst = std::max(worst, std::abs(v.norm() - R));
    for (const auto& t : m.triangles) {
        const Vec3& a = m.vertices[static_cast<std::size_t>(t[0])];
        const Vec3& b = m.vertices[static_cast<std::size_t>(t[1])];
        const Vec3& c = m.vertices[static_cast<std::size_t>(t[2])];
        volume += a.dot(b.cross(c)) / 6;  // > 0 when the triangles are CCW from outside
    }
    CHECK(worst < 0.5 * h);
    // Enclosed volume: every vertex lies in the shell |r − R| <= w (w = worst); a point of a
    // triangle is a convex combination Σλ_i v_i, and |Σλ_i v_i|² = Σλ_i|v_i|² − Σ_{i<j} λ_iλ_j|v_i − v_j|²
    // >= (R − w)² − e²/3 (e the longest edge, Σ_{i<j} λ_iλ_j <= 1/3), so the closed surface lies
    // between the radii r_lo = sqrt((R − w)² − e²/3) and R + w and encloses a volume between theirs.
    Real e = 0;
    for (const auto& t : m.triangles)
        for (int a = 0; a < 3; ++a)
            e = std::max(
                e, (m.vertices[static_cast<std::size_t>(t[a])] - m.vertices[static_cast<std::size_t>(t[(a + 1) % 3])])
                       .norm());
    const Real rLo = std::sqrt((R - worst) * (R - worst) - e * e / 3), rHi = R + worst;
    const Real V = 4.0 / 3 * M_PI * R * R * R;
    CHECK(volume > 4.0 / 3 * M_PI * rLo * rLo * rLo);
    CHECK(volume < 4.0 / 3 * M_PI * rHi * rHi * rHi);
    std::printf(
        "levelset mesh: %zu triangles, max |r - R| %.2e, longest edge %.4f (voxel %.3f), volume %.5f vs %.5f "
        "(bounds %.5f, %.5f)\n",
        m.triangles.size(), worst, e, h, volume, V, 4.0 / 3 * M_PI * rLo * rLo * rLo, 4.0 / 3 * M_PI * rHi * rHi * rHi);
    // deterministic
    CHECK(levelSetMesh(*s.colliders[0].levelSet).triangles == m.triangles);
}

namespace {

struct DropResult {
    Real minY = 0, meanY = 0, maxPenetration = 0;
};

/// A ball of radius 6 lattice steps (h = 0.05) dropped at 1.5 m/s from 0.02 above the collider's
/// top (y = 0), 4 substeps a frame at 24 fps (the gln_network drop test's setup), to frame 10: it
/// lands in the first frame and then rests, spreading slowly (goo). Not longer: goo resting on a
/// collider folds a few frames later (frame 13 on the slab; on the ground it spreads the same way;
/// README, docs/math.md, "What the step does not do yet"), a dynamics limit, not the collider's.
DropResult dropBall(const std::string& collider, const std::string& detect, const fs::path& sceneFile) {
    const std::string json = R"({"frames": {"start": 1, "end": 16, "fps": 24}, "substeps": 4,
        "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.3}, "velocity": [0, -1.5, 0],
                     "material": {"preset": "goo", "damping": 2}}],
        "forces": [{"type": "gravity"}], "collision": {"detect": ")" +
                             detect + R"("},
        "colliders": [)" + collider +
                             "]}";
    const SceneDesc scene = parseScene(json, sceneFile);
    const Lattice lat = test::sphereLattice(6, 0.05, Vec3(-0.3, 0.02, -0.3));
    Simulation sim(scene, {&lat});
    REQUIRE(sim.active());
    DropResult r;
    for (int f = 2; f <= 10; ++f) r.maxPenetration = std::max(r.maxPenetration, sim.advanceTo(f).maxPenetration);
    const std::vector<Vec3>& x = sim.body(0)->positions();
    r.minY = HUGE_VAL;
    for (const Vec3& p : x) {
        r.minY = std::min(r.minY, p.y());
        r.meanY += p.y() / static_cast<Real>(x.size());
    }
    return r;
}

}  // namespace

TEST_CASE("levelset collider: a ball dropped on a level-set box rests where it rests on the ground",
          "[io][vdb][levelset][sim]") {
    test::TempDir dir("levelset-drop");
    // a slab [-1, 1] x [-0.5, 0] x [-1, 1], voxel 0.025 (half the ball's lattice step): top face at y = 0
    const Real vs = 0.025;
    writeGrids(dir.path() / "slab.vdb",
               {boxGrid(openvdb::Vec3d(-1, -0.5, -1), openvdb::Vec3d(1, 0, 1), vs, "surface")});
    // On the flat top, away from the edges, the level set's samples are exact distances to the
    // plane y = 0 (linear, so trilinear interpolation is exact up to float rounding): the ball must
    // come to rest where it does on the analytic ground. The difference allowed is one voxel of
    // the level set, for the float samples and for meshToVolume's distances near the top face.
    for (const std::string detect : {"sdf", "gln"}) {
        const DropResult ground = dropBall(R"({"type": "ground", "height": 0})", detect, dir.path() / "a.json");
        const DropResult slab = dropBall(R"({"type": "levelset", "file": "slab.vdb"})", detect, dir.path() / "a.json");
        INFO(detect << ": ground min y " << ground.minY << ", mean y " << ground.meanY << "; level set min y "
                    << slab.minY << ", mean y " << slab.meanY << ", max penetration " << slab.maxPenetration);
        std::printf("drop (%s): ground min y %.3e mean y %.7f; levelset min y %.3e mean y %.7f, max penetration %.1e\n",
                    detect.c_str(), ground.minY, ground.meanY, slab.minY, slab.meanY, slab.maxPenetration);
        // it landed and stopped: resting on the top, not fallen through or hovering
        CHECK(slab.minY > -vs);
        CHECK(slab.minY < 0.02);
        CHECK(std::abs(slab.minY - ground.minY) < vs);
        CHECK(std::abs(slab.meanY - ground.meanY) < vs);
    }
}

TEST_CASE("levelset collider: bad input names the file and the problem", "[io][vdb][levelset]") {
    test::TempDir dir("levelset-bad");
    openvdb::initialize();
    openvdb::FloatGrid::Ptr fog = oneVoxelFog();
    openvdb::Vec3SGrid::Ptr vec = openvdb::Vec3SGrid::create();
    vec->setName("vel");
    vec->setGridClass(openvdb::GRID_UNKNOWN);
    vec->tree().setValue(openvdb::Coord(0, 0, 0), openvdb::Vec3s(1, 0, 0));
    writeGrids(dir.path() / "fog.vdb", {fog, vec});
    writeGrids(dir.path() / "ball.vdb", {sphereGrid(0.5f, openvdb::Vec3f(0, 0, 0), 0.05f, "surface")});
    std::ofstream(dir.path() / "text.vdb") << "not a vdb";
    auto error = [&](const std::string& collider) -> std::string {
        try {
            parseScene("{" + kObject + R"(, "colliders": [)" + collider + "]}", dir.path() / "scene.json");
        } catch (const InputError& e) {
            return e.what();
        }
        return "no error";
    };
    const std::string fogPath = (dir.path() / "fog.vdb").string();
    CHECK_THAT(error(R"({"type": "levelset"})"), Catch::Contains("colliders[0].file") && Catch::Contains("missing"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "absent.vdb"})"),
               Catch::Contains("colliders[0].file") && Catch::Contains("absent.vdb") && Catch::Contains("cannot open"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "text.vdb"})"),
               Catch::Contains("text.vdb") && Catch::Contains("not an OpenVDB file"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "fog.vdb"})"),
               Catch::Contains(fogPath) && Catch::Contains("no level-set grid"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "fog.vdb", "grid": "surface"})"),
               Catch::Contains(fogPath) && Catch::Contains("no grid named 'surface'"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "fog.vdb", "grid": "density"})"),
               Catch::Contains(fogPath) && Catch::Contains("not a level set"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "fog.vdb", "grid": "vel"})"),
               Catch::Contains(fogPath) && Catch::Contains("vec3s") && Catch::Contains("not float"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "ball.vdb", "transform": {"scale": [1, 2, 1]}})"),
               Catch::Contains("colliders[0].transform.scale") && Catch::Contains("uniform"));
    // a mirror would turn the distances' sign convention inside out
    CHECK_THAT(error(R"({"type": "levelset", "file": "ball.vdb", "transform": {"scale": [-1, -1, -1]}})"),
               Catch::Contains("colliders[0].transform.scale") && Catch::Contains("positive uniform"));
    CHECK_THAT(error(R"({"type": "levelset", "file": "ball.vdb", "mesh": "a.obj"})"), Catch::Contains("mesh"));
    CHECK(error(R"({"type": "levelset", "file": "ball.vdb", "transform": {"scale": 2}})") == "no error");
}

TEST_CASE("e2e: a bad level-set collider exits 2 with one line and writes nothing", "[e2e][badinput][levelset]") {
    test::TempDir root("levelset-e2e");
    openvdb::initialize();
    openvdb::FloatGrid::Ptr fog = oneVoxelFog();
    const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
        {R"({"type": "levelset", "file": "absent.vdb"})", {"absent.vdb", "cannot open"}},
        {R"({"type": "levelset", "file": "fog.vdb"})", {"fog.vdb", "no level-set grid"}},
        {R"({"type": "levelset", "file": "fog.vdb", "grid": "density"})", {"fog.vdb", "not a level set"}},
        // The shipped cube cut after 400 bytes: OpenVDB's message is cut to one short line.
        {R"({"type": "levelset", "file": "cut.vdb"})", {"cut.vdb", "cannot read it as OpenVDB: RuntimeError"}},
        // Cut after its header: no grid at all, said as such rather than "no grid named 'surface'".
        {R"({"type": "levelset", "file": "head.vdb", "grid": "surface"})", {"head.vdb", "holds no grids"}},
    };
    const std::string cube = e2e::readAll(test::sourcePath("scenes") / "levelsets" / "cube.vdb");
    int index = 0;
    for (const auto& [collider, expect] : cases) {
        const fs::path d = root.path() / ("case" + std::to_string(index++));
        fs::create_directories(d);
        writeGrids(d / "fog.vdb", {fog});
        std::ofstream(d / "cut.vdb", std::ios::binary) << cube.substr(0, 400);
        std::ofstream(d / "head.vdb", std::ios::binary) << cube.substr(0, 10);
        std::ofstream(d / "s.json") << R"({"frames": {"start": 1, "end": 2}, )" << kObject
                                    << R"(, "forces": [{"type": "gravity"}], "colliders": [)" << collider
                                    << R"(], "render": {"width": 32, "height": 32, "supersample": 1}})";
        const std::vector<std::string> before = e2e::snapshot(d);
        for (const std::string cmd : {"render s.json", "simulate s.json"}) {
            const e2e::Run r = e2e::runDgvIn(d, cmd);
            INFO(collider << ": dgv " << cmd << " exit " << r.exitCode << ", stderr: " << r.err);
            CHECK(r.exitCode == 2);
            CHECK(e2e::lineCount(r.err) == 1);
            CHECK(r.err.size() < 400);
            CHECK(r.out.empty());
            CHECK_THAT(r.err, Catch::Contains("s.json") && Catch::Contains("colliders[0].file"));
            for (const std::string& e : expect) CHECK_THAT(r.err, Catch::Contains(e));
            CHECK(e2e::snapshot(d) == before);
        }
    }
}

TEST_CASE("levelset collider: the shipped scene's cube is where its transform puts it", "[io][vdb][levelset][scene]") {
    // scenes/levelset_drop.json: a 1.6 m cube (scenes/levelsets/cube.vdb, voxel 0.04, centred at
    // the origin) moved down 0.8 and turned 30° about Y: its top face is the plane y = 0 (the
    // points below lie within 0.4 of the axis, inside the 0.8 half-width whatever the turn), and
    // a side face is 0.8 from the centre along the turned x axis.
    const SceneDesc s = loadScene(test::sourcePath("scenes") / "levelset_drop.json");
    const auto phi = colliderPhi(s);
    Vec3 g;
    for (const Vec3& x : {Vec3(0, 0.03, 0), Vec3(0.2, 0.0, -0.1), Vec3(-0.3, -0.05, 0.25)}) {
        // on a flat face the level set is linear: exact up to the float samples (and the file's
        // own distances, within 1e-5 of the plane's here)
        CHECK(phi(x, &g) == Approx(x.y()).margin(1e-5));
        CHECK((g - Vec3::UnitY()).norm() < 1e-4);
    }
    const Real c = std::cos(M_PI / 6), sn = std::sin(M_PI / 6);
    const Vec3 side(c, 0, -sn);  // the local +x axis turned 30° about Y
    CHECK(phi(Vec3(0, -0.8, 0) + 0.85 * side, &g) == Approx(0.05).margin(1e-5));
    CHECK((g - side).norm() < 1e-4);
    CHECK(phi(Vec3(0, -0.8, 0), nullptr) < 0);
}
