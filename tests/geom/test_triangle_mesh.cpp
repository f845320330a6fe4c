// Tests of src/geom/triangle_mesh.hpp: topology report, volume, transforms, normals, smoothing.
#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include "dynamics/lattices.hpp"
#include "geom/primitives.hpp"
#include "geom/triangle_mesh.hpp"
#include "sim/body_contact.hpp"

#include <algorithm>
#include <cmath>

using namespace dgv;

namespace {

TriangleMesh unitTetra() {
    TriangleMesh m;
    m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
    m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    return m;
}

}  // namespace

TEST_CASE("triangle_mesh: a tetrahedron is closed and manifold with volume 1/6", "[geom]") {
    const MeshReport r = analyseMesh(unitTetra());
    CHECK(r.closed);
    CHECK(r.manifold);
    CHECK(r.boundaryEdges == 0);
    CHECK(r.nonManifoldEdges == 0);
    CHECK(r.vertices == 4);
    CHECK(r.triangles == 4);
    CHECK(std::abs(r.signedVolume - 1.0 / 6) < 1e-15);
    CHECK(r.bounds.min == Vec3(0, 0, 0));
    CHECK(r.bounds.max == Vec3(1, 1, 1));
}

TEST_CASE("triangle_mesh: a removed triangle leaves three boundary edges", "[geom]") {
    TriangleMesh m = unitTetra();
    m.triangles.pop_back();
    const MeshReport r = analyseMesh(m);
    CHECK_FALSE(r.closed);
    CHECK(r.manifold);
    CHECK(r.boundaryEdges == 3);
}

TEST_CASE("triangle_mesh: one flipped triangle is closed but not manifold", "[geom]") {
    TriangleMesh m = unitTetra();
    std::swap(m.triangles[3][1], m.triangles[3][2]);
    const MeshReport r = analyseMesh(m);
    CHECK(r.closed);
    CHECK_FALSE(r.manifold);
}

TEST_CASE("triangle_mesh: three triangles on one edge are non-manifold", "[geom]") {
    TriangleMesh m = unitTetra();
    m.vertices.emplace_back(-1, -1, 0.5);
    m.triangles.push_back({0, 1, 4});
    const MeshReport r = analyseMesh(m);
    CHECK(r.nonManifoldEdges == 1);
    CHECK(r.boundaryEdges == 2);
    CHECK_FALSE(r.closed);
    CHECK_FALSE(r.manifold);
}

TEST_CASE("triangle_mesh: an empty mesh is neither closed nor manifold", "[geom]") {
    const MeshReport r = analyseMesh(TriangleMesh{});
    CHECK_FALSE(r.closed);
    CHECK_FALSE(r.manifold);
    CHECK(r.bounds.empty());
    CHECK(meshBounds(TriangleMesh{}).empty());
}

TEST_CASE("triangle_mesh: degenerate triangles are dropped and counted", "[geom]") {
    TriangleMesh m = unitTetra();
    m.vertices.emplace_back(2, 0, 0);  // collinear with 0 and 1
    m.triangles.push_back({0, 0, 1});  // repeated index
    m.triangles.push_back({0, 1, 4});  // zero area
    m.triangles.push_back({1, 2, 2});
    CHECK(dropDegenerateTriangles(m) == 3);
    CHECK(m.triangles.size() == 4);
    CHECK(m.vertices.size() == 5);  // unreferenced vertices are kept
    CHECK(dropDegenerateTriangles(m) == 0);
}

