// Tests of the connection change from a displacement (eqs 45-52) and of the trace-free
// projection (eqs 60-61), including the decisions recorded in docs/math.md.
#include <catch2/catch.hpp>

#include "deform/connection_delta.hpp"
#include "deform/displacement.hpp"
#include "deform_test_util.hpp"
#include "geom/geometric_state.hpp"
#include "solve/holonomy.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>
#include <random>

using namespace dgv;
using namespace dgv::test;

namespace {

PointConnection randomSymmetric(std::mt19937_64& rng, Real scale = 1) {
    std::normal_distribution<Real> n(0, scale);
    PointConnection g;
    for (Mat3& m : g) {
        for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = n(rng);
        m = (0.5 * (m + m.transpose())).eval();
    }
    return g;
}

Real norm(const PointConnection& g) { return std::sqrt(g[0].squaredNorm() + g[1].squaredNorm() + g[2].squaredNorm()); }

/// 27-vector of T^c_ab, index 9c + 3a + b.
using Vec27 = Eigen::Matrix<Real, 27, 1>;
using Mat27 = Eigen::Matrix<Real, 27, 27>;
inline int idx(int c, int a, int b) { return 9 * c + 3 * a + b; }

/// exp(X) by scaling and squaring (for the path test).
Mat3 expm(const Mat3& X) {
    int s = 0;
    Real n = X.norm();
    while (n > 0.25) {
        n /= 2;
        ++s;
    }
    const Mat3 Y = X / std::pow(2.0, s);
    Mat3 term = Mat3::Identity(), sum = Mat3::Identity();
    for (int k = 1; k < 20; ++k) {
        term = (term * Y / Real(k)).eval();
        sum += term;
    }
    for (int i = 0; i < s; ++i) sum = (sum * sum).eval();
    return sum;
}

/// A along direction v: A(c, a) = sum_b Gamma^c_ab v_b.
Mat3 along(const PointConnection& g, const Vec3& v) {
    Mat3 A;
    for (int c = 0; c < 3; ++c) A.row(c) = (g[static_cast<std::size_t>(c)] * v).transpose();
    return A;
}

}  // namespace

TEST_CASE("connection: dGamma from eps (eq 52) matches Gamma(deformed) - Gamma(rest) at 2nd order", "[deform][slow]") {
    const Vec3i cells(16, 8, 8);
    const Vec3 centre(8, 4, 4);
    struct Case {
        const char* name;
        MapFn rest, deform;
    };
    const Case cases[] = {
        {"twist on flat", [](const Vec3& p) { return p; }, twistMap(0.05, centre)},
        {"bend on flat", [](const Vec3& p) { return p; }, bendMap(12.0, centre)},
        {"stretch on flat", [](const Vec3& p) { return p; }, stretchMap(0.1, centre, 8.0)},
        {"twist on bent", bendMap(20.0, centre), twistMap(0.05, centre)},
        {"stretch on twisted", twistMap(0.03, centre), stretchMap(0.1, centre, 8.0)},
    };
    for (const Case& cs : cases) {
        Real prev = 0, worstOrder = 10, prevB = 0, worstOrderB = 10;
        for (int m : {1, 2, 4}) {
            const Lattice lat = boxLattice(cells, m, 1);
            const std::vector<Vec3> x = mapPoints(restPositions(lat), cs.rest);
            const std::vector<Vec3> X = mapPoints(x, cs.deform);
            GeometricState rest, def;
            computeGeometricState(lat, x, rest);
            computeGeometricState(lat, X, def);
            const std::vector<Mat3> M = deformationMatrices(lat, rest, displacementCoefficients(rest, X));
            const ConnectionField d = connectionDelta(lat, rest, M);
            Real err = 0, ref = 0, errB = 0;
            for (Index p = 0; p < lat.size(); ++p) {
                for (std::size_t c = 0; c < 3; ++c) {
                    const Mat3 truth = def.christoffel[c][p] - rest.christoffel[c][p];
                    const Real e = (d[c][p] - truth).cwiseAbs().maxCoeff();
                    ref = std::max(ref, truth.cwiseAbs().maxCoeff());
                    if (innerPoint(lat, p, 0.2))
                        err = std::max(err, e);
                    else
                        errB = std::max(errB, e);
                }
            }
            const Real rel = err / ref, relB = errB / ref;
            if (prev > 0) worstOrder = std::min(worstOrder, std::log2(prev / rel));
            if (prevB > 0) worstOrderB = std::min(worstOrderB, std::log2(prevB / relB));
            if (verbose()) std::printf("dGamma %-18s m=%d: inner rel err %.3e, boundary %.3e\n", cs.name, m, rel, relB);
            prev = rel;
            prevB = relB;
        }
        INFO(cs.name);
        CHECK(worstOrder > 1.8);
        CHECK(worstOrderB > 0.8);
    }
}

