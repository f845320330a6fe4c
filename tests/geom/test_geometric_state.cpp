// Tests of the geometric state (src/geom/geometric_state.hpp): tangents, metric, duals, Christoffel
// symbols (eqs 1-8) and the covariant derivative (eq 11), against affine maps (exact), and the
// twist, cylindrical and spherical maps (closed forms, convergence rates).
#include <catch2/catch.hpp>

#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>

using namespace dgv;

namespace {

using MapFn = std::function<Vec3(const Vec3&)>;
/// Exact Christoffel symbols of a map in its own parameters: returns Gamma^c as (a,b) matrix.
using GammaFn = std::function<Mat3(const Vec3&, int)>;

bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

std::vector<unsigned char> fullMask(const Vec3i& dims) {
    return std::vector<unsigned char>(static_cast<std::size_t>(dims.prod()), 1);
}

std::vector<unsigned char> sphereMask(const Vec3i& dims, const Vec3& centre, Real radius) {
    std::vector<unsigned char> m(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < dims.z(); ++k)
        for (int j = 0; j < dims.y(); ++j)
            for (int i = 0; i < dims.x(); ++i)
                if ((Vec3(i, j, k) - centre).norm() <= radius)
                    m[static_cast<std::size_t>(i + dims.x() * (j + dims.y() * k))] = 1;
    return m;
}

/// A box of parameter space sampled at refinement m: s = s0 + (step0 / m) * u.
struct Sampled {
    Lattice lat;
    Vec3 s0, step;
    std::vector<Vec3> x;
    Vec3 param(Index p) const { return s0 + step.cwiseProduct(lat.coords[p].cast<Real>()); }
    /// Whether p lies at least `margin` (a fraction of the extent) inside the parameter box: a
    /// region fixed in space whatever the refinement.
    bool inner(Index p, Real margin) const {
        const Vec3i& u = lat.coords[p];
        for (int a = 0; a < 3; ++a) {
            const Real t = Real(u[a]) / Real(lat.dims[a] - 1);
            if (t < margin || t > 1 - margin) return false;
        }
        return true;
    }
    bool interior(Index p, int layers = 1) const {
        const Vec3i& u = lat.coords[p];
        for (int a = 0; a < 3; ++a)
            if (u[a] < layers || u[a] > lat.dims[a] - 1 - layers) return false;
        return true;
    }
};

Sampled sampleBox(const Vec3i& cells, int m, const Vec3& s0, const Vec3& step0, const MapFn& phi) {
    Sampled s;
    const Vec3i dims = cells * m + Vec3i::Ones();
    s.lat = buildLattice(Vec3::Zero(), 1, dims, fullMask(dims));
    s.s0 = s0;
    s.step = step0 / Real(m);
    s.x.resize(s.lat.size());
    for (Index p = 0; p < s.lat.size(); ++p) s.x[p] = phi(s.param(p));
    return s;
}

/// Exact lattice-coordinate symbols: Gamma^c_ab(u) = step_a step_b / step_c * Gamma-hat(s).
Mat3 latticeGamma(const Sampled& s, const GammaFn& exact, Index p, int c) {
    const Mat3 g = exact(s.param(p), c);
    Mat3 r;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) r(a, b) = g(a, b) * s.step[a] * s.step[b] / s.step[c];
    return r;
}

struct ErrorSplit {
    Real interior = 0;  ///< max |Gamma - exact| over interior points / max |exact|
    Real boundary = 0;
};

ErrorSplit gammaError(const Sampled& s, const GeometricState& st, const GammaFn& exact) {
    Real scale = 0, eIn = 0, eBd = 0;
    for (Index p = 0; p < s.lat.size(); ++p) {
        for (int c = 0; c < 3; ++c) {
            const Mat3 ex = latticeGamma(s, exact, p, c);
            scale = std::max(scale, ex.cwiseAbs().maxCoeff());
            const Real e = (st.christoffel[c][p] - ex).cwiseAbs().maxCoeff();
            (s.interior(p) ? eIn : eBd) = std::max(s.interior(p) ? eIn : eBd, e);
        }
    }
    REQUIRE(scale > 0);
    return {eIn / scale, eBd / scale};
}

struct Rates {
    std::array<ErrorSplit, 3> errors;
    std::array<Real, 2> interior, boundary;
};

