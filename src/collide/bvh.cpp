#include "collide/bvh.hpp"

#include "base/check.hpp"

#include <algorithm>
#include <cmath>

namespace dgv {
namespace {

void leafMoments(const CurveSoA& s, BvhNode& n) {
    for (Index i = n.begin; i <= n.end; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        n.box.extend(Vec3(s.x[k], s.y[k], s.z[k]));
    }
    n.centre = n.box.centre();
    for (Index i = n.begin; i <= n.end; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        n.radius = std::max(n.radius, (Vec3(s.x[k], s.y[k], s.z[k]) - n.centre).norm());
    }
    for (Index i = n.begin; i < n.end; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        const Vec3 p0(s.x[k], s.y[k], s.z[k]), p1(s.x[k + 1], s.y[k + 1], s.z[k + 1]);
        const Vec3 e = p1 - p0, m = 0.5 * (p0 + p1) - n.centre;
        n.length += s.len[k];
        n.m0 += e;
        for (int a = 0; a < 3; ++a) n.m1.col(a) += m[a] * e;
        for (int a = 0; a < 3; ++a)
            for (int b = a; b < 3; ++b) n.m2[momentIndex(a, b)] += (m[a] * m[b] + e[a] * e[b] / 12) * e;
    }
}

/// Adds child `c`'s moments, translated from its centre to n.centre.
void addTranslated(BvhNode& n, const BvhNode& c) {
    const Vec3 s = c.centre - n.centre;
    n.length += c.length;
    n.m0 += c.m0;
    for (int a = 0; a < 3; ++a) n.m1.col(a) += c.m1.col(a) + s[a] * c.m0;
    for (int a = 0; a < 3; ++a)
        for (int b = a; b < 3; ++b)
            n.m2[momentIndex(a, b)] +=
                c.m2[momentIndex(a, b)] + s[a] * c.m1.col(b) + s[b] * c.m1.col(a) + s[a] * s[b] * c.m0;
}

int build(const CurveSoA& s, CurveBvh& t, Index begin, Index end, int leafSize) {
    const int id = static_cast<int>(t.nodes.size());
    t.nodes.emplace_back();
    t.nodes[static_cast<std::size_t>(id)].begin = begin;
    t.nodes[static_cast<std::size_t>(id)].end = end;
    if (end - begin <= leafSize) {
        leafMoments(s, t.nodes[static_cast<std::size_t>(id)]);
        return id;
    }
    const Index mid = begin + (end - begin) / 2;
    const int l = build(s, t, begin, mid, leafSize);
    const int r = build(s, t, mid, end, leafSize);
    BvhNode& n = t.nodes[static_cast<std::size_t>(id)];
    const BvhNode& L = t.nodes[static_cast<std::size_t>(l)];
    const BvhNode& R = t.nodes[static_cast<std::size_t>(r)];
    n.left = l;
    n.right = r;
    n.box.extend(L.box);
    n.box.extend(R.box);
    n.centre = n.box.centre();
    n.radius = std::min(0.5 * n.box.size().norm(),
                        std::max((L.centre - n.centre).norm() + L.radius, (R.centre - n.centre).norm() + R.radius));
    addTranslated(n, L);
    addTranslated(n, R);
    return id;
}

}  // namespace

CurveBvh buildCurveBvh(const CurveSoA& curve, int leafSize) {
    DGV_CHECK_GE(leafSize, 1);
    DGV_CHECK_GE(curve.segments(), 1);
    CurveBvh t;
    t.nodes.reserve(static_cast<std::size_t>(4 * (curve.segments() / leafSize + 1)));
    build(curve, t, 0, curve.segments(), leafSize);
    return t;
}

FarValue farFieldPair(const BvhNode& A, const BvhNode& B) {
    const Vec3 R = A.centre - B.centre;
    const Real D2 = R.squaredNorm(), D = std::sqrt(D2);
    const Real q = (A.radius + B.radius) / D;
    DGV_CHECK_LT(q, 1.0);
    const Real inv3 = 1 / (D2 * D), inv5 = inv3 / D2, inv7 = inv5 / D2;
    // Order 0: K(R)·(M_A × M_B), K(r) = r/|r|^3.
    Real v = inv3 * R.dot(A.m0.cross(B.m0));
    // Order 1: Σ_k ∂_k K · (F_A[k] × M_B − M_A × F_B[k]),  ∂_k K_i = δ_ik/D³ − 3 R_i R_k / D⁵.
    for (int k = 0; k < 3; ++k) {
        const Vec3 w = A.m1.col(k).cross(B.m0) - A.m0.cross(B.m1.col(k));
        v += inv3 * w[k] - 3 * inv5 * R[k] * R.dot(w);
    }
    // Order 2: ½ Σ_kl ∂_k∂_l K · (S_A[kl] × M_B − F_A[k] × F_B[l] − F_A[l] × F_B[k] + M_A × S_B[kl]),
    // ∂_k∂_l K_i = −3(δ_ik R_l + δ_il R_k + δ_kl R_i)/D⁵ + 15 R_i R_k R_l / D⁷.
    for (int k = 0; k < 3; ++k) {
        for (int l = 0; l < 3; ++l) {
            const int kl = momentIndex(k, l);
            const Vec3 w = A.m2[kl].cross(B.m0) - A.m1.col(k).cross(B.m1.col(l)) - A.m1.col(l).cross(B.m1.col(k)) +
                           A.m0.cross(B.m2[kl]);
            Real h = -3 * inv5 * (R[l] * w[k] + R[k] * w[l]) + 15 * inv7 * R[k] * R[l] * R.dot(w);
            if (k == l) h -= 3 * inv5 * R.dot(w);
            v += 0.5 * h;
        }
    }
    FarValue out;
    const Real inv4pi = 1 / (4 * M_PI);
    out.value = v * inv4pi;
    const Real tail = 1 / ((1 - q) * (1 - q) * (1 - q)) - (1 + 3 * q + 6 * q * q);
    const Real scale = A.length * B.length / D2 * inv4pi;
    // Truncation, with 1% for the rounding of the tail itself, plus the arithmetic of ~100 terms
    // each at most (1 + 3q + 6q²)·scale.
    out.bound = 1.01 * std::max<Real>(tail, 0) * scale + 1e-13 * scale;
    return out;
}

}  // namespace dgv
