#include "collide/gln_farfield.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace dgv {
namespace {

struct NodePair {
    int a, b;
};

/// An allocator whose value-less construct leaves a trivial type uninitialised, so that a
/// vector of millions of far pairs is sized without a serial zero fill: the parallel loops that
/// write its elements then also touch its pages, on every core.
template <class T>
struct DefaultInit : std::allocator<T> {
    template <class U>
    struct rebind {
        using other = DefaultInit<U>;
    };
    DefaultInit() = default;
    template <class U>
    DefaultInit(const DefaultInit<U>&) noexcept {}
    template <class U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};
template <class T>
using Buffer = std::vector<T, DefaultInit<T>>;

/// What the traversal does with a node pair at opening ratio theta: accept it as far, evaluate
/// it exactly (two leaves not separated), or open it.
enum class Open { Far, Near, Split };
Open classify(const CurveBvh& ta, const CurveBvh& tb, NodePair p, Real theta) {
    const BvhNode& A = ta.nodes[static_cast<std::size_t>(p.a)];
    const BvhNode& B = tb.nodes[static_cast<std::size_t>(p.b)];
    if (A.radius + B.radius < theta * (A.centre - B.centre).norm()) return Open::Far;
    return A.leaf() && B.leaf() ? Open::Near : Open::Split;
}

/// The two pairs an opened pair becomes: the larger node's children with the other node.
std::array<NodePair, 2> children(const CurveBvh& ta, const CurveBvh& tb, NodePair p) {
    const BvhNode& A = ta.nodes[static_cast<std::size_t>(p.a)];
    const BvhNode& B = tb.nodes[static_cast<std::size_t>(p.b)];
    if (B.leaf() || (!A.leaf() && A.radius >= B.radius)) return {{{A.left, p.b}, {A.right, p.b}}};
    return {{{p.a, B.left}, {p.a, B.right}}};
}

/// Dual-tree traversal in a fixed order from the node pair `start`: far node pairs (handed to
/// `far`) and near leaf pairs (appended to `near`).
template <class Far>
void traverse(const CurveBvh& ta, const CurveBvh& tb, NodePair start, Real theta, Far&& far,
              std::vector<NodePair>& near) {
    std::vector<NodePair> stack{start};
    while (!stack.empty()) {
        const NodePair p = stack.back();
        stack.pop_back();
        switch (classify(ta, tb, p, theta)) {
            case Open::Far:
                far(p);
                break;
            case Open::Near:
                near.push_back(p);
                break;
            case Open::Split: {
                const std::array<NodePair, 2> c = children(ta, tb, p);
                stack.push_back(c[1]);
                stack.push_back(c[0]);  // the first child is visited first
                break;
            }
        }
    }
}

void traverse(const CurveBvh& ta, const CurveBvh& tb, Real theta, std::vector<NodePair>& far,
              std::vector<NodePair>& near) {
    traverse(
        ta, tb, NodePair{0, 0}, theta, [&](NodePair p) { far.push_back(p); }, near);
}

/// The exact sum over the near leaf pairs near[0, count), in parallel (deterministic).
GlnSum nearSum(const CurveSoA& a, const CurveBvh& ta, const CurveSoA& b, const CurveBvh& tb, const NodePair* near,
               std::size_t count, GlnKernel kernel) {
    return parallelReduce<GlnSum>(
        static_cast<Index>(count), GlnSum{},
        [&](GlnSum& acc, Index i) {
            const NodePair& p = near[static_cast<std::size_t>(i)];
            const BvhNode& A = ta.nodes[static_cast<std::size_t>(p.a)];
            const BvhNode& B = tb.nodes[static_cast<std::size_t>(p.b)];
            GlnSum s = glnTile(a, A.begin, A.end, b, B.begin, B.end, kernel);
            if (s.illConditioned > 0) s = glnTileCareful(a, A.begin, A.end, b, B.begin, B.end);
            acc += s;
        },
        [](GlnSum x, const GlnSum& y) { return x += y; }, 16);
}

/// The sum of n far pairs' multipoles and their bounds (`valueOf(i)`: pair i's), the bound
/// widened by the sum's own rounding. Parallel and deterministic.
template <class ValueOf>
FarValue sumFar(Index n, ValueOf&& valueOf) {
    FarValue fv = parallelReduce<FarValue>(
        n, FarValue{},
        [&](FarValue& acc, Index i) {
            const FarValue v = valueOf(i);
            acc.value += v.value;
            acc.bound += v.bound + std::abs(v.value) * 0x1p-50;  // each term's rounding
        },
        [](FarValue x, const FarValue& y) {
            x.value += y.value;
            x.bound += y.bound;
            return x;
        },
        256);
    fv.bound += 0x1p-50 * std::abs(fv.value) * std::sqrt(static_cast<double>(n) + 1);
    return fv;
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

FarFieldSum glnFarFieldSum(const CurveSoA& a, const CurveBvh& ta, const CurveSoA& b, const CurveBvh& tb, Real theta,
                           GlnKernel kernel, double maxFarBound) {
    DGV_CHECK(theta > 0 && theta < 1);
    std::vector<NodePair> far, near;
    traverse(ta, tb, theta, far, near);
    FarFieldSum out;
    out.farPairs = static_cast<Index>(far.size());
    out.nearTiles = static_cast<Index>(near.size());
    const FarValue fv = sumFar(out.farPairs, [&](Index i) {
        const NodePair& p = far[static_cast<std::size_t>(i)];
        return farFieldPair(ta.nodes[static_cast<std::size_t>(p.a)], tb.nodes[static_cast<std::size_t>(p.b)]);
    });
    out.farValue = fv.value;
    out.farBound = fv.bound;
    if (!(out.farBound <= maxFarBound)) {
        out.nearEvaluated = false;
        return out;
    }
    out.near = nearSum(a, ta, b, tb, near.data(), near.size(), kernel);
    return out;
}

FarFieldSum glnAdaptiveSum(const CurveSoA& a, const CurveBvh& ta, const CurveSoA& b, const CurveBvh& tb, Real theta,
                           double budget, const std::function<bool(const FarFieldSum&)>& done, GlnKernel kernel,
                           int maxRounds) {
    DGV_CHECK(theta > 0 && theta < 1);
    DGV_CHECK(budget > 0);
    struct Task {  // a node pair to traverse, and the opening ratio to traverse it at
        NodePair pair;
        Real theta;
    };
    struct Far {  // a far pair, the ratio it was accepted at, and its multipole (FarValue's)
        Task at;
        double value, bound;
    };
    Buffer<Far> far;
    Buffer<NodePair> near;
    // Traverses every task's node pair at its ratio, in parallel over blocks of tasks, and
    // appends the far pairs (with their multipoles) and the near leaf pairs in task order: the
    // lists are the same for any thread count.
    auto expand = [&](const std::vector<Task>& tasks) {
        const Index n = static_cast<Index>(tasks.size());
        const Index blocks = std::min<Index>(n, 512);
        std::vector<std::vector<Far>> fars(static_cast<std::size_t>(blocks));
        std::vector<std::vector<NodePair>> nears(static_cast<std::size_t>(blocks));
        parallelFor(
            blocks,
            [&](Index k) {
                std::vector<Far>& f = fars[static_cast<std::size_t>(k)];
                std::vector<NodePair>& e = nears[static_cast<std::size_t>(k)];
                for (Index t = k * n / blocks; t < (k + 1) * n / blocks; ++t) {
                    const Task& task = tasks[static_cast<std::size_t>(t)];
                    traverse(
                        ta, tb, task.pair, task.theta,
                        [&](NodePair p) {
                            const FarValue v = farFieldPair(ta.nodes[static_cast<std::size_t>(p.a)],
                                                            tb.nodes[static_cast<std::size_t>(p.b)]);
                            f.push_back({{p, task.theta}, v.value, v.bound});
                        },
                        e);
                }
            },
            1);
        // Appended block by block at offsets from a prefix sum, the copies in parallel (a serial
        // append of millions of pairs held the second core idle for a third of the sum).
        std::vector<std::size_t> farAt(fars.size() + 1, far.size()), nearAt(nears.size() + 1, near.size());
        for (std::size_t k = 0; k < fars.size(); ++k) {
            farAt[k + 1] = farAt[k] + fars[k].size();
            nearAt[k + 1] = nearAt[k] + nears[k].size();
        }
        far.resize(farAt.back());
        near.resize(nearAt.back());
        parallelFor(
            blocks,
            [&](Index k) {
                const std::size_t blk = static_cast<std::size_t>(k);
                std::copy(fars[blk].begin(), fars[blk].end(), far.begin() + static_cast<std::ptrdiff_t>(farAt[blk]));
                std::copy(nears[blk].begin(), nears[blk].end(),
                          near.begin() + static_cast<std::ptrdiff_t>(nearAt[blk]));
            },
            1);
    };
    auto boundOf = [&] {
        return parallelReduce<double>(
            static_cast<Index>(far.size()), 0.0,
            [&](double& acc, Index i) { acc += far[static_cast<std::size_t>(i)].bound; },
            [](double x, double y) { return x + y; }, 4096);
    };
    // The first tasks: the root pair opened a few levels (as the traversal opens them), so that
    // the first traversal has work for every thread.
    {
        std::vector<Task> tasks{{NodePair{0, 0}, theta}};
        for (int level = 0; level < 8; ++level) {
            std::vector<Task> next;
            for (const Task& t : tasks) {
                if (classify(ta, tb, t.pair, theta) != Open::Split) {
                    next.push_back(t);
                } else {
                    for (const NodePair& c : children(ta, tb, t.pair)) next.push_back({c, theta});
                }
            }
            tasks = std::move(next);
        }
        expand(tasks);
    }
    double bound = boundOf();
    FarFieldSum out;
    out.nearEvaluated = false;
    std::size_t evaluated = 0;  // near tiles summed so far: they stay exact, whatever is refined
    double target = budget;
    // Refine where the bound is: every far pair whose bound is over its even share of half the
    // target is opened again at half the ratio it was accepted at. The pairs under their share
    // sum to under half the target, and an opened pair's bound falls by about 2^3 or more
    // (bvh.hpp), so a few rounds bring the whole under it, with exact pairs only where the far
    // field was weak. Once under, the near tiles added since the last try are summed and
    // `done` asked; if it declines, the target halves and the refinement goes on.
    for (int round = 0; round <= maxRounds; ++round) {
        if (bound <= target) {
            out.near += nearSum(a, ta, b, tb, near.data() + evaluated, near.size() - evaluated, kernel);
            evaluated = near.size();
            const FarValue fv = sumFar(static_cast<Index>(far.size()), [&](Index i) {
                const Far& f = far[static_cast<std::size_t>(i)];
                return FarValue{f.value, f.bound};
            });
            out.farPairs = static_cast<Index>(far.size());
            out.nearTiles = static_cast<Index>(near.size());
            out.farValue = fv.value;
            out.farBound = fv.bound;
            out.smallestTheta = parallelReduce<Real>(
                static_cast<Index>(far.size()), Real(1),
                [&](Real& acc, Index i) { acc = std::min(acc, far[static_cast<std::size_t>(i)].at.theta); },
                [](Real x, Real y) { return std::min(x, y); }, 4096);
            out.nearEvaluated = true;
            if (done(out)) return out;
            target = 0.5 * std::min(target, bound);
        }
        if (round == maxRounds) break;
        const double share = 0.5 * target / static_cast<double>(far.size());
        // Split into the pairs kept and the pairs opened, in order, block by block in parallel:
        // each block counts its own, a prefix sum places them.
        const Index n = static_cast<Index>(far.size());
        const Index blocks = std::max<Index>(1, std::min<Index>(n / 4096, 256));
        auto first = [&](Index k) { return static_cast<std::size_t>(k * n / blocks); };
        std::vector<std::size_t> keptAt(static_cast<std::size_t>(blocks) + 1, 0),
            openedAt(static_cast<std::size_t>(blocks) + 1, 0);
        parallelFor(
            blocks,
            [&](Index k) {
                std::size_t o = 0;
                for (std::size_t i = first(k); i < first(k + 1); ++i) o += far[i].bound > share ? 1 : 0;
                openedAt[static_cast<std::size_t>(k) + 1] = o;
                keptAt[static_cast<std::size_t>(k) + 1] = first(k + 1) - first(k) - o;
            },
            1);
        for (std::size_t k = 0; k < static_cast<std::size_t>(blocks); ++k) {
            keptAt[k + 1] += keptAt[k];
            openedAt[k + 1] += openedAt[k];
        }
        Buffer<Far> kept(keptAt.back());
        std::vector<Task> opened(openedAt.back());
        parallelFor(
            blocks,
            [&](Index k) {
                std::size_t ki = keptAt[static_cast<std::size_t>(k)], oi = openedAt[static_cast<std::size_t>(k)];
                for (std::size_t i = first(k); i < first(k + 1); ++i) {
                    const Far& f = far[i];
                    if (f.bound > share)
                        opened[oi++] = {f.at.pair, Real(0.5) * f.at.theta};
                    else
                        kept[ki++] = f;
                }
            },
            1);
        far = std::move(kept);
        expand(opened);
        bound = boundOf();
        ++out.rounds;
    }
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
        // The two hierarchies are independent: one on each core.
        std::array<CurveBvh, 2> trees;
        parallelFor(
            2, [&](Index i) { trees[static_cast<std::size_t>(i)] = buildCurveBvh(i == 0 ? a : b, st.leafSize); }, 1);
        const CurveBvh& ta = trees[0];
        const CurveBvh& tb = trees[1];
        // The result of a far-field sum, with its method's name.
        auto record = [&](const FarFieldSum& f, Real theta, const std::string& method) {
            const LinkValue near = toLinkValue(f.near);
            r.raw = near.raw + f.farValue;
            r.bound = near.bound + f.farBound;
            r.pairsExact = f.near.pairs;
            r.farPairs = f.farPairs;
            r.intersections = f.near.intersections;
            r.theta = theta;
            r.method = method;
        };
        if (st.adaptive) {
            // Tried as soon as the far bound is under the budget, then at each halving of it.
            bool decided = false;
            auto accept = [&](const FarFieldSum& f) {
                ++r.passes;
                char m[96];
                std::snprintf(m, sizeof m, "adaptive far field (theta = %g to %g, %d rounds)", st.theta,
                              f.smallestTheta, f.rounds);
                record(f, f.smallestTheta, m);
                if (r.intersections > 0) r.status = GlnStatus::Intersect;
                decided = r.intersections > 0 || certify(r.raw, r.bound, r.linking);
                return decided;
            };
            (void)glnAdaptiveSum(a, ta, b, tb, st.theta, st.budget, accept, st.kernel, st.adaptiveRounds);
            if (decided) return r;
        }
        Real theta = st.theta;
        for (int pass = 0; pass < st.refinements; ++pass, theta *= 0.5) {
            // A far bound over 0.45 leaves too little room to certify: skip this θ's near field.
            const bool last = pass + 1 == st.refinements;
            const FarFieldSum f = glnFarFieldSum(a, ta, b, tb, theta, st.kernel, last ? HUGE_VAL : 0.45);
            ++r.passes;
            if (!f.nearEvaluated) continue;
            char m[64];
            std::snprintf(m, sizeof m, "far field (theta = %g)", theta);
            record(f, theta, m);
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
    if (r.intersections > 0)
        r.status = GlnStatus::Intersect;
    else if (!certify(r.raw, r.bound, r.linking))
        r.status = GlnStatus::Uncertain;
    return r;
}

}  // namespace dgv