Rates measureRates(const char* name, const Vec3i& cells, const Vec3& s0, const Vec3& step0, const MapFn& phi,
                   const GammaFn& exact) {
    Rates r;
    for (int level = 0; level < 3; ++level) {
        const Sampled s = sampleBox(cells, 1 << level, s0, step0, phi);
        GeometricState st;
        computeGeometricState(s.lat, s.x, st);
        r.errors[level] = gammaError(s, st, exact);
    }
    for (int i = 0; i < 2; ++i) {
        r.interior[i] = std::log2(r.errors[i].interior / r.errors[i + 1].interior);
        r.boundary[i] = std::log2(r.errors[i].boundary / r.errors[i + 1].boundary);
    }
    if (verbose()) {
        std::printf(
            "%s: interior rel. error %.3e %.3e %.3e (orders %.2f %.2f); "
            "boundary %.3e "
            "%.3e %.3e (orders %.2f %.2f)\n",
            name, r.errors[0].interior, r.errors[1].interior, r.errors[2].interior, r.interior[0], r.interior[1],
            r.errors[0].boundary, r.errors[1].boundary, r.errors[2].boundary, r.boundary[0], r.boundary[1]);
    }
    INFO(name << " interior errors " << r.errors[0].interior << " " << r.errors[1].interior << " "
              << r.errors[2].interior << "; boundary " << r.errors[0].boundary << " " << r.errors[1].boundary << " "
              << r.errors[2].boundary);
    CHECK(r.interior[0] > 1.8);
    CHECK(r.interior[1] > 1.8);
    CHECK(r.boundary[0] > 0.8);
    CHECK(r.boundary[1] > 0.8);
    return r;
}

// ---- the maps
// -----------------------------------------------------------------------------

/// Twist about z: kappa radians per unit of z, about the axis through `centre`.
struct Twist {
    Real kappa;
    Vec3 centre;
    Vec3 operator()(const Vec3& s) const {
        const Vec3 d = s - centre;
        const Real t = kappa * d.z(), c = std::cos(t), sn = std::sin(t);
        return Vec3(d.x() * c - d.y() * sn, d.x() * sn + d.y() * c, d.z());
    }
    Mat3 jacobian(const Vec3& s) const {
        const Vec3 d = s - centre;
        const Real t = kappa * d.z(), c = std::cos(t), sn = std::sin(t);
        Mat3 j;
        j.col(0) = Vec3(c, sn, 0);
        j.col(1) = Vec3(-sn, c, 0);
        j.col(2) = Vec3(kappa * (-d.x() * sn - d.y() * c), kappa * (d.x() * c - d.y() * sn), 1);
        return j;
    }
    /// Second derivatives d^2 phi / ds_a ds_b.
    Vec3 hessian(const Vec3& s, int a, int b) const {
        const Vec3 d = s - centre;
        const Real t = kappa * d.z(), c = std::cos(t), sn = std::sin(t);
        if (a > b) std::swap(a, b);
        if (b != 2) return Vec3::Zero();
        if (a == 0) return kappa * Vec3(-sn, c, 0);
        if (a == 1) return kappa * Vec3(-c, -sn, 0);
        return -kappa * kappa * Vec3(d.x() * c - d.y() * sn, d.x() * sn + d.y() * c, 0);
    }
    Mat3 gamma(const Vec3& s, int c) const {
        const Mat3 jInv = jacobian(s).inverse();
        Mat3 g;
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) g(a, b) = jInv.row(c).dot(hessian(s, a, b));
        return g;
    }
};

/// Cylindrical coordinates (r, theta, z).
Vec3 cylindrical(const Vec3& s) { return Vec3(s[0] * std::cos(s[1]), s[0] * std::sin(s[1]), s[2]); }
Mat3 cylindricalGamma(const Vec3& s, int c) {
    Mat3 g = Mat3::Zero();
    const Real r = s[0];
    if (c == 0) g(1, 1) = -r;                     // Gamma^r_thth = -r
    if (c == 1) g(0, 1) = g(1, 0) = Real(1) / r;  // Gamma^th_rth = 1/r
    return g;
}

