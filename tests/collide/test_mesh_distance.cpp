// The exact signed distance to a closed triangle mesh (src/collide/mesh_distance.hpp): against
// the closed form of a box's distance, the hierarchy against a brute-force scan of every
// triangle, and the sign on a lattice surface with an edge that four faces share.
#include <catch2/catch.hpp>

#include "collide/mesh_distance.hpp"
#include "dynamics/lattices.hpp"
#include "geom/lattice.hpp"
#include "geom/primitives.hpp"
#include "sim/body_contact.hpp"

#include <cmath>
#include <limits>
#include <random>

using namespace dgv;

namespace {

/// The signed distance of the axis-aligned box of half sizes b centred at the origin.
Real boxDistance(const Vec3& x, const Vec3& b) {
    const Vec3 q = x.cwiseAbs() - b;
    return q.cwiseMax(Vec3::Zero()).norm() + std::min(q.maxCoeff(), Real(0));
}

/// The unsigned distance to the nearest triangle, by scanning every one (points sampled densely
/// enough on each triangle would be an approximation; this is the exact minimum over the
/// triangles, each by projection onto its plane or onto its edges).
Real bruteDistance(const TriangleMesh& m, const Vec3& x) {
    auto segment = [&](const Vec3& a, const Vec3& b) {
        const Vec3 ab = b - a;
        const Real t = std::clamp((x - a).dot(ab) / ab.squaredNorm(), Real(0), Real(1));
        return (x - a - t * ab).norm();
    };
    Real best = std::numeric_limits<Real>::infinity();
    for (const auto& t : m.triangles) {
        const Vec3 &a = m.vertices[static_cast<std::size_t>(t[0])], &b = m.vertices[static_cast<std::size_t>(t[1])],
                   &c = m.vertices[static_cast<std::size_t>(t[2])];
        const Vec3 n = (b - a).cross(c - a).normalized();
        const Vec3 p = x - (x - a).dot(n) * n;  // the projection onto the plane
        const Real u = (b - p).cross(c - p).dot(n), v = (c - p).cross(a - p).dot(n), w = (a - p).cross(b - p).dot(n);
        if (u >= 0 && v >= 0 && w >= 0) best = std::min(best, std::abs((x - a).dot(n)));
        best = std::min({best, segment(a, b), segment(b, c), segment(c, a)});
    }
    return best;
}

}  // namespace

TEST_CASE("mesh distance: a box's signed distance and gradient are the closed form", "[collide][distance]") {
    const Vec3 half(1.0, 0.5, 0.25);
    const TriangleMesh box = makeBox(2 * half, 3);
    const MeshDistance d(box);
    REQUIRE(d.triangleCount() == box.triangles.size());
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<Real> u(-1.6, 1.6);
    int inside = 0, outside = 0;
    Real worst = 0, worstGradient = 0;
    for (int s = 0; s < 4000; ++s) {
        const Vec3 x(u(rng), 0.6 * u(rng), 0.5 * u(rng));
        Vec3 g;
        const Real got = d.signedDistance(x, &g);
        const Real want = boxDistance(x, half);
        worst = std::max(worst, std::abs(got - want));
        (want < 0 ? inside : outside)++;
        CHECK(g.norm() == Approx(1).epsilon(1e-12));
        // The gradient against central differences of the closed form, away from the box's
        // medial surfaces and its edges' and corners' cones, where it is smooth.
        const Real e = 1e-6;
        Vec3 fd;
        for (int a = 0; a < 3; ++a)
            fd[a] = (boxDistance(x + e * Vec3::Unit(a), half) - boxDistance(x - e * Vec3::Unit(a), half)) / (2 * e);
        if (std::abs(fd.norm() - 1) < 1e-6) worstGradient = std::max(worstGradient, (g - fd).norm());
    }
    CHECK(inside > 200);
    CHECK(outside > 2000);
    CHECK(worst < 1e-12);
    CHECK(worstGradient < 1e-5);
    // On the surface: distance 0, the gradient the face's outward normal.
    Vec3 g;
    CHECK(std::abs(d.signedDistance(Vec3(0.3, 0.5, 0.1), &g)) < 1e-15);
    CHECK((g - Vec3::UnitY()).norm() < 1e-12);
    // An empty mesh is infinitely far.
    CHECK(MeshDistance(TriangleMesh{}).signedDistance(Vec3::Zero()) == std::numeric_limits<Real>::infinity());
}

TEST_CASE("mesh distance: the hierarchy finds the nearest triangle of a deformed lattice surface",
          "[collide][distance]") {
    // A voxel ball of radius 6 voxels, sheared and bent: the surface contact between bodies asks about.
    const Real h = 0.05;
    const Lattice lat = test::sphereLattice(6, h, Vec3(-0.3, -0.3, -0.3), Vec3(0.2, 0.1, 0.3));
    std::vector<Vec3> x = restPositions(lat);
    for (Vec3& p : x)
        p = Vec3(p.x() + 0.3 * p.y() + 0.5 * p.z() * p.z(), 0.8 * p.y(), p.z() / 0.8 + 0.2 * std::sin(4 * p.x()));
    const TriangleMesh surface = latticeSurface(lat, x);
    const MeshDistance d(surface);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<Real> u(-0.6, 0.6);
    Real worst = 0;
    int negative = 0;
    for (int s = 0; s < 1500; ++s) {
        const Vec3 q(u(rng), u(rng), u(rng));
        const Real got = d.signedDistance(q);
        worst = std::max(worst, std::abs(std::abs(got) - bruteDistance(surface, q)));
        negative += got < 0 ? 1 : 0;
    }
    CHECK(worst < 1e-13);
    CHECK(negative > 50);
    // At the lattice points: a corner of 8 complete cells is inside, by at least about a voxel
    // after the map (it scales lengths by 0.8 at least); a corner of fewer lies on the surface.
    int inner = 0;
    Real shallowest = std::numeric_limits<Real>::infinity(), offSurface = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        const int cells = completeCellsAt(lat, p);
        const Real s = d.signedDistance(x[static_cast<std::size_t>(p)]);
        if (cells == 8) {
            ++inner;
            shallowest = std::min(shallowest, -s);
        } else if (cells > 0) {
            offSurface = std::max(offSurface, std::abs(s));
        }
    }
    CHECK(inner > 300);
    CHECK(shallowest > 0.5 * h);
    CHECK(offSurface < 1e-15);
}

