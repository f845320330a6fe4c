// Tests of holonomies along lattice paths (src/solve/holonomy.hpp, seed eqs 12-19): constant
// connections against the closed form, reversal, flat loops, eq 19 against a known field, and
// the edge exponentials (expPhi1, edgeSteps) against Eigen's.
#include <catch2/catch.hpp>

#include "solve/holonomy.hpp"
#include "solve/solve_fixtures.hpp"

#include <Eigen/LU>
#include <unsupported/Eigen/MatrixFunctions>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <random>
#include <vector>

using namespace dgv;
using namespace dgv::test;

namespace {

using Christoffel = std::array<std::vector<Mat3>, 3>;

Christoffel constantConnection(const Lattice& lat, const PointConnection& g) {
    Christoffel c;
    for (int k = 0; k < 3; ++k) c[k].assign(static_cast<std::size_t>(lat.size()), g[k]);
    return c;
}

PointConnection randomSymmetricConnection(std::mt19937& rng, Real scale) {
    std::uniform_real_distribution<Real> u(-scale, scale);
    PointConnection g;
    for (auto& m : g) {
        for (int a = 0; a < 3; ++a)
            for (int b = a; b < 3; ++b) m(a, b) = m(b, a) = u(rng);
    }
    return g;
}

/// Straight run of `steps` points from p along `slot`, appended to path (p excluded).
void run(const Lattice& lat, std::vector<Index>& path, int slot, int steps) {
    for (int i = 0; i < steps; ++i) {
        const Index q = lat.neighbours[static_cast<std::size_t>(path.back())][static_cast<std::size_t>(slot)];
        REQUIRE(q != kNoPoint);
        path.push_back(q);
    }
}

Real rate(Real coarse, Real fine) { return std::log2(coarse / fine); }

}  // namespace

TEST_CASE("holonomy: constant connection gives the closed form exp(-L G)", "[solve]") {
    std::mt19937 rng(7);
    const Lattice lat = boxLattice(Vec3i(10, 6, 4));
    const PointConnection g = randomSymmetricConnection(rng, 0.05);
    const Christoffel chr = constantConnection(lat, g);
    std::vector<Index> path{lat.pointAt(Vec3i(0, 0, 0))};
    run(lat, path, kPlusI, 9);
    const Mat3 gx = connectionMatrix(g, 0), gy = connectionMatrix(g, 1);
    REQUIRE((pathHolonomy(lat, chr, path) - Mat3((-9 * gx).exp())).norm() < 1e-13);
    run(lat, path, kPlusJ, 5);
    const Mat3 expected = Mat3((-5 * gy).exp()) * Mat3((-9 * gx).exp());  // later on the left
    REQUIRE((pathHolonomy(lat, chr, path) - expected).norm() < 1e-13);
    // Γ^c_ab = G_b(c, a): a direction-b step carries coefficient a into c.
    REQUIRE(gx(1, 2) == g[1](2, 0));
    // The single-point path is the identity.
    REQUIRE(pathHolonomy(lat, chr, {path.front()}).isIdentity(0));
}

TEST_CASE("holonomy: a path and its reverse give inverse holonomies", "[solve]") {
    const Lattice lat = boxLattice(Vec3i(8, 8, 8));
    Christoffel chr;
    for (int c = 0; c < 3; ++c) chr[c].resize(static_cast<std::size_t>(lat.size()));
    for (Index p = 0; p < lat.size(); ++p) {
        const Vec3 u = lat.coords[static_cast<std::size_t>(p)].cast<Real>();
        for (int c = 0; c < 3; ++c) {
            Mat3 m;
            for (int a = 0; a < 3; ++a)
                for (int b = a; b < 3; ++b)
                    m(a, b) = m(b, a) = 0.08 * std::sin(0.7 * u.x() + 1.3 * c + a - 0.4 * b * u.y() + 0.3 * u.z());
            chr[c][static_cast<std::size_t>(p)] = m;
        }
    }
    std::mt19937 rng(3);
    std::vector<Index> path{lat.pointAt(Vec3i(4, 4, 4))};
    for (int i = 0; i < 60; ++i) {
        std::vector<Index> options;
        for (Index q : lat.neighbours[static_cast<std::size_t>(path.back())])
            if (q != kNoPoint) options.push_back(q);
        path.push_back(options[std::uniform_int_distribution<std::size_t>(0, options.size() - 1)(rng)]);
    }
    const Mat3 forward = pathHolonomy(lat, chr, path);
    const std::vector<Index> back(path.rbegin(), path.rend());
    const Mat3 backward = pathHolonomy(lat, chr, back);
    REQUIRE(!forward.isIdentity(1e-3));
    REQUIRE((backward * forward - Mat3::Identity()).norm() < 1e-12);
    REQUIRE((forward * backward - Mat3::Identity()).norm() < 1e-12);
}