/// Spherical coordinates (r, theta, phi), theta from the pole.
Vec3 spherical(const Vec3& s) {
    const Real r = s[0], th = s[1], ph = s[2];
    return r * Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
}
Mat3 sphericalGamma(const Vec3& s, int c) {
    Mat3 g = Mat3::Zero();
    const Real r = s[0], th = s[1];
    const Real sn = std::sin(th), cs = std::cos(th);
    if (c == 0) {
        g(1, 1) = -r;            // Gamma^r_thth
        g(2, 2) = -r * sn * sn;  // Gamma^r_phph
    } else if (c == 1) {
        g(0, 1) = g(1, 0) = 1 / r;  // Gamma^th_rth
        g(2, 2) = -sn * cs;         // Gamma^th_phph
    } else {
        g(0, 2) = g(2, 0) = 1 / r;    // Gamma^ph_rph
        g(1, 2) = g(2, 1) = cs / sn;  // Gamma^ph_thph
    }
    return g;
}

Real maxAbsGamma(const GeometricState& st) {
    Real m = 0;
    for (int c = 0; c < 3; ++c)
        for (const Mat3& g : st.christoffel[c]) m = std::max(m, g.cwiseAbs().maxCoeff());
    return m;
}

Mat3 randomAffine(std::mt19937_64& rng) {
    std::uniform_real_distribution<Real> d(-0.6, 0.6);
    for (;;) {
        Mat3 a = Mat3::Identity() * 1.3;
        for (int i = 0; i < 9; ++i) a(i / 3, i % 3) += d(rng);
        if (a.determinant() > 0.3) return a;
    }
}

/// Sphere plus a one-voxel-thin sheet and a one-voxel rod and an isolated point.
Lattice awkwardLattice() {
    const Vec3i dims(24, 20, 20);
    std::vector<unsigned char> mask = sphereMask(dims, {9, 9.5, 9.5}, 7.2);
    auto set = [&](int i, int j, int k) { mask[static_cast<std::size_t>(i + dims.x() * (j + dims.y() * k))] = 1; };
    for (int j = 2; j < 8; ++j)
        for (int i = 18; i < 23; ++i) set(i, j, 3);  // sheet, normal k
    for (int k = 10; k < 18; ++k) set(20, 15, k);    // rod along k
    set(22, 18, 1);                                  // isolated point
    return buildLattice(Vec3(-1, 0.5, 2), 0.7, dims, mask);
}

}  // namespace

TEST_CASE(
    "geometric state: rest lattice has h e_a frames, h^2 metric, zero "
    "connection",
    "[geom]") {
    const Lattice lat = awkwardLattice();
    GeometricState st;
    computeGeometricState(lat, restPositions(lat), st);
    const Real h = lat.spacing;
    REQUIRE(st.size() == lat.size());
    for (Index p = 0; p < lat.size(); ++p) {
        for (int a = 0; a < 3; ++a) {
            REQUIRE((st.tangent[a][p] - h * Vec3::Unit(a)).norm() < 1e-13);
            REQUIRE((st.dual[a][p] - Vec3::Unit(a) / h).norm() < 1e-12);
        }
        REQUIRE((st.metric[p] - h * h * Mat3::Identity()).norm() < 1e-13);
        REQUIRE((st.metricInv[p] - Mat3::Identity() / (h * h)).norm() < 1e-12);
    }
    REQUIRE(maxAbsGamma(st) < 1e-12);
}

TEST_CASE("geometric state: affine maps give zero connection and exact duals", "[geom]") {
    const Lattice lat = awkwardLattice();
    const std::vector<Vec3> rest = restPositions(lat);
    std::mt19937_64 rng(12345);
    for (int trial = 0; trial < 4; ++trial) {
        const Mat3 a = randomAffine(rng);
        const Vec3 b(3.5 * trial - 2, 1.25, -7);
        std::vector<Vec3> x(rest.size());
        for (std::size_t p = 0; p < x.size(); ++p) x[p] = a * rest[p] + b;
        GeometricState st;
        computeGeometricState(lat, x, st);
        INFO("trial " << trial << " det " << a.determinant());
        REQUIRE(maxAbsGamma(st) < 1e-12);
        Real dualErr = 0, invErr = 0, tanErr = 0;
        for (Index p = 0; p < lat.size(); ++p) {
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    dualErr = std::max(dualErr, std::abs(st.dual[i][p].dot(st.tangent[j][p]) - (i == j ? 1.0 : 0.0)));
            invErr = std::max(invErr, (st.metric[p] * st.metricInv[p] - Mat3::Identity()).cwiseAbs().maxCoeff());
            // Frames with a finite difference on every axis are exactly h A e_a.
            bool full = true;
            for (int s = 0; s < 6; s += 2)
                full = full && (lat.neighbours[p][s] != kNoPoint || lat.neighbours[p][s + 1] != kNoPoint);
            if (full)
                for (int i = 0; i < 3; ++i)
                    tanErr = std::max(tanErr, (st.tangent[i][p] - lat.spacing * a.col(i)).norm());
        }
        REQUIRE(dualErr < 1e-12);
        REQUIRE(invErr < 1e-12);
        REQUIRE(tanErr < 1e-12);
    }
}