TEST_CASE("mesh distance: the nearest point's triangle and barycentric coordinates rebuild it, on lattice points",
          "[collide][distance]") {
    // The contact between bodies solved together holds a point against Σ w_j x_(q_j) of the
    // nearest triangle: w must rebuild the nearest point (|x − Σ w_j v_j| = |distance|, and x
    // lies along the gradient from it), and the triangle's vertices must be lattice points.
    const Real h = 0.05;
    const Lattice lat = test::sphereLattice(5, h, Vec3(-0.25, -0.25, -0.25));
    std::vector<Vec3> x = restPositions(lat);
    for (Vec3& p : x) p = Vec3(p.x() + 0.4 * p.y(), 0.9 * p.y() + 0.3 * p.x() * p.x(), p.z());
    std::vector<Index> points;
    const TriangleMesh surface = latticeSurface(lat, x, &points);
    REQUIRE(points.size() == surface.vertices.size());
    for (std::size_t v = 0; v < points.size(); ++v) CHECK(x[at(points[v])] == surface.vertices[v]);
    const MeshDistance d(surface);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<Real> u(-0.4, 0.4);
    Real worstPoint = 0, worstSum = 0, worstDistance = 0;
    for (int s = 0; s < 800; ++s) {
        const Vec3 q(u(rng), u(rng), u(rng));
        const MeshDistance::Closest c = d.closest(q);
        REQUIRE(c.triangle >= 0);
        CHECK(c.distance == d.signedDistance(q));
        CHECK(c.barycentric.minCoeff() >= 0);
        worstSum = std::max(worstSum, std::abs(c.barycentric.sum() - 1));
        Vec3 nearest = Vec3::Zero();
        for (int k = 0; k < 3; ++k)
            nearest += c.barycentric[k] * x[at(points[at(surface.triangles[at(c.triangle)][static_cast<std::size_t>(k)])])];
        worstPoint = std::max(worstPoint, (q - (nearest + c.distance * c.gradient)).norm());
        worstDistance = std::max(worstDistance, std::abs((q - nearest).norm() - std::abs(c.distance)));
    }
    CHECK(worstSum < 1e-14);
    CHECK(worstPoint < 1e-12);
    CHECK(worstDistance < 1e-12);
    // beyond the given distance: no triangle
    CHECK(d.closest(Vec3(3, 0, 0), 0.5).triangle == -1);
}

TEST_CASE("mesh distance: the sign is right beside an edge four faces share", "[collide][distance]") {
    // Two cells that touch along one edge only (the lattice surface is closed but not manifold
    // there): the cells' insides are negative, the two empty quarters beside the edge positive, even where the nearest
    // point is the edge's end.
    const Vec3i dims(3, 3, 2);
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 0);
    auto set = [&](int i, int j, int k) { mask[static_cast<std::size_t>(i + 3 * (j + 3 * k))] = 1; };
    for (int k = 0; k < 2; ++k)
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b < 2; ++b) {
                set(a, b, k);          // cell (0, 0)
                set(1 + a, 1 + b, k);  // cell (1, 1)
            }
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, mask);
    const TriangleMesh surface = latticeSurface(lat, restPositions(lat));
    REQUIRE(surface.triangles.size() == 24);
    const MeshDistance d(surface);
    for (const Real e : {0.3, 0.05, 1e-3}) {
        INFO(e);
        CHECK(d.signedDistance(Vec3(1 - e, 1 - e, 0.5)) == Approx(-e));
        CHECK(d.signedDistance(Vec3(1 + e, 1 + e, 0.5)) == Approx(-e));
        CHECK(d.signedDistance(Vec3(1 + e, 1 - e, 0.5)) == Approx(e));
        CHECK(d.signedDistance(Vec3(1 - e, 1 + e, 0.5)) == Approx(e));
        // Above the top, nearest the cells' top edges that end at the shared corner (1, 1, 1).
        CHECK(d.signedDistance(Vec3(1 + e, 1 - e, 1 + e)) == Approx(e * std::sqrt(2.0)));
    }
}

TEST_CASE("mesh distance: beyond a given distance from the box, the box's distance bounds it", "[collide][distance]") {
    const TriangleMesh sphere = makeSphere(0.5, 32, 16);
    const MeshDistance d(sphere);
    Vec3 g, gFull;
    // Near the box: the exact distance, whatever `beyond` says of farther points.
    const Vec3 near(0.55, 0.1, 0);
    CHECK(d.signedDistance(near, &g, 0.2) == d.signedDistance(near, &gFull));
    CHECK(g == gFull);
    // Farther: the box's distance, below the true one and positive.
    const Vec3 far(0.9, 0.8, 0);
    const Real bound = d.signedDistance(far, &g, 0.2), exact = d.signedDistance(far, &gFull);
    CHECK(bound == Approx(std::hypot(0.4, 0.3)).epsilon(1e-3));
    CHECK(bound > 0.2);
    CHECK(bound < exact);
    CHECK(g.norm() == Approx(1).epsilon(1e-12));
}
