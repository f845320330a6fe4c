#include "solve/holonomy.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <Eigen/LU>
#include <unsupported/Eigen/MatrixFunctions>

#include <algorithm>
#include <array>
#include <cmath>

namespace dgv {

namespace {

PointConnection pointConnection(const std::array<std::vector<Mat3>, 3>& christoffel, Index p) {
    return {christoffel[0][at(p)], christoffel[1][at(p)], christoffel[2][at(p)]};
}

/// Slot of the neighbour q of p (checked: consecutive path points must be 6-neighbours).
int slotBetween(const Lattice& lat, Index p, Index q) {
    DGV_CHECK(p >= 0 && p < lat.size());
    DGV_CHECK(q >= 0 && q < lat.size());
    for (int s = 0; s < 6; ++s)
        if (lat.neighbours[at(p)][static_cast<std::size_t>(s)] == q) return s;
    DGV_CHECK_EQ(p, q);  // not neighbours: a bug in the caller's path
    return -1;
}

/// Generator S of the directed edge (p, slot).
Mat3 generatorOf(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel, Index p, int slot) {
    const Index q = lat.neighbours[at(p)][static_cast<std::size_t>(slot)];
    return edgeGenerator(pointConnection(christoffel, p), pointConnection(christoffel, q), slot / 2,
                         (slot & 1) ? 1 : -1);
}

}  // namespace

Mat3 connectionMatrix(const PointConnection& gamma, int axis) {
    Mat3 g;
    for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a) g(c, a) = gamma[static_cast<std::size_t>(c)](a, axis);
    return g;
}

Mat3 edgeGenerator(const PointConnection& gammaP, const PointConnection& gammaQ, int axis, int sign) {
    return Real(0.5 * sign) * (connectionMatrix(gammaP, axis) + connectionMatrix(gammaQ, axis));
}

namespace {

/// Degree d of the Taylor polynomial of φ1 at 1-norm x <= 1/4: the first omitted term
/// x^(d+1) / (d+2)! below 2^-56 (d <= 13).
int phi1Degree(Real x) {
    int degree = 1;
    for (Real term = x * x / Real(6); degree < 13 && term > Real(1.4e-17); ++degree) term *= x / Real(degree + 3);
    return degree;
}

}  // namespace

void expPhi1Batch(const Mat3* S, Mat3* expS, Mat3* phi1, int count) {
    DGV_CHECK(count >= 0 && count <= 4);
    // Scale S by 2^-k until its 1-norm is <= 1/4, where a Taylor polynomial of phi1 of degree
    // <= 13 is exact to round-off; exp(X) = 1 + X phi1(X) exactly; then square back up
    // with exp(2X) = exp(X)^2 and phi1(2X) = phi1(X) (exp(X) + 1) / 2 (all commute). Each step
    // of the recursion is taken for every matrix in turn (independent products overlap); a
    // matrix whose degree or squaring count is smaller skips the steps it does not take, so
    // each result is the same bits whatever shares its batch.
    std::array<Mat3, 4> X, p, e;
    std::array<int, 4> squarings{}, degree{};
    int mostDegree = 0, mostSquarings = 0;
    for (std::size_t l = 0; l < static_cast<std::size_t>(count); ++l) {
        const Real norm = S[l].cwiseAbs().colwise().sum().maxCoeff();
        if (norm > Real(0.25)) squarings[l] = std::min(60, int(std::ceil(std::log2(norm / Real(0.25)))));
        X[l] = std::ldexp(Real(1), -squarings[l]) * S[l];
        degree[l] = phi1Degree(std::min(norm, Real(0.25)));
        mostDegree = std::max(mostDegree, degree[l]);
        mostSquarings = std::max(mostSquarings, squarings[l]);
        p[l] = Mat3::Identity();
    }
    // Horner: phi1 = sum_{j=0}^{degree} X^j / (j+1)!
    for (int j = mostDegree; j >= 1; --j)
        for (std::size_t l = 0; l < static_cast<std::size_t>(count); ++l)
            if (j <= degree[l]) p[l] = Mat3::Identity() + (X[l] * p[l]) / Real(j + 1);
    for (std::size_t l = 0; l < static_cast<std::size_t>(count); ++l) e[l] = Mat3::Identity() + X[l] * p[l];
    for (int i = 0; i < mostSquarings; ++i)
        for (std::size_t l = 0; l < static_cast<std::size_t>(count); ++l)
            if (i < squarings[l]) {
                p[l] = Real(0.5) * p[l] * (e[l] + Mat3::Identity());
                e[l] = e[l] * e[l];
            }
    for (std::size_t l = 0; l < static_cast<std::size_t>(count); ++l) {
        expS[l] = e[l];
        phi1[l] = p[l];
    }
}