TEST_CASE("connection: trace-free projection is symmetric, trace-free, idempotent, orthogonal", "[deform]") {
    std::mt19937_64 rng(3);
    for (int t = 0; t < 100; ++t) {
        const PointConnection g = randomSymmetric(rng);
        PointConnection p = g;
        projectTraceFree(p);
        REQUIRE(connectionTrace(p).norm() < 1e-14);
        for (const Mat3& m : p) REQUIRE((m - m.transpose()).norm() < 1e-15);
        PointConnection q = p;
        projectTraceFree(q);
        for (std::size_t c = 0; c < 3; ++c) REQUIRE((q[c] - p[c]).norm() < 1e-15);
        // orthogonal: <P g, g - P g> = 0
        Real inner = 0;
        for (std::size_t c = 0; c < 3; ++c) inner += p[c].cwiseProduct(g[c] - p[c]).sum();
        REQUIRE(std::abs(inner) < 1e-13 * norm(g) * norm(g));
    }
    // field version
    ConnectionField f;
    for (auto& v : f) v.assign(5, Mat3::Identity());
    projectTraceFree(f);
    PointConnection one = {f[0][2], f[1][2], f[2][2]};
    CHECK(connectionTrace(one).norm() < 1e-15);
}

TEST_CASE("connection: degrees of freedom and the antisymmetrisation (decisions)", "[deform]") {
    // Projectors on 27-vectors T^c_ab.
    Mat27 symAB = Mat27::Zero(), antiCB = Mat27::Zero(), antiCA = Mat27::Zero(), trace = Mat27::Zero();
    for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
                symAB(idx(c, a, b), idx(c, a, b)) += 0.5;
                symAB(idx(c, a, b), idx(c, b, a)) += 0.5;
                antiCB(idx(c, a, b), idx(c, a, b)) += 0.5;  // (T^c_ab - T^b_ac) / 2
                antiCB(idx(c, a, b), idx(b, a, c)) -= 0.5;
                antiCA(idx(c, a, b), idx(c, a, b)) += 0.5;  // (T^c_ab - T^a_cb) / 2
                antiCA(idx(c, a, b), idx(a, c, b)) -= 0.5;
            }
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) trace(a, idx(b, a, b)) = 1;  // tau_a = sum_b T^b_ab
    auto rank = [](const Eigen::MatrixXd& m) { return Eigen::FullPivLU<Eigen::MatrixXd>(m).rank(); };
    // A torsion-free connection has 3 x 6 = 18 components, not the seed's 24 (= 27 - 3).
    CHECK(rank(symAB) == 18);
    // Symmetric in (a, b) AND antisymmetric in (c, b) (or (c, a)): only zero.
    Eigen::MatrixXd both(54, 27);
    both << Mat27::Identity() - symAB, Mat27::Identity() - antiCB;
    CHECK(rank(both) == 27);
    both << Mat27::Identity() - symAB, Mat27::Identity() - antiCA;
    CHECK(rank(both) == 27);
    // Volume needs only the 3 traces: symmetric and trace-free leaves 15.
    Eigen::MatrixXd symFree(54, 27);
    symFree << Mat27::Identity() - symAB, trace;
    CHECK(27 - rank(symFree) == 15);
    // Alternating the seed's antisymmetrisation with the symmetry drives dGamma to zero ...
    std::mt19937_64 rng(5);
    const PointConnection g = randomSymmetric(rng);
    Vec27 v;
    for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) v[idx(c, a, b)] = g[static_cast<std::size_t>(c)](a, b);
    Vec27 w = v;
    for (int i = 0; i < 200; ++i) w = symAB * (antiCB * w);
    CHECK(w.norm() < 1e-6 * v.norm());
    // ... and antisymmetrising in (a, b) removes all of a symmetric dGamma at once.
    Mat27 antiAB = Mat27::Identity() - symAB;
    CHECK((antiAB * v).norm() < 1e-15);
}