TEST_CASE("holonomy: closed loops are the identity in a flat volume", "[solve]") {
    // The connection of any embedding in R^3 is flat; with finite differences the loop holonomy
    // is the identity exactly for affine maps and up to the second-order discretisation otherwise.
    SECTION("affine map: identity to round-off") {
        const Lattice lat = boxLattice(Vec3i(9, 9, 9), 0.1);
        Mat3 a;
        a << 1.2, 0.3, -0.1, 0.05, 0.9, 0.2, 0.1, -0.3, 1.1;
        std::vector<Vec3> x = restPositions(lat);
        for (Vec3& p : x) p = a * p + Vec3(3, -1, 2);
        GeometricState st;
        computeGeometricState(lat, x, st);
        std::vector<Index> loop{lat.pointAt(Vec3i(0, 0, 0))};
        run(lat, loop, kPlusI, 8);
        run(lat, loop, kPlusJ, 8);
        run(lat, loop, kPlusK, 8);
        run(lat, loop, kMinusI, 8);
        run(lat, loop, kMinusJ, 8);
        run(lat, loop, kMinusK, 8);
        REQUIRE((pathHolonomy(lat, st.christoffel, loop) - Mat3::Identity()).norm() < 1e-12);
    }
    SECTION("twist: the loop defect falls at second order") {
        Real defect[3];
        for (int level = 0; level < 3; ++level) {
            const int m = 1 << level;
            const int n = 8 * m + 1;
            const Lattice lat = boxLattice(Vec3i(n, n, n), Real(1) / Real(8 * m));
            GeometricState st;
            computeGeometricState(lat, mapped(lat, twistMap(1.2)), st);
            // A fixed physical square in the x-z plane through the middle, off the boundary.
            std::vector<Index> loop{lat.pointAt(Vec3i(2 * m, 4 * m, 2 * m))};
            run(lat, loop, kPlusI, 4 * m);
            run(lat, loop, kPlusK, 4 * m);
            run(lat, loop, kMinusI, 4 * m);
            run(lat, loop, kMinusK, 4 * m);
            defect[level] = (pathHolonomy(lat, st.christoffel, loop) - Mat3::Identity()).norm();
        }
        if (verbose()) std::printf("twist loop defect: %.3e %.3e %.3e\n", defect[0], defect[1], defect[2]);
        REQUIRE(defect[0] < 1e-2);
        REQUIRE(rate(defect[0], defect[1]) > 1.8);
        REQUIRE(rate(defect[1], defect[2]) > 1.8);
    }
}