TEST_CASE("geometric state: connection is invariant under x -> A x + b", "[geom]") {
    const Lattice lat = awkwardLattice();
    const std::vector<Vec3> rest = restPositions(lat);
    const Twist twist{0.06 / lat.spacing, Vec3(5, 7, 9)};
    std::vector<Vec3> x(rest.size()), y(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = twist(rest[p]);
    std::mt19937_64 rng(777);
    const Mat3 a = randomAffine(rng);
    const Vec3 b(10, -20, 30);
    for (std::size_t p = 0; p < x.size(); ++p) y[p] = a * x[p] + b;
    GeometricState sx, sy;
    computeGeometricState(lat, x, sx);
    computeGeometricState(lat, y, sy);
    const Real scale = maxAbsGamma(sx);
    REQUIRE(scale > 0.01);
    // The ball (component 0 or 1, the larger): every frame from differences, so invariant. The thin
    // sheet, rod and isolated point have made-up normals (completeFrame) that follow rigid motions
    // only, so they are excluded.
    std::vector<Index> sizes(static_cast<std::size_t>(lat.components), 0);
    for (int c : lat.component) ++sizes[static_cast<std::size_t>(c)];
    const int ball = static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
    Real diff = 0;
    for (int c = 0; c < 3; ++c)
        for (Index p = 0; p < lat.size(); ++p)
            if (lat.component[p] == ball)
                diff = std::max(diff, (sx.christoffel[c][p] - sy.christoffel[c][p]).cwiseAbs().maxCoeff());
    INFO("max |Gamma(Ax+b) - Gamma(x)| / max |Gamma| = " << diff / scale);
    // Round-off of second differences of positions of size |b| ~ 37 (measured 1.2e-12).
    REQUIRE(diff / scale < 5e-12);
}

TEST_CASE("geometric state: duals and inverse metric on a curved map", "[geom]") {
    const Sampled s = sampleBox({8, 8, 8}, 2, Vec3(1, 0.5, 0), Vec3(0.125, 0.1, 0.125), spherical);
    GeometricState st;
    computeGeometricState(s.lat, s.x, st);
    Real dualErr = 0, invErr = 0, symErr = 0;
    for (Index p = 0; p < s.lat.size(); ++p) {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                dualErr = std::max(dualErr, std::abs(st.dual[i][p].dot(st.tangent[j][p]) - (i == j)));
        invErr = std::max(invErr, (st.metric[p] * st.metricInv[p] - Mat3::Identity()).cwiseAbs().maxCoeff());
        invErr = std::max(invErr, (st.metricInv[p] * st.metric[p] - Mat3::Identity()).cwiseAbs().maxCoeff());
        for (int c = 0; c < 3; ++c) {
            symErr = std::max(symErr, (st.christoffel[c][p] - st.christoffel[c][p].transpose()).norm());
            // Gamma^c_ab = x^c . x_ab, and x_ab = sum_c Gamma^c_ab x_c (eq 7) for the stored x_ab.
        }
        for (int k = 0; k < 6; ++k) {
            const int a = kSymmetricPairs[k][0], b = kSymmetricPairs[k][1];
            Vec3 rebuilt = Vec3::Zero();
            for (int c = 0; c < 3; ++c) rebuilt += st.christoffel[c][p](a, b) * st.tangent[c][p];
            REQUIRE((rebuilt - st.second[k][p]).norm() <= 1e-12 * (1 + st.second[k][p].norm()));
        }
    }
    REQUIRE(dualErr < 1e-12);
    REQUIRE(invErr < 1e-12);
    REQUIRE(symErr == 0);
}

TEST_CASE("geometric state: twist converges at 2nd order inside, 1st at the boundary", "[geom]") {
    // 0.05 rad per voxel on a 16 x 8 x 8 box at the coarsest spacing (h = 1).
    const Twist twist{0.05, Vec3(8, 4, 4)};
    const Rates r = measureRates("twist", {16, 8, 8}, Vec3::Zero(), Vec3::Ones(), twist,
                                 [&](const Vec3& s, int c) { return twist.gamma(s, c); });
    // The prototype measured 4.2e-4 at the coarsest spacing (docs/math.md).
    CHECK(r.errors[0].interior < 1e-3);
}

TEST_CASE("geometric state: cylindrical coordinates, textbook symbols, rates", "[geom]") {
    measureRates("cylindrical", {8, 8, 4}, Vec3(1, 0, 0), Vec3(0.125, 0.15, 0.25), cylindrical, cylindricalGamma);
}

TEST_CASE("geometric state: spherical coordinates, textbook symbols, rates", "[geom]") {
    measureRates("spherical", {8, 8, 8}, Vec3(1, 0.5, 0), Vec3(0.125, 0.1, 0.125), spherical, sphericalGamma);
}

TEST_CASE("geometric state: trace of the connection is d ln det F", "[geom]") {
    SECTION("twist: det F = 1, so sum_b Gamma^b_ab = 0 inside") {
        const Twist twist{0.05, Vec3(8, 4, 4)};
        const Sampled s = sampleBox({16, 8, 8}, 1, Vec3::Zero(), Vec3::Ones(), twist);
        GeometricState st;
        computeGeometricState(s.lat, s.x, st);
        Real worst = 0;
        for (Index p = 0; p < s.lat.size(); ++p) {
            if (!s.interior(p)) continue;
            for (int a = 0; a < 3; ++a) {
                Real tr = 0;
                for (int b = 0; b < 3; ++b) tr += st.christoffel[b][p](a, b);
                worst = std::max(worst, std::abs(tr));
            }
        }
        INFO("max |sum_b Gamma^b_ab| = " << worst << ", max |Gamma| = " << maxAbsGamma(st));
        REQUIRE(maxAbsGamma(st) > 0.04);
        REQUIRE(worst < 1e-12);
    }
    SECTION(
        "spherical: sum_b Gamma^b_ab = d_a ln(r^2 sin theta), converging at "
        "2nd order") {
        std::array<Real, 3> err{};
        for (int level = 0; level < 3; ++level) {
            const Sampled s = sampleBox({8, 8, 8}, 1 << level, Vec3(1, 0.5, 0), Vec3(0.125, 0.1, 0.125), spherical);
            GeometricState st;
            computeGeometricState(s.lat, s.x, st);
            Real worst = 0, scale = 0;
            for (Index p = 0; p < s.lat.size(); ++p) {
                if (!s.interior(p)) continue;
                const Vec3 sp = s.param(p);
                // d/du_a = step_a d/ds_a
                const Vec3 exact(2 / sp[0] * s.step[0], std::cos(sp[1]) / std::sin(sp[1]) * s.step[1], 0);
                for (int a = 0; a < 3; ++a) {
                    Real tr = 0;
                    for (int b = 0; b < 3; ++b) tr += st.christoffel[b][p](a, b);
                    worst = std::max(worst, std::abs(tr - exact[a]));
                    scale = std::max(scale, std::abs(exact[a]));
                }
            }
            err[level] = worst / scale;
        }
        INFO("relative errors " << err[0] << " " << err[1] << " " << err[2]);
        REQUIRE(std::log2(err[0] / err[1]) > 1.8);
        REQUIRE(std::log2(err[1] / err[2]) > 1.8);
    }
}

TEST_CASE(
    "covariant derivative: constant world vector has zero derivative "
    "(converging)",
    "[geom]") {
    // f = V constant in space, f^b = x^b . V: df/du_a = 0, so f^b_{;a} -> 0 at 2nd order inside.
    const Vec3 v(0.3, -1.1, 0.7);
    // Measured on a region fixed in space (the central half of each parameter range).
    std::array<Real, 3> err{};
    for (int level = 0; level < 3; ++level) {
        const Sampled s = sampleBox({8, 8, 8}, 1 << level, Vec3(1, 0.5, 0), Vec3(0.125, 0.1, 0.125), spherical);
        GeometricState st;
        computeGeometricState(s.lat, s.x, st);
        std::vector<Vec3> f(s.lat.size());
        for (Index p = 0; p < s.lat.size(); ++p)
            f[p] = Vec3(st.dual[0][p].dot(v), st.dual[1][p].dot(v), st.dual[2][p].dot(v));
        const std::vector<Mat3> cov = covariantDerivative(s.lat, st, f);
        REQUIRE(cov.size() == f.size());
        Real worst = 0, scale = 0;
        for (Index p = 0; p < s.lat.size(); ++p) {
            if (!s.inner(p, 0.25)) continue;
            worst = std::max(worst, cov[p].cwiseAbs().maxCoeff());
            // Size of each of the two terms that cancel: the connection term.
            for (int b = 0; b < 3; ++b) scale = std::max(scale, (st.christoffel[b][p] * f[p]).cwiseAbs().maxCoeff());
        }
        err[level] = worst / scale;
    }
    if (verbose())
        std::printf(
            "covariant derivative of a constant vector: rel. error %.3e "
            "%.3e %.3e\n",
            err[0], err[1], err[2]);
    INFO("relative errors " << err[0] << " " << err[1] << " " << err[2]);
    REQUIRE(err[0] < 0.03);
    REQUIRE(std::log2(err[0] / err[1]) > 1.8);
    REQUIRE(std::log2(err[1] / err[2]) > 1.8);
}

TEST_CASE("covariant derivative: linear field on an affine lattice is exact", "[geom]") {
    const Lattice lat = awkwardLattice();
    const std::vector<Vec3> rest = restPositions(lat);
    std::mt19937_64 rng(99);
    const Mat3 a = randomAffine(rng);
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = a * rest[p] + Vec3(1, 2, 3);
    GeometricState st;
    computeGeometricState(lat, x, st);
    Mat3 m;
    m << 0.5, -1, 2, 0.25, 3, -0.75, 1, 1, -2;
    const Vec3 c0(4, -5, 6);
    std::vector<Vec3> f(rest.size());
    for (Index p = 0; p < lat.size(); ++p) f[p] = c0 + m * lat.coords[p].cast<Real>();
    const std::vector<Mat3> cov = covariantDerivative(lat, st, f);
    Real worst = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        for (int ax = 0; ax < 3; ++ax) {
            const bool has = lat.neighbours[p][2 * ax] != kNoPoint || lat.neighbours[p][2 * ax + 1] != kNoPoint;
            // Axes without neighbours have no derivative (0), by definition.
            const Vec3 expected = has ? Vec3(m.col(ax)) : Vec3::Zero();
            worst = std::max(worst, (cov[p].col(ax) - expected).cwiseAbs().maxCoeff());
        }
    }
    REQUIRE(worst < 1e-11);
}