TEST_CASE("connection: trace-free dGamma keeps det M along a path (eqs 57, 60-61)", "[deform]") {
    // Piecewise-constant transport dM/dl = -A M + M Abar along a path: exact per step with
    // exponentials, det M_k+1 = det M_k exp(tr(Abar - A)) = det M_k exp(tau . v).
    std::mt19937_64 rng(11);
    std::normal_distribution<Real> n(0, 1);
    Mat3 Mraw = Mat3::Identity(), Mfree = Mat3::Identity();
    for (int step = 0; step < 40; ++step) {
        const PointConnection gamma = randomSymmetric(rng, 0.1);
        PointConnection dg = randomSymmetric(rng, 0.05);
        Vec3 v(n(rng), n(rng), n(rng));
        v.normalize();
        PointConnection bar = gamma, barFree = gamma;
        PointConnection dgFree = dg;
        projectTraceFree(dgFree);
        for (std::size_t c = 0; c < 3; ++c) {
            bar[c] += dg[c];
            barFree[c] += dgFree[c];
        }
        const Mat3 A = along(gamma, v);
        Mraw = expm(-A) * Mraw * expm(along(bar, v));
        Mfree = expm(-A) * Mfree * expm(along(barFree, v));
        // tr dA = tau . v
        CHECK(along(dg, v).trace() == Approx(connectionTrace(dg).dot(v)).margin(1e-14));
    }
    if (verbose())
        std::printf("det M after 40 steps: raw %.6f, trace-free %.16f\n", Mraw.determinant(), Mfree.determinant());
    CHECK(std::abs(Mfree.determinant() - 1) < 1e-12);
    CHECK(std::abs(Mraw.determinant() - 1) > 1e-3);
}

TEST_CASE("connection: sum_b Gamma^b_ab = d_a ln det(frame) on the lattice", "[deform]") {
    const Vec3 centre(8, 4, 4);
    struct Case {
        const char* name;
        MapFn map;
        Real tol;
    };
    const Case cases[] = {{"twist", twistMap(0.05, centre), 1e-12}, {"stretch", stretchMap(0.1, centre, 8.0), 0}};
    for (const Case& cs : cases) {
        Real prev = 0, worst = 10;
        for (int m : {1, 2, 4}) {
            const Lattice lat = boxLattice(Vec3i(16, 8, 8), m, 1);
            const std::vector<Vec3> X = mapPoints(restPositions(lat), cs.map);
            GeometricState st;
            computeGeometricState(lat, X, st);
            std::vector<Real> ld(X.size());
            for (Index p = 0; p < lat.size(); ++p) {
                Mat3 F;
                F << st.tangent[0][p], st.tangent[1][p], st.tangent[2][p];
                ld[p] = std::log(F.determinant());
            }
            Real err = 0, ref = 0;
            for (Index p = 0; p < lat.size(); ++p) {
                if (!innerPoint(lat, p, 0.2)) continue;
                const PointConnection g = {st.christoffel[0][p], st.christoffel[1][p], st.christoffel[2][p]};
                const Vec3 tau = connectionTrace(g);
                Vec3 grad;
                for (int a = 0; a < 3; ++a)
                    grad[a] = 0.5 * (ld[lat.neighbours[p][2 * a + 1]] - ld[lat.neighbours[p][2 * a]]);
                err = std::max(err, (tau - grad).cwiseAbs().maxCoeff());
                ref = std::max(ref, grad.cwiseAbs().maxCoeff());
            }
            if (verbose())
                std::printf("trace identity %s m=%d: abs err %.3e (|grad ln det| %.3e)\n", cs.name, m, err, ref);
            if (cs.tol > 0) CHECK(err < cs.tol);
            if (prev > 0) worst = std::min(worst, std::log2(prev / (err / ref)));
            prev = err / ref;
        }
        if (cs.tol == 0) CHECK(worst > 1.8);
    }
}

