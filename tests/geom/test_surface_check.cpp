// Tests of the embedded surface's check (src/geom/surface_check.hpp): no false alarm on rigid,
// affine or smooth large motion; a torn or flipped surface is caught.
#include <catch2/catch.hpp>

#include "geom/embedding.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"
#include "geom/primitives.hpp"
#include "geom/surface_check.hpp"
#include "geom/voxelise.hpp"

#include <Eigen/Geometry>

#include <cmath>

using namespace dgv;

namespace {

struct Fixture {
    TriangleMesh mesh;
    Lattice lat;
    MeshEmbedding emb;
    GeometricState state;
    std::vector<Vec3> deformed;
    SurfaceCheckSetup setup;

    explicit Fixture(TriangleMesh m, int resolution = 12) : mesh(std::move(m)) {
        VoxeliseSettings vs;
        vs.resolution = resolution;
        lat = voxelise(mesh, vs);
        emb = embedVertices(lat, mesh.vertices);
        setup = prepareSurfaceCheck(mesh);
    }
    /// Moves every lattice point by f and recomputes the state and the deformed surface.
    template <typename F>
    SurfaceCheck moved(F&& f) {
        std::vector<Vec3> x(static_cast<std::size_t>(lat.size()));
        for (Index p = 0; p < lat.size(); ++p) x[static_cast<std::size_t>(p)] = f(lat.restPosition(p));
        computeGeometricState(lat, x, state);
        deformVertices(emb, state, deformed);
        return checkSurface(setup, mesh, emb, state, lat.spacing, deformed);
    }
    SurfaceCheck check() const { return checkSurface(setup, mesh, emb, state, lat.spacing, deformed); }
    Index anchoredVertices() const {
        Index n = 0;
        for (std::size_t v = 0; v < emb.size(); ++v) n += emb.trilinear(v) ? 0 : 1;
        return n;
    }
};

}  // namespace

TEST_CASE("surface check: rest, rigid and volume-keeping affine motion pass with stretch near 1", "[geom][surface]") {
    Fixture f(makeSphere(0.5, 32, 16));
    REQUIRE(f.anchoredVertices() > 0);  // both embedding rules are exercised
    const SurfaceCheck rest = f.moved([](const Vec3& x) { return x; });
    CHECK(rest.ok());
    // At rest |e| = |F e0|, so the figure is 4|e| / (4|e| + h/2) < 4 and close to it for long edges.
    CHECK(rest.worstStretch < kTearRatio);

    const Mat3 turn = Eigen::AngleAxis<Real>(1.1, Vec3(1, 2, -0.5).normalized()).toRotationMatrix();
    const SurfaceCheck rigid = f.moved([&](const Vec3& x) { return Vec3(turn * x + Vec3(3, -1, 2)); });
    CHECK(rigid.ok());
    CHECK(rigid.worstStretch == Approx(rest.worstStretch).epsilon(1e-9));

    // A 3:1 stretch with det 1, turned: the embedding is exact, the frames predict every edge.
    Mat3 a = Vec3(3, 1 / std::sqrt(3.0), 1 / std::sqrt(3.0)).asDiagonal();
    a = turn * a;
    a(0, 1) += 0.8;  // and a shear
    const SurfaceCheck affine = f.moved([&](const Vec3& x) { return Vec3(a * x); });
    CHECK(affine.ok());
    CHECK(affine.flippedTriangles == 0);
    CHECK(affine.tornEdges == 0);
}

TEST_CASE("surface check: a bar bent into a half circle is not torn", "[geom][surface]") {
    // Smooth, large, non-affine: the bar (2 × 0.3 × 0.3) along x wraps onto a half circle of
    // radius 2/π about the z axis, lengths along the centre line kept.
    Fixture f(makeBox(Vec3(2, 0.3, 0.3), 8), 24);
    const Real radius = 2 / M_PI;
    const SurfaceCheck bent = f.moved([&](const Vec3& x) {
        const Real angle = x.x() / radius;
        const Real r = radius + x.y();
        return Vec3(r * std::sin(angle), r * std::cos(angle) - radius, x.z());
    });
    CHECK(bent.ok());
    CHECK(bent.worstStretch < 2);
}