TEST_CASE("geometric state: thin sheets, rods and isolated points get sane frames", "[geom]") {
    const Lattice lat = awkwardLattice();
    const std::vector<Vec3> rest = restPositions(lat);
    const Real h = lat.spacing;
    const Mat3 rot = Eigen::AngleAxis<Real>(0.9, Vec3(1, 2, -0.5).normalized()).toRotationMatrix();
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = rot * rest[p] + Vec3(0.1, 0.2, 0.3);
    GeometricState st;
    computeGeometricState(lat, x, st);
    int sheet = 0, rod = 0, isolated = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        int missing = 0;
        for (int ax = 0; ax < 3; ++ax)
            missing += lat.neighbours[p][2 * ax] == kNoPoint && lat.neighbours[p][2 * ax + 1] == kNoPoint;
        Mat3 frame;
        frame << st.tangent[0][p], st.tangent[1][p], st.tangent[2][p];
        REQUIRE(frame.determinant() == Approx(h * h * h).epsilon(1e-12));
        if (missing == 1) {
            // Rigid motion of a sheet: the completed frame is exactly h R.
            ++sheet;
            REQUIRE((frame - h * rot).cwiseAbs().maxCoeff() < 1e-12);
        } else if (missing == 2) {
            // Rod along k: x_k = h R e_k; the others orthogonal to it, length h.
            ++rod;
            REQUIRE((frame.col(2) - h * rot.col(2)).norm() < 1e-12);
            REQUIRE((frame.transpose() * frame - h * h * Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-12);
        } else if (missing == 3) {
            ++isolated;
            REQUIRE((frame - h * Mat3::Identity()).cwiseAbs().maxCoeff() == 0);
        }
    }
    REQUIRE(sheet > 20);
    REQUIRE(rod >= 6);
    REQUIRE(isolated == 1);
    REQUIRE(maxAbsGamma(st) < 1e-12);
}

