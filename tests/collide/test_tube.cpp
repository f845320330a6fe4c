// Tubes around closed curves (geom/tube.hpp), used to draw the GLN figures: closed, manifold,
// outward, the right radius. (Listed with the collide tests: the curves they draw live here.)

#include "geom/tube.hpp"
#include "tests/collide/curves.hpp"

#include <catch2/catch.hpp>

#include <map>
#include <utility>

using namespace dgv;

TEST_CASE("tube: closed, manifold, outward, at the given radius", "[collide][gln]") {
    const int n = 128, sides = 12;
    const Real R = 1, r = 0.05;
    const ClosedCurve ring = test::ring(Vec3(0.5, -1, 2), Vec3::UnitX(), Vec3(0, 0.6, 0.8), R, n);
    for (const ClosedCurve& curve : {ring, test::torusCurve(2, 0.7, 3, 0.4, 300)}) {
        const TriangleMesh m = makeTube(curve, r, sides);
        const int nv = static_cast<int>(curve.size());
        REQUIRE(m.vertexCount() == static_cast<std::size_t>(nv * sides));
        REQUIRE(m.triangleCount() == static_cast<std::size_t>(2 * nv * sides));
        // Each cross-section: at distance r from its curve vertex.
        for (int i = 0; i < nv; ++i)
            for (int s = 0; s < sides; ++s)
                REQUIRE(
                    std::abs((m.vertices[static_cast<std::size_t>(i * sides + s)] - curve[static_cast<std::size_t>(i)])
                                 .norm() -
                             r) < 1e-12);
        // Closed and consistently oriented: every directed edge once, its reverse once.
        std::map<std::pair<int, int>, int> directed;
        for (const auto& t : m.triangles)
            for (int k = 0; k < 3; ++k)
                ++directed[{t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]}];
        for (const auto& [e, count] : directed) {
            REQUIRE(count == 1);
            REQUIRE(directed.count({e.second, e.first}) == 1);
        }
    }
    // Outward: the enclosed volume (divergence theorem) is positive and, by Pappus, the
    // cross-section's area times the length of the centre line (the polygon's area
    // (sides/2) r² sin(2π/sides)); the ring's polyline has length 2nR sin(π/n).
    const TriangleMesh m = makeTube(ring, r, sides);
    Real volume = 0;
    for (const auto& t : m.triangles)
        volume += m.vertices[static_cast<std::size_t>(t[0])].dot(
                      m.vertices[static_cast<std::size_t>(t[1])].cross(m.vertices[static_cast<std::size_t>(t[2])])) /
                  6;
    const Real expected = sides / 2.0 * r * r * std::sin(2 * M_PI / sides) * 2 * n * R * std::sin(M_PI / n);
    INFO("volume " << volume << " expected " << expected);
    // The sections are normal to the central-difference tangent, so consecutive prisms are
    // wedges whose volumes differ from area × chord by O((r/R)²) relative: well under 1%.
    CHECK(std::abs(volume - expected) < 0.01 * expected);
}