TEST_CASE("holonomy: eq 19 reproduces a known field along a path", "[solve]") {
    // x(s) = Σ_b (e^{k_b s_b} - 1)/k_b e_b with s = u/m: Γ^b_bb = k_b/m (exact, constant), frames
    // x_b = e^{k_b s_b}/m e_b. A world field V = B x + c has coefficients f^b = x^b·V and
    // f^b_{;a} = x^b·B x_a =: G^b_a. Solving eq 12 along a staircase path from f(γ_0) must give
    // f along the whole path; the trapezoid rule for the driving term is second order.
    const Vec3 k(0.6, -0.4, 0.9);
    Mat3 bMat;
    bMat << 0.3, -1.0, 0.2, 0.5, 0.1, -0.7, 0.4, 0.8, -0.2;
    const Vec3 cVec(0.2, -0.3, 1.0);
    Real err[3];
    for (int level = 0; level < 3; ++level) {
        const int m = 4 << level;
        const int n = 2 * m + 1;
        const Lattice lat = boxLattice(Vec3i(n, n, n));
        Christoffel chr;
        for (int c = 0; c < 3; ++c) {
            Mat3 g = Mat3::Zero();
            g(c, c) = k[c] / m;
            chr[c].assign(static_cast<std::size_t>(lat.size()), g);
        }
        std::vector<Mat3> driving(static_cast<std::size_t>(lat.size()));
        std::vector<Vec3> exact(static_cast<std::size_t>(lat.size()));
        for (Index p = 0; p < lat.size(); ++p) {
            const Vec3 s = lat.coords[static_cast<std::size_t>(p)].cast<Real>() / Real(m);
            Vec3 x, grow;
            for (int b = 0; b < 3; ++b) {
                grow[b] = std::exp(k[b] * s[b]);
                x[b] = (grow[b] - 1) / k[b];
            }
            const Mat3 tangent = (grow / Real(m)).asDiagonal();
            const Mat3 dual = tangent.inverse();  // rows x^b
            exact[static_cast<std::size_t>(p)] = dual * (bMat * x + cVec);
            driving[static_cast<std::size_t>(p)] = dual * bMat * tangent;
        }
        std::vector<Index> path{lat.pointAt(Vec3i(0, 0, 0))};
        run(lat, path, kPlusI, 2 * m);
        run(lat, path, kPlusJ, m);
        run(lat, path, kPlusK, 2 * m);
        run(lat, path, kMinusI, m);
        run(lat, path, kPlusJ, m);
        const std::vector<Vec3> f = solveAlongPath(lat, chr, driving, path, exact[static_cast<std::size_t>(path[0])]);
        REQUIRE(f.size() == path.size());
        Real e = 0, scale = 0;
        for (std::size_t i = 0; i < path.size(); ++i) {
            e = std::max(e, (f[i] - exact[static_cast<std::size_t>(path[i])]).norm());
            scale = std::max(scale, exact[static_cast<std::size_t>(path[i])].norm());
        }
        err[level] = e / scale;
        // The homogeneous part is exact for this constant, commuting connection.
        const Mat3 h = pathHolonomy(lat, chr, path);
        const Vec3 ds =
            (lat.coords[static_cast<std::size_t>(path.back())] - lat.coords[static_cast<std::size_t>(path.front())])
                .cast<Real>() /
            Real(m);
        REQUIRE((h - Mat3((-k.cwiseProduct(ds)).array().exp().matrix().asDiagonal())).norm() < 1e-13);
    }
    if (verbose()) std::printf("eq 19 path error: %.3e %.3e %.3e\n", err[0], err[1], err[2]);
    REQUIRE(err[0] < 1e-2);
    REQUIRE(rate(err[0], err[1]) > 1.9);
    REQUIRE(rate(err[1], err[2]) > 1.9);
}

namespace {

/// Calls check(S, scale) for 20 generators S of each scale, entries normal with that deviation.
template <typename Check>
void forRandomGenerators(unsigned seed, std::initializer_list<Real> scales, Check&& check) {
    std::mt19937 rng(seed);
    std::normal_distribution<Real> n(0, 1);
    for (Real scale : scales)
        for (int trial = 0; trial < 20; ++trial) {
            Mat3 s;
            for (int i = 0; i < 9; ++i) s(i / 3, i % 3) = scale * n(rng);
            check(s, scale);
        }
}

}  // namespace