TEST_CASE("connection: eq 57 holds for the transpose of the stored M (sign and order decision)", "[deform]") {
    // Frames F (columns x_a) move by F(n) = F(0) H(0, n) (solve/holonomy.hpp, eq 18 with its
    // minus sign: H carries coefficients, frames carry H^-1), and Fbar = F M^T (eq 37). Hence
    // M^T(n) = H(n, 0) M^T(0) Hbar(0, n): eq 57 as written, for the seed's matrix convention
    // (rows = upper index, "M_ab = M_b^a"), i.e. the transpose of our M(a, c) = M_a^c. With FD
    // connections it holds to the 2nd-order discretisation error; the other readings fail.
    const Vec3i cells(16, 8, 8);
    const Vec3 centre(8, 4, 4);
    Real prev = 0, worstOrder = 10;
    for (int m : {1, 2, 4}) {
        const Lattice lat = boxLattice(cells, m, 1);
        const std::vector<Vec3> x = mapPoints(restPositions(lat), bendMap(20.0, centre));
        const std::vector<Vec3> X = mapPoints(x, twistMap(0.05, centre));
        GeometricState rest, def;
        computeGeometricState(lat, x, rest);
        computeGeometricState(lat, X, def);
        const std::vector<Mat3> M = deformationMatrices(lat, rest, displacementCoefficients(rest, X));
        std::vector<Index> path{lat.pointAt(Vec3i(4 * m, 2 * m, 3 * m))};
        auto run = [&](int slot, int steps) {
            for (int i = 0; i < steps; ++i) path.push_back(lat.neighbours[path.back()][slot]);
        };
        run(kPlusI, 6 * m);
        run(kPlusJ, 3 * m);
        run(kPlusK, 2 * m);
        const std::vector<Index> back(path.rbegin(), path.rend());
        const Mat3 H = pathHolonomy(lat, rest.christoffel, path);    // H(n, 0)
        const Mat3 Hbar = pathHolonomy(lat, def.christoffel, back);  // Hbar(0, n)
        const Mat3 M0 = M[path.front()], Mn = M[path.back()];
        const Real err = (H * M0.transpose() * Hbar - Mn.transpose()).norm() / Mn.norm();
        // the other readings: M untransposed, or the holonomies swapped
        const Real wrong1 = (H * M0 * Hbar - Mn).norm() / Mn.norm();
        const Real wrong2 = (Hbar * M0.transpose() * H - Mn.transpose()).norm() / Mn.norm();
        if (verbose())
            std::printf("eq 57 m=%d: rel err %.3e (untransposed %.3e, swapped %.3e)\n", m, err, wrong1, wrong2);
        CHECK(wrong1 > 100 * err);
        CHECK(wrong2 > 20 * err);  // swapping is O(1) wrong; err falls 4x per halving
        if (prev > 0) worstOrder = std::min(worstOrder, std::log2(prev / err));
        prev = err;
    }
    CHECK(worstOrder > 1.8);
}
