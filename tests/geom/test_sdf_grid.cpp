// Dense signed-distance grids (geom/sdf_grid.hpp): trilinear inside, distance-like outside.

#include "geom/sdf_grid.hpp"

#include <catch2/catch.hpp>

using namespace dgv;

namespace {
/// Samples of f on a grid of `dims` samples from `origin`, spacing h.
template <typename F>
SdfGrid sample(const Vec3& origin, Real h, const Vec3i& dims, F&& f) {
    SdfGrid g;
    g.origin = origin;
    g.spacing = h;
    g.dims = dims;
    for (int k = 0; k < dims.z(); ++k)
        for (int j = 0; j < dims.y(); ++j)
            for (int i = 0; i < dims.x(); ++i) g.values.push_back(float(f(origin + h * Vec3(i, j, k))));
    return g;
}
}  // namespace

TEST_CASE("sdf_grid: a plane's distance and gradient are reproduced exactly inside the box", "[geom][sdf]") {
    const Vec3 n = Vec3(1, 2, -2) / 3.0;
    auto plane = [&](const Vec3& x) { return n.dot(x) - 0.25; };
    const SdfGrid g = sample(Vec3(-1, -0.5, 0.25), 0.125, Vec3i(17, 9, 12), plane);
    const Box3 b = g.bounds();
    CHECK((b.max - Vec3(1, 0.5, 1.625)).norm() < 1e-12);
    for (const Vec3& x : {Vec3(0.1, 0.2, 0.3), Vec3(-0.93, -0.41, 1.6), Vec3(0.999, 0.4999, 0.26), b.min, b.max}) {
        INFO(x.transpose());
        CHECK(g.distance(x) == Approx(plane(x)).margin(1e-6));  // float samples
        CHECK((g.gradient(x) - n).norm() < 1e-5);
    }
}

TEST_CASE("sdf_grid: outside the box, boundary value plus the distance to the box", "[geom][sdf]") {
    auto f = [](const Vec3& x) { return x.norm() - 0.5; };
    const SdfGrid g = sample(Vec3::Constant(-1), 0.25, Vec3i(9, 9, 9), f);
    // straight out along +x from the face centre: d = f(1,0,0) + 2
    CHECK(g.distance(Vec3(3, 0, 0)) == Approx(0.5 + 2).margin(1e-6));
    CHECK(g.gradient(Vec3(3, 0, 0)).x() == Approx(1));
    // beyond a corner: the gradient is the unit vector from the box corner
    const Vec3 x(2, 2, -3);
    const Vec3 c(1, 1, -1);
    CHECK(g.distance(x) == Approx(g.distance(c) + (x - c).norm()).margin(1e-9));
    CHECK((g.gradient(x) - (x - c).normalized()).norm() < 1e-12);
    // continuous across the box boundary, and the gradient matches finite differences
    const Vec3 y(1.0 + 1e-9, 0.3, 0.2);
    CHECK(g.distance(y) == Approx(g.distance(Vec3(1.0, 0.3, 0.2))).margin(1e-8));
    for (const Vec3& p : {Vec3(0.3, -0.2, 0.55), Vec3(1.5, 0.3, 0.2), Vec3(-2, 0.1, 0.6)}) {
        const Real e = 1e-6;
        Vec3 fd;
        for (int a = 0; a < 3; ++a)
            fd[a] = (g.distance(p + e * Vec3::Unit(a)) - g.distance(p - e * Vec3::Unit(a))) / (2 * e);
        INFO(p.transpose());
        CHECK((g.gradient(p) - fd).norm() < 1e-5);
    }
}