TEST_CASE("holonomy: expPhi1 agrees with Eigen's Pade exponential", "[solve]") {
    // exp([[S, v], [0, 0]]) = [[exp(S), phi1(S) v], [0, 1]]: an independent reference.
    forRandomGenerators(13, {1e-6, 1e-3, 0.02, 0.1, 0.3, 1.0, 4.0}, [](const Mat3& s, Real scale) {
        Mat4 aug = Mat4::Zero();
        aug.topLeftCorner<3, 3>() = s;
        aug.topRightCorner<3, 1>() = Vec3(0.3, -0.2, 0.7);
        const Mat4 ref = aug.exp();
        Mat3 e, phi;
        expPhi1(s, e, phi);
        // both are backward stable: relative errors ~ u |S| (squarings) times |exp S|
        const Real tol = 1e-15 * (4 + 8 * s.norm()) * std::max(Real(1), ref.norm());
        INFO("scale " << scale << ": " << (e - ref.topLeftCorner<3, 3>()).norm() << " vs " << tol);
        REQUIRE((e - ref.topLeftCorner<3, 3>()).norm() < tol);
        REQUIRE((phi * Vec3(0.3, -0.2, 0.7) - ref.topRightCorner<3, 1>()).norm() < tol);
        // the transport of an edge is the same pair
        Mat3 t;
        Vec3 step;
        edgeTransport(s, 1, t, step);
        REQUIRE(t == e);
        REQUIRE(step == phi.col(1));
    });
}

TEST_CASE("holonomy: edgeSteps gives the step vectors of the edge transport", "[solve]") {
    // from = φ1(S) e_axis and to = φ1(-S) e_axis = exp(-S) φ1(S) e_axis, for generators on
    // both sides of the 1-norm 1/4 where edgeSteps switches from its power sums to expPhi1.
    forRandomGenerators(29, {1e-8, 1e-3, 0.02, 0.05, 0.08, 0.2, 1.0}, [](const Mat3& s, Real scale) {
        for (int axis = 0; axis < 3; ++axis) {
            Mat3 e, phi, eMinus, phiMinus;
            expPhi1(s, e, phi);
            expPhi1(-s, eMinus, phiMinus);
            Vec3 from, to;
            edgeSteps(s, axis, from, to);
            INFO("scale " << scale << " axis " << axis);
            REQUIRE((from - phi.col(axis)).norm() < 4e-16 * phi.norm());
            REQUIRE((to - phiMinus.col(axis)).norm() < 4e-16 * phiMinus.norm());
        }
    });
}

TEST_CASE("holonomy: expPhi1Batch gives each generator the bits it gets alone, whatever shares its batch", "[solve]") {
    // Batches mixing scales, so that their members take different Taylor degrees and different
    // numbers of squarings (the reconstruction's result must not depend on which edges share
    // a batch: δΓ = 0 asks for exactly no step only if both connections' edges match bit for bit).
    std::vector<Mat3> all;
    forRandomGenerators(41, {1e-8, 1e-3, 0.02, 0.1, 0.3, 1.0, 4.0}, [&](const Mat3& s, Real) { all.push_back(s); });
    std::mt19937 rng(7);
    std::shuffle(all.begin(), all.end(), rng);
    std::size_t next = 0;
    int batches = 0;
    while (next < all.size()) {
        const int count = std::min(static_cast<int>(all.size() - next), 1 + batches % 4);
        std::array<Mat3, 4> e, phi;
        expPhi1Batch(&all[next], e.data(), phi.data(), count);
        for (int l = 0; l < count; ++l) {
            Mat3 e1, phi1;
            expPhi1(all[next + static_cast<std::size_t>(l)], e1, phi1);
            REQUIRE(std::memcmp(e1.data(), e[static_cast<std::size_t>(l)].data(), sizeof(Mat3)) == 0);
            REQUIRE(std::memcmp(phi1.data(), phi[static_cast<std::size_t>(l)].data(), sizeof(Mat3)) == 0);
        }
        next += static_cast<std::size_t>(count);
        ++batches;
    }
    CHECK(batches > 50);
    expPhi1Batch(nullptr, nullptr, nullptr, 0);  // an empty batch does nothing
}
