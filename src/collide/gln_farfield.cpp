#include "collide/gln_farfield.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

namespace dgv {
namespace {

struct NodePair {
    int a, b;
};

/// Dual-tree traversal in a fixed order: far node pairs and near leaf pairs.
void traverse(const CurveBvh& ta, const CurveBvh& tb, Real theta, std::vector<NodePair>& far,
              std::vector<NodePair>& near) {
    std::vector<NodePair> stack{{0, 0}};
    while (!stack.empty()) {
        const NodePair p = stack.back();
        stack.pop_back();
        const BvhNode& A = ta.nodes[static_cast<std::size_t>(p.a)];
        const BvhNode& B = tb.nodes[static_cast<std::size_t>(p.b)];
        const Real D = (A.centre - B.centre).norm();
        if (A.radius + B.radius < theta * D) {
            far.push_back(p);
        } else if (A.leaf() && B.leaf()) {
            near.push_back(p);
        } else if (B.leaf() || (!A.leaf() && A.radius >= B.radius)) {
            stack.push_back({A.right, p.b});
            stack.push_back({A.left, p.b});
        } else {
            stack.push_back({p.a, B.right});
            stack.push_back({p.a, B.left});
        }
    }
}

bool boxesDisjoint(const ClosedCurve& a, const ClosedCurve& b) {
    Box3 ba, bb;
    for (const Vec3& p : a) ba.extend(p);
    for (const Vec3& p : b) bb.extend(p);
    return (ba.max.array() < bb.min.array()).any() || (bb.max.array() < ba.min.array()).any();
}

/// Certifies `raw` ± `bound`: the nearest integer when the interval excludes every half-integer.
bool certify(double raw, double bound, long long& k) {
    const double r = std::nearbyint(raw);
    if (!(std::abs(raw - r) + bound < 0.5)) return false;
    k = static_cast<long long>(r);
    return true;
}

}  // namespace

FarFieldSum glnFarFieldSum(const CurveSoA& a, const CurveBvh& ta, const CurveSoA& b, const CurveBvh& tb,
                           Real theta, GlnKernel kernel, double maxFarBound) {
    DGV_CHECK(theta > 0 && theta < 1);
    std::vector<NodePair> far, near;
    traverse(ta, tb, theta, far, near);
    FarFieldSum out;
    out.farPairs = static_cast<Index>(far.size());
    out.nearTiles = static_cast<Index>(near.size());
    const FarValue fv = parallelReduce<FarValue>(
        out.farPairs, FarValue{},
        [&](FarValue& acc, Index i) {
            const NodePair& p = far[static_cast<std::size_t>(i)];
            const FarValue v = farFieldPair(ta.nodes[static_cast<std::size_t>(p.a)], tb.nodes[static_cast<std::size_t>(p.b)]);
            acc.value += v.value;
            acc.bound += v.bound + std::abs(v.value) * 0x1p-50;  // the sum's own rounding
        },
        [](FarValue x, const FarValue& y) {
            x.value += y.value;
            x.bound += y.bound;
            return x;
        },
        256);
    out.farValue = fv.value;
    out.farBound = fv.bound + 0x1p-50 * std::abs(fv.value) * std::sqrt(static_cast<double>(far.size()) + 1);
    if (!(out.farBound <= maxFarBound)) {
        out.nearEvaluated = false;
        return out;
    }
    out.near = parallelReduce<GlnSum>(
        out.nearTiles, GlnSum{},
        [&](GlnSum& acc, Index i) {
            const NodePair& p = near[static_cast<std::size_t>(i)];
            const BvhNode& A = ta.nodes[static_cast<std::size_t>(p.a)];
            const BvhNode& B = tb.nodes[static_cast<std::size_t>(p.b)];
            GlnSum s = glnTile(a, A.begin, A.end, b, B.begin, B.end, kernel);
            if (s.illConditioned > 0) s = glnTileCareful(a, A.begin, A.end, b, B.begin, B.end);
            acc += s;
        },
        [](GlnSum x, const GlnSum& y) { return x += y; }, 16);
    return out;
}

GlnResult linkingNumber(const ClosedCurve& ca, const ClosedCurve& cb, const GlnSettings& st) {
    DGV_CHECK_GE(ca.size(), std::size_t(3));
    DGV_CHECK_GE(cb.size(), std::size_t(3));
    GlnResult r;
    r.segmentsA = static_cast<Index>(ca.size());
    r.segmentsB = static_cast<Index>(cb.size());
    r.avx2 = st.kernel == GlnKernel::Avx2 || (st.kernel == GlnKernel::Auto && glnAvx2Available());
    if (boxesDisjoint(ca, cb)) {
        // A plane separates the curves: every view direction normal to it shows no crossing.
        r.culled = true;
        r.method = "bounding boxes disjoint";
        return r;
    }
    const Real scale = unitScale(ca, cb);
    const CurveSoA a = toSoA(ca, scale), b = toSoA(cb, scale);

    const bool direct = !st.farField || r.segmentsA * r.segmentsB <= st.directPairs;
    if (!direct) {
        const CurveBvh ta = buildCurveBvh(a, st.leafSize), tb = buildCurveBvh(b, st.leafSize);
        Real theta = st.theta;
        for (int pass = 0; pass < st.refinements; ++pass, theta *= 0.5) {
            // A far bound over 0.45 leaves too little room to certify: skip this θ's near field.
            const bool last = pass + 1 == st.refinements;
            const FarFieldSum f = glnFarFieldSum(a, ta, b, tb, theta, st.kernel, last ? HUGE_VAL : 0.45);
            ++r.passes;
            if (!f.nearEvaluated) continue;
            const LinkValue near = toLinkValue(f.near);
            r.raw = near.raw + f.farValue;
            r.bound = near.bound + f.farBound;
            r.pairsExact = f.near.pairs;
            r.farPairs = f.farPairs;
            r.intersections = f.near.intersections;
            r.theta = theta;
            char m[64];
            std::snprintf(m, sizeof m, "far field (theta = %g)", theta);
            r.method = m;
            if (r.intersections > 0) {
                r.status = GlnStatus::Intersect;
                return r;
            }
            if (certify(r.raw, r.bound, r.linking)) return r;
        }
    }
    const GlnSum s = glnDirectSum(a, b, st.kernel);
    const LinkValue v = toLinkValue(s);
    ++r.passes;
    r.raw = v.raw;
    r.bound = v.bound;
    r.pairsExact = s.pairs;
    r.farPairs = 0;
    r.intersections = s.intersections;
    r.theta = 0;
    r.method = "direct";
    if (r.intersections > 0) r.status = GlnStatus::Intersect;
    else if (!certify(r.raw, r.bound, r.linking)) r.status = GlnStatus::Uncertain;
    return r;
}

}  // namespace dgv