TEST_CASE("triangle_mesh: a mirror keeps the volume positive by flipping the winding", "[geom]") {
    TriangleMesh m = makeSphere(1.0, 32, 16);
    const Real v0 = meshSignedVolume(m);
    Mat3 mirror = Vec3(-2, 1, 1).asDiagonal();
    transformMesh(m, mirror, Vec3(5, 0, 0));
    CHECK(std::abs(meshSignedVolume(m) - 2 * v0) < 1e-12 * v0);
    CHECK(analyseMesh(m).manifold);
    const Box3 b = meshBounds(m);
    CHECK(std::abs(b.centre().x() - 5) < 1e-12);

    TriangleMesh r = makeSphere(1.0, 32, 16);
    transformMesh(r, Eigen::AngleAxis<Real>(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix(), Vec3::Zero());
    CHECK(std::abs(meshSignedVolume(r) - v0) < 1e-12 * v0);
}

TEST_CASE("triangle_mesh: vertex normals of a sphere point outward", "[geom]") {
    const TriangleMesh m = makeSphere(2.0, 48, 24);
    const std::vector<Vec3> n = vertexNormals(m);
    REQUIRE(n.size() == m.vertices.size());
    Real worst = 1;
    for (std::size_t v = 0; v < n.size(); ++v) {
        CHECK(std::abs(n[v].norm() - 1) < 1e-12);
        worst = std::min(worst, n[v].dot(m.vertices[v].normalized()));
    }
    CHECK(worst > 0.999);
}

TEST_CASE("triangle_mesh: Taubin smoothing takes a voxel staircase off and keeps the volume", "[geom]") {
    // The outer cell faces of a voxel ball of radius 8 (the surface goo's volume gives, before
    // smoothing: sim/simulation volumeSurface).
    const Lattice lat = test::sphereLattice(8, 1.0, Vec3::Constant(-8));
    TriangleMesh m = latticeSurface(lat, restPositions(lat));
    auto radialSpread = [](const TriangleMesh& mesh) {
        Real mean = 0, sq = 0;
        for (const Vec3& v : mesh.vertices) mean += v.norm();
        mean /= static_cast<Real>(mesh.vertices.size());
        for (const Vec3& v : mesh.vertices) sq += (v.norm() - mean) * (v.norm() - mean);
        return std::sqrt(sq / static_cast<Real>(mesh.vertices.size()));
    };
    const Real v0 = meshSignedVolume(m), s0 = radialSpread(m);
    smoothTaubin(m, 10);
    const Real v1 = meshSignedVolume(m), s1 = radialSpread(m);
    INFO("volume " << v0 << " -> " << v1 << ", radial spread " << s0 << " -> " << s1);
    CHECK(std::abs(v1 / v0 - 1) < 0.01);
    CHECK(s1 < 0.5 * s0);
    CHECK(analyseMesh(m).closed);
    // A smooth mesh hardly moves: a UV sphere of radius 1.
    TriangleMesh sphere = makeSphere(1.0);
    const TriangleMesh before = sphere;
    smoothTaubin(sphere, 10);
    Real moved = 0;
    for (std::size_t i = 0; i < sphere.vertices.size(); ++i)
        moved = std::max(moved, (sphere.vertices[i] - before.vertices[i]).norm());
    INFO("sphere: largest move " << moved);
    CHECK(moved < 0.02);
}

TEST_CASE("triangle_mesh: vertices at the same position share the lowest index among them", "[geom]") {
    const std::vector<Vec3> v = {Vec3(1, 0, 0),      Vec3(0, 0, 0), Vec3(1, 0, 0),   Vec3(0, 0, 0),
                                 Vec3(0, 0, 1e-300), Vec3(1, 0, 0), Vec3(-0.0, 0, 0)};
    // -0.0 == 0.0: one position; 1e-300 is another.
    CHECK(samePositionRepresentatives(v) == std::vector<int>{0, 1, 0, 1, 4, 0, 1});
    CHECK(samePositionRepresentatives({}).empty());
}

TEST_CASE("triangle_mesh: the look stays with its triangles when they are dropped or turned", "[geom][materials]") {
    // Two tetrahedra: the first outward, the second inside out, far apart; plus one degenerate
    // triangle in between. Each triangle's material is its index and its corners' coordinates
    // name the corner's vertex, so any misalignment shows.
    TriangleMesh m;
    m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1),
                  Vec3(5, 0, 0), Vec3(6, 0, 0), Vec3(5, 1, 0), Vec3(5, 0, 1)};
    m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {1, 1, 2},
                   {4, 5, 6}, {4, 7, 5}, {4, 6, 7}, {5, 7, 6}};
    m.materials.resize(m.triangles.size());
    auto uvOf = [](int v) { return Eigen::Vector2f(static_cast<float>(v), static_cast<float>(10 * v)); };
    for (std::size_t f = 0; f < m.triangles.size(); ++f) {
        m.triangleMaterials.push_back(static_cast<int>(f));
        m.cornerUvs.push_back({uvOf(m.triangles[f][0]), uvOf(m.triangles[f][1]), uvOf(m.triangles[f][2])});
    }
    auto aligned = [&]() {
        if (!m.hasMaterials()) return false;
        for (std::size_t f = 0; f < m.triangles.size(); ++f)
            for (std::size_t k = 0; k < 3; ++k)
                if (m.cornerUvs[f][k] != uvOf(m.triangles[f][k])) return false;
        return true;
    };
    CHECK(dropDegenerateTriangles(m) == 1);
    CHECK(m.triangleMaterials == std::vector<int>{0, 1, 2, 3, 5, 6, 7, 8});
    CHECK(aligned());
    const OrientReport r = orientOutward(m);
    CHECK(r.flippedParts == 1);
    CHECK(meshSignedVolume(m) == Approx(2.0 / 6));
    CHECK(aligned());
    transformMesh(m, Mat3(Vec3(-1, 1, 1).asDiagonal()), Vec3::Zero());  // a mirror turns every triangle
    CHECK(meshSignedVolume(m) == Approx(2.0 / 6));
    CHECK(aligned());
    CHECK(m.triangleMaterials == std::vector<int>{0, 1, 2, 3, 5, 6, 7, 8});
}