TEST_CASE("geometric state: completeFrame and invertMetric kernels", "[geom]") {
    const Real h = 0.5;
    SECTION("one missing axis: orthogonal, right-handed, det = h^3") {
        for (int c = 0; c < 3; ++c) {
            std::array<Vec3, 3> t = {Vec3(0.6, 0.1, 0), Vec3(-0.1, 0.4, 0.2), Vec3(0.3, 0.2, 0.7)};
            std::array<bool, 3> present = {true, true, true};
            present[c] = false;
            completeFrame(t, present, h);
            Mat3 f;
            f << t[0], t[1], t[2];
            REQUIRE(f.determinant() == Approx(h * h * h).epsilon(1e-13));
            REQUIRE(std::abs(t[c].dot(t[(c + 1) % 3])) < 1e-14);
            REQUIRE(std::abs(t[c].dot(t[(c + 2) % 3])) < 1e-14);
        }
    }
    SECTION("two missing axes: det = h^3, orthogonal") {
        std::array<Vec3, 3> t = {Vec3(0, 0, 0), Vec3(0, -0.8, 0), Vec3(0, 0, 0)};  // flipped rod
        completeFrame(t, {false, true, false}, h);
        Mat3 f;
        f << t[0], t[1], t[2];
        REQUIRE(f.determinant() == Approx(h * h * h).epsilon(1e-13));
        REQUIRE(std::abs(t[0].dot(t[1])) < 1e-14);
        REQUIRE(std::abs(t[2].dot(t[1])) < 1e-14);
        REQUIRE(std::abs(t[0].dot(t[2])) < 1e-14);
    }
    SECTION("collapsed sheet falls back to the rest direction") {
        std::array<Vec3, 3> t = {Vec3(0.5, 0, 0), Vec3(0.5, 0, 0), Vec3(9, 9, 9)};
        completeFrame(t, {true, true, false}, h);
        REQUIRE(t[2] == Vec3(0, 0, h));
    }
    SECTION("invertMetric: regular, singular and zero") {
        Mat3 g;
        g << 2, 0.3, 0.1, 0.3, 1, 0.2, 0.1, 0.2, 3;
        Mat3 gi;
        REQUIRE(invertMetric(g, gi));
        REQUIRE((g * gi - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-15);
        const Vec3 v(1, 2, 2);
        const Mat3 rank1 = v * v.transpose();
        REQUIRE_FALSE(invertMetric(rank1, gi));
        REQUIRE((gi - v * v.transpose() / std::pow(v.squaredNorm(), 2)).cwiseAbs().maxCoeff() < 1e-15);
        REQUIRE_FALSE(invertMetric(Mat3::Zero(), gi));
        REQUIRE(gi == Mat3::Zero());
    }
}

TEST_CASE("geometric state: a collapsed region yields finite values, no traps", "[geom]") {
    const Lattice lat = awkwardLattice();
    std::vector<Vec3> x = restPositions(lat);
    for (Vec3& p : x) p.z() = 0.25 * std::floor(p.z());   // flattens slabs onto planes
    for (Index p = 0; p < 40; ++p) x[p] = Vec3(1, 1, 1);  // and collapses a corner to a point
    GeometricState st;
    computeGeometricState(lat, x, st);
    for (Index p = 0; p < lat.size(); ++p) {
        REQUIRE(st.metricInv[p].allFinite());
        for (int c = 0; c < 3; ++c) REQUIRE(st.christoffel[c][p].allFinite());
    }
}

TEST_CASE("geometric state: identical bytes for 1 and 2 threads", "[geom]") {
    const Lattice lat = awkwardLattice();
    const std::vector<Vec3> rest = restPositions(lat);
    const Twist twist{0.08, Vec3(3, 5, 7)};
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = twist(rest[p]);
    GeometricState a, b;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        computeGeometricState(lat, x, a);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        computeGeometricState(lat, x, b);
    }
    for (Index p = 0; p < lat.size(); ++p) {
        for (int c = 0; c < 3; ++c) {
            REQUIRE(a.christoffel[c][p] == b.christoffel[c][p]);
            REQUIRE(a.dual[c][p] == b.dual[c][p]);
        }
        REQUIRE(a.metricInv[p] == b.metricInv[p]);
    }
}