void expPhi1(const Mat3& S, Mat3& expS, Mat3& phi1) { expPhi1Batch(&S, &expS, &phi1, 1); }

void edgeSteps(const Mat3& S, int axis, Vec3& from, Vec3& to) {
    const Real norm = S.cwiseAbs().colwise().sum().maxCoeff();
    if (!(norm <= Real(0.25))) {  // also NaN
        Mat3 t;
        edgeTransport(S, axis, t, from);
        edgeTransport(-S, axis, t, to);
        return;
    }
    const int degree = phi1Degree(norm);
    std::array<Vec3, 14> power;  // S^j e_axis
    power[0] = Vec3::Unit(axis);
    for (int j = 1; j <= degree; ++j) power[static_cast<std::size_t>(j)] = S * power[static_cast<std::size_t>(j - 1)];
    // φ1(±S) e = E ± O, E and O the even and odd terms Σ S^j e / (j+1)!, smallest first.
    Real factorial = 1;
    for (int j = 2; j <= degree + 1; ++j) factorial *= Real(j);
    Vec3 even = Vec3::Zero(), odd = Vec3::Zero();
    for (int j = degree; j >= 0; --j) {
        (j & 1 ? odd : even) += power[static_cast<std::size_t>(j)] / factorial;
        factorial /= Real(j + 1);
    }
    from = even + odd;
    to = even - odd;
}

void edgeTransport(const Mat3& generator, int axis, Mat3& expS, Vec3& step) {
    Mat3 phi1;
    expPhi1(generator, expS, phi1);
    step = phi1.col(axis);
}

Mat3 pathHolonomy(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel,
                  const std::vector<Index>& path) {
    Mat3 h = Mat3::Identity();
    for (std::size_t k = 1; k < path.size(); ++k) {
        const int slot = slotBetween(lat, path[k - 1], path[k]);
        if (slot < 0) continue;
        const Mat3 s = generatorOf(lat, christoffel, path[k - 1], slot);
        h = Mat3((-s).exp()) * h;  // later steps on the left (eq 18)
    }
    return h;
}

std::vector<Vec3> solveAlongPath(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel,
                                 const std::vector<Mat3>& driving, const std::vector<Index>& path, const Vec3& start) {
    DGV_CHECK_EQ(static_cast<Index>(driving.size()), lat.size());
    std::vector<Vec3> f;
    if (path.empty()) return f;
    f.reserve(path.size());
    f.push_back(start);
    for (std::size_t k = 1; k < path.size(); ++k) {
        const Index p = path[k - 1], q = path[k];
        const int slot = slotBetween(lat, p, q);
        if (slot < 0) {  // repeated point: a step of length zero
            f.push_back(f.back());
            continue;
        }
        const int axis = slot / 2;
        const Real sign = (slot & 1) ? 1 : -1;
        const Mat3 hop = (-generatorOf(lat, christoffel, p, slot)).exp();  // H(λ_k, λ_{k-1})
        const Vec3 gp = sign * driving[at(p)].col(axis);                   // G^b (eq 16)
        const Vec3 gq = sign * driving[at(q)].col(axis);
        f.push_back(hop * f.back() + Real(0.5) * (hop * gp + gq));
    }
    return f;
}

EdgeTransports computeEdgeTransports(const Lattice& lat, const std::array<std::vector<Mat3>, 3>& christoffel) {
    for (const auto& g : christoffel) DGV_CHECK_EQ(static_cast<Index>(g.size()), lat.size());
    EdgeTransports e;
    const std::size_t n = at(lat.size());
    for (int b = 0; b < 3; ++b) {
        e.forward[at(b)].assign(n, Mat3::Zero());
        e.backward[at(b)].assign(n, Mat3::Zero());
        e.stepFrom[at(b)].assign(n, Vec3::Zero());
        e.stepTo[at(b)].assign(n, Vec3::Zero());
    }
    parallelFor(
        lat.size(),
        [&](Index p) {
            for (int b = 0; b < 3; ++b) {
                if (lat.neighbours[at(p)][at(2 * b + 1)] == kNoPoint) continue;
                const Mat3 s = generatorOf(lat, christoffel, p, 2 * b + 1);
                Mat3 t;
                Vec3 a;
                edgeTransport(s, b, t, a);
                const Mat3 tInv = t.inverse();
                e.forward[at(b)][at(p)] = t;
                e.backward[at(b)][at(p)] = tInv;
                e.stepFrom[at(b)][at(p)] = a;
                e.stepTo[at(b)][at(p)] = tInv * a;  // φ1(-S) = exp(-S) φ1(S)
            }
        },
        256);
    return e;
}

}  // namespace dgv
