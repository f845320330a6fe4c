// Tests of the displacement representation (src/deform/displacement.hpp): eqs 35-39, 42-43,
// 62-63; exact for affine maps, and the deformed metric converging at finite-difference order.
#include <catch2/catch.hpp>

#include "deform/displacement.hpp"
#include "deform_test_util.hpp"
#include "geom/geometric_state.hpp"

#include <Eigen/LU>

#include <cmath>
#include <cstdio>
#include <random>

using namespace dgv;
using namespace dgv::test;

TEST_CASE("displacement: eps round trip and affine maps are exact", "[deform]") {
    const Lattice lat = boxLattice(Vec3i(6, 5, 4), 1, 0.7, Vec3(1, -2, 3));
    // a curved rest configuration
    const std::vector<Vec3> x = mapPoints(restPositions(lat), bendMap(9.0, Vec3(3, 1, 4)));
    GeometricState rest;
    computeGeometricState(lat, x, rest);
    Mat3 A;
    A << 1.1, 0.2, -0.1, 0.05, 0.9, 0.3, -0.2, 0.1, 1.2;
    const Vec3 b(0.3, -0.4, 0.5);
    std::vector<Vec3> X(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) X[i] = A * x[i] + b;
    const std::vector<Vec3> eps = displacementCoefficients(rest, X);
    const std::vector<Vec3> back = displacedPositions(rest, eps);
    for (std::size_t i = 0; i < x.size(); ++i) REQUIRE((back[i] - X[i]).norm() < 1e-12);

    // On the flat lattice an affine map has M = A^T exactly (also at the boundary), det M =
    // det A, and gbar = M g M^T equals the metric of the mapped lattice.
    GeometricState flat, mapped;
    const std::vector<Vec3> x0 = restPositions(lat);
    computeGeometricState(lat, x0, flat);
    std::vector<Vec3> X0(x0.size());
    for (std::size_t i = 0; i < x0.size(); ++i) X0[i] = A * x0[i] + b;
    computeGeometricState(lat, X0, mapped);
    const std::vector<Mat3> M = deformationMatrices(lat, flat, displacementCoefficients(flat, X0));
    for (Index p = 0; p < lat.size(); ++p) {
        REQUIRE((M[p] - A.transpose()).norm() < 1e-12);
        const Mat3 gbar = deformedMetric(M[p], flat.metric[p]);
        REQUIRE((gbar - mapped.metric[p]).norm() < 1e-12 * mapped.metric[p].norm());
        Mat3 frame;
        frame << flat.tangent[0][p], flat.tangent[1][p], flat.tangent[2][p];
        Mat3 frameBar;
        frameBar << mapped.tangent[0][p], mapped.tangent[1][p], mapped.tangent[2][p];
        REQUIRE((deformedFrame(frame, M[p]) - frameBar).norm() < 1e-12);
        // eq 43
        REQUIRE(gbar.determinant() ==
                Approx(flat.metric[p].determinant() * std::pow(M[p].determinant(), 2)).epsilon(1e-12));
    }
}

TEST_CASE("displacement: eqs 37-38 hold exactly on the lattice, the covariant derivative of eps is eq 11 at 2nd order",
          "[deform]") {
    // M from eps with the discrete covariant derivative of displacement.hpp: the deformed
    // tangents X_a = sum_c M(a, c) x_c and metric gbar = M g M^T equal those computed from the
    // deformed positions to round-off at EVERY point (boundary included). In the continuum
    // eps^c_{;a} is eq 11, d eps^c/du_a + sum_b eps^b Gamma^c_ba: geom's covariantDerivative
    // discretises that form literally, and the two agree at 2nd order inside.
    const Vec3i cells(16, 8, 8);
    const Vec3 centre(8, 4, 4);
    struct Case {
        const char* name;
        MapFn rest, deform;
    };
    const Case cases[] = {
        {"twist on flat", [](const Vec3& p) { return p; }, twistMap(0.05, centre)},
        {"stretch on bent", bendMap(20.0, centre), stretchMap(0.1, centre, 8.0)},
        {"bend on twisted", twistMap(0.03, centre), bendMap(15.0, centre)},
    };
    for (const Case& cs : cases) {
        Real prev = 0, worstOrder = 10;
        for (int m : {1, 2, 4}) {
            const Lattice lat = boxLattice(cells, m, 1);
            const std::vector<Vec3> x = mapPoints(restPositions(lat), cs.rest);
            const std::vector<Vec3> X = mapPoints(x, cs.deform);
            GeometricState rest, def;
            computeGeometricState(lat, x, rest);
            computeGeometricState(lat, X, def);
            const std::vector<Vec3> eps = displacementCoefficients(rest, X);
            const std::vector<Mat3> M = deformationMatrices(lat, rest, eps);
            const std::vector<Mat3> literal = covariantDerivative(lat, rest, eps);  // (c, a)
            Real exact = 0, err = 0, ref = 0;
            for (Index p = 0; p < lat.size(); ++p) {
                Mat3 frame, frameBar;
                frame << rest.tangent[0][p], rest.tangent[1][p], rest.tangent[2][p];
                frameBar << def.tangent[0][p], def.tangent[1][p], def.tangent[2][p];
                exact = std::max(exact, (deformedFrame(frame, M[p]) - frameBar).norm() / frameBar.norm());
                exact = std::max(exact,
                                 (deformedMetric(M[p], rest.metric[p]) - def.metric[p]).norm() / def.metric[p].norm());
                if (!innerPoint(lat, p, 0.2)) continue;
                const Mat3 D = M[p] - Mat3::Identity();
                err = std::max(err, (D - literal[p].transpose()).norm());
                ref = std::max(ref, D.norm());
            }
            CHECK(exact < 1e-13);
            const Real rel = err / ref;
            if (prev > 0) worstOrder = std::min(worstOrder, std::log2(prev / rel));
            if (verbose())
                std::printf("eps_;a %s m=%d: eqs 37-38 rel err %.1e, against eq 11 literal %.3e\n", cs.name, m, exact,
                            rel);
            prev = rel;
        }
        INFO(cs.name);
        CHECK(worstOrder > 1.8);
    }
}

TEST_CASE("displacement: strain and pressure (eqs 62-63)", "[deform]") {
    const Mat3 M = Vec3(1.03, 0.99, 1.0).asDiagonal();
    CHECK(pressure(M) == Approx(-0.02 / 3).epsilon(1e-12));
    CHECK(pressure(Mat3::Identity()) == 0);
    Mat3 S = Mat3::Identity();
    S(0, 1) = 0.02;  // simple shear: no pressure, symmetric strain 0.01 off the diagonal
    CHECK(std::abs(pressure(S)) < 1e-15);
    const Mat3 tau = strain(S);
    CHECK(tau(0, 1) == Approx(0.01));
    CHECK(tau(1, 0) == Approx(0.01));
    CHECK(tau.diagonal().norm() < 1e-15);
    // pressure is the linearised volume change: det M ~ 1 - 3p
    const Mat3 small = Mat3::Identity() + 1e-4 * (Mat3() << 1, 2, 3, 4, 5, 6, 7, 8, 10).finished();
    CHECK(small.determinant() - 1 == Approx(-3 * pressure(small)).epsilon(1e-3));
}