TEST_CASE("geometric state: the realisable boundary stencils are exact for affine maps and telescope along each axis",
          "[geom]") {
    // BoundaryStencils::Realisable (the dynamics' state): along every lattice edge p -> q = p + e_a
    // the change of the tangent x_a is the trapezoid rule of x_aa, x_a(q) − x_a(p) = ½ (x_aa(p) +
    // x_aa(q)), which is what the reconstruction's edge generators integrate (holonomy.hpp: the
    // midpoint S_pq). Inside, the central stencils do this exactly; at the boundary the
    // second-order x_aa (2x − 5x[s] + 4x[2s] − x[3s]) does not (docs/math.md, "Boundary stencils
    // the reconstruction can realise").
    const Lattice lat = awkwardLattice();
    const std::vector<Vec3> rest = restPositions(lat);
    std::mt19937_64 rng(777);
    const Mat3 a = randomAffine(rng);
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = a * rest[p] + Vec3(0.3, -2, 1);
    GeometricState st;
    computeGeometricState(lat, x, st, BoundaryStencils::Realisable);
    CHECK(maxAbsGamma(st) < 1e-12);
    // A curved map (a bend and a swirl of a few voxels' wavelength).
    for (std::size_t p = 0; p < x.size(); ++p) {
        const Vec3 u = rest[p];
        x[p] =
            u + Vec3(0.4 * std::sin(0.9 * u.y()), 0.3 * std::cos(0.7 * u.z() + 0.2 * u.x()), 0.25 * u.x() * u.y() / 10);
    }
    GeometricState realisable, accurate;
    computeGeometricState(lat, x, realisable, BoundaryStencils::Realisable);
    computeGeometricState(lat, x, accurate);
    auto worstEdge = [&](const GeometricState& s) {
        Real worst = 0;
        for (Index p = 0; p < lat.size(); ++p)
            for (int ax = 0; ax < 3; ++ax) {
                const Index q = lat.neighbours[static_cast<std::size_t>(p)][static_cast<std::size_t>(2 * ax + 1)];
                if (q == kNoPoint) continue;
                const Vec3 change = s.tangent[ax][q] - s.tangent[ax][p];
                const Vec3 trapezoid = Real(0.5) * (s.second[ax][p] + s.second[ax][q]);
                worst = std::max(worst, (change - trapezoid).norm());
            }
        return worst;
    };
    const Real eRealisable = worstEdge(realisable), eAccurate = worstEdge(accurate);
    INFO("largest |x_a(q) - x_a(p) - trapezoid of x_aa|: realisable " << eRealisable << ", accurate " << eAccurate);
    CHECK(eRealisable < 1e-13);
    CHECK(eAccurate > 1e-3);
    // Interior points (all six neighbours and the cross stencils' diagonals) are the same either way.
    Real interiorDiff = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        bool interior = true;
        for (int s = 0; s < 6 && interior; ++s) {
            const Index q = lat.neighbours[static_cast<std::size_t>(p)][static_cast<std::size_t>(s)];
            interior = q != kNoPoint;
            for (int t = 0; t < 6 && interior; ++t)
                if (t / 2 != s / 2)
                    interior = lat.neighbours[static_cast<std::size_t>(q)][static_cast<std::size_t>(t)] != kNoPoint;
        }
        if (!interior) continue;
        for (int c = 0; c < 3; ++c)
            interiorDiff = std::max(interiorDiff,
                                    (realisable.christoffel[c][p] - accurate.christoffel[c][p]).cwiseAbs().maxCoeff());
    }
    CHECK(interiorDiff == 0);
}