TEST_CASE("surface check: a vertex thrown out by its anchor's second derivative is a torn edge", "[geom][surface]") {
    // The failure the lattice checks miss: every cell keeps its volume, but an anchored vertex
    // follows x + x_a d + 1/2 x_ab d d with a wild x_ab (the torn beak of a swirled duck).
    Fixture f(makeSphere(0.5, 32, 16));
    REQUIRE(f.moved([](const Vec3& x) { return x; }).ok());
    std::size_t v = 0;
    while (f.emb.trilinear(v)) ++v;
    const std::size_t q = static_cast<std::size_t>(f.emb.anchor[v]);
    const Vec3 d = f.emb.offset[v];
    REQUIRE(d.norm() > 0.1);
    // x_aa += (0, 20 h / |d|², 0) for a = 1..3: vertex v moves 1/2 Σ_a d_a² · 20 h/|d|² = 10 h up,
    // the other vertices anchored at q by 10 h |d'|²/|d|², the rest not at all.
    for (std::size_t k = 0; k < 6; ++k)
        if (kSymmetricPairs[k][0] == kSymmetricPairs[k][1])
            f.state.second[k][q] += Vec3(0, 20 * f.lat.spacing / d.squaredNorm(), 0);
    const std::vector<Vec3> before = f.deformed;
    deformVertices(f.emb, f.state, f.deformed);
    REQUIRE((f.deformed[v] - before[v]).norm() == Approx(10 * f.lat.spacing).epsilon(1e-9));
    const SurfaceCheck torn = f.check();
    CHECK_FALSE(torn.ok());
    CHECK(torn.tornEdges >= 1);
    CHECK(torn.worstStretch > kTearRatio);
}

TEST_CASE("surface check: a fitted vertex is judged by its fit's frame, not its anchor's", "[geom][surface]") {
    // The one-solve step's embedding (fitOutside): a vertex outside the cells follows the affine
    // fit of its neighbourhood. Its anchor's frame at the boundary is a one-sided difference that
    // can disagree with the fit by several times; here the anchors' frames are set to the rest
    // frame while the lattice is stretched 5× along x, so only the fit predicts the edges.
    Fixture f(makeSphere(0.5, 32, 16));
    f.emb = embedVertices(f.lat, f.mesh.vertices, true);
    REQUIRE(f.emb.fittedVertices() > 100);
    const SurfaceCheck stretched = f.moved([](const Vec3& x) { return Vec3(5 * x.x(), x.y() / 5, x.z()); });
    REQUIRE(stretched.ok());
    for (std::size_t a = 0; a < 3; ++a)
        for (auto& t : f.state.tangent[a]) t = f.lat.spacing * Vec3::Unit(static_cast<Eigen::Index>(a));
    const SurfaceCheck judged = f.check();
    CHECK(judged.tornEdges == 0);
    CHECK(judged.worstStretch < 2);
    // ...while a fitted vertex thrown 10 voxels off its fit is still a tear.
    std::size_t v = 0;
    while (f.emb.trilinear(v)) ++v;
    f.deformed[v] += Vec3(0, 10 * f.lat.spacing, 0);
    const SurfaceCheck torn = f.check();
    CHECK_FALSE(torn.ok());
    CHECK(torn.tornEdges >= 1);
}

TEST_CASE("surface check: a surface folded over is flipped, a squashed one is not", "[geom][surface]") {
    // A box's top face, subdivided: fold its +x half over onto the −x half about the line x = 0
    // (the vertices with x > 0 go to (−x, y + 2|x|·0, ...)), the lattice at rest. The triangles
    // along the fold line meet their neighbours at 180°: flipped. Edge lengths are kept.
    Fixture f(makeBox(Vec3(1, 0.2, 1), 8), 12);
    REQUIRE(f.moved([](const Vec3& x) { return x; }).ok());
    REQUIRE(f.setup.edges.size() == f.mesh.triangles.size() * 3 / 2);  // closed: each edge in two triangles
    REQUIRE(f.setup.neighbours.size() == f.setup.edges.size());
    Index moved = 0;
    for (std::size_t v = 0; v < f.deformed.size(); ++v) {
        const Vec3 r = f.mesh.vertices[v];
        if (r.y() > 0.09 && r.x() > 1e-9) {  // top face, right half: mirrored to the left, lifted a hair
            f.deformed[v] = Vec3(-r.x(), r.y() + 1e-3 * r.x(), r.z());
            ++moved;
        }
    }
    REQUIRE(moved > 0);
    const SurfaceCheck fold = f.check();
    // Along the fold line x = 0 the top face's triangles on either side now face opposite ways:
    // the 8 divisions give 8 strips of 2 triangles on each side of it.
    CHECK(fold.flippedTriangles >= 16);
    CHECK_FALSE(fold.ok());  // 34 of 768 triangles, over kMaxFlippedFraction
    // Folds on a few triangles (specks below what shows) pass; a tear never does.
    SurfaceCheck specks;
    specks.triangles = 1000;
    specks.flippedTriangles = 20;
    CHECK(specks.ok());
    specks.flippedTriangles = 21;
    CHECK_FALSE(specks.ok());
    specks.flippedTriangles = 0;
    specks.tornEdges = 1;
    CHECK_FALSE(specks.ok());
    // The same surface squashed 5:1 flat, as goo spreading on the ground is, is not folded.
    const SurfaceCheck squashed =
        f.moved([](const Vec3& x) { return Vec3(std::sqrt(5.0) * x.x(), x.y() / 5, std::sqrt(5.0) * x.z()); });
    CHECK(squashed.ok());
}
