#include "solve/gather.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <type_traits>

namespace dgv {

namespace {

int neighbourCount(const Lattice& lat, Index p) {
    int n = 0;
    for (Index q : lat.neighbours[at(p)]) n += q != kNoPoint;
    return n;
}

template <typename V>
Real dot(const V& a, const V& b) {
    return a.cwiseProduct(b).sum();
}

/// Frames: Σ_q F(q) T_qp.
struct FrameProblem {
    const Lattice& lat;
    const EdgeTransports& e;
    Mat3 implied(Index p, const std::vector<Mat3>& y) const {
        Mat3 s = Mat3::Zero();
        for (int slot = 0; slot < 6; ++slot) {
            const Index q = lat.neighbours[at(p)][at(slot)];
            if (q != kNoPoint) s.noalias() += y[at(q)] * frameTransport(lat, e, q, slot ^ 1);
        }
        return s;
    }
    Real scaleTerm(Index p, int n, const std::vector<Mat3>& y) const {
        (void)p;
        return Real(n) * Real(n) * y[at(p)].squaredNorm();
    }
};

/// Positions: Σ_q (x(q) - D_pq) = Σ_q x(q) - div[p].
struct PositionProblem {
    const Lattice& lat;
    std::vector<Vec3> div;    ///< Σ_q D_pq
    std::vector<Real> edge2;  ///< n_p Σ_q |D_pq|^2
    PositionProblem(const Lattice& l, const EdgeTransports& e, const std::vector<Mat3>& frames)
        : lat(l), div(at(l.size())), edge2(at(l.size())) {
        parallelFor(lat.size(), [&](Index p) {
            Vec3 s = Vec3::Zero();
            Real s2 = 0;
            int n = 0;
            for (int slot = 0; slot < 6; ++slot) {
                if (lat.neighbours[at(p)][at(slot)] == kNoPoint) continue;
                const Vec3 d = positionStep(lat, e, frames, p, slot);
                s += d;
                s2 += d.squaredNorm();
                ++n;
            }
            div[at(p)] = s;
            edge2[at(p)] = Real(n) * s2;
        });
    }
    Vec3 implied(Index p, const std::vector<Vec3>& y) const {
        Vec3 s = -div[at(p)];
        for (Index q : lat.neighbours[at(p)])
            if (q != kNoPoint) s += y[at(q)];
        return s;
    }
    Real scaleTerm(Index p, int, const std::vector<Vec3>&) const { return edge2[at(p)]; }
};

struct Pair {
    Real a = 0, b = 0;
};

/// Squared residual norm (a) and squared scale (b) of the file comment.
template <typename V, typename P>
Pair residualParts(const Lattice& lat, const P& prob, const std::vector<unsigned char>& fixed,
                   const std::vector<unsigned char>* held, const std::vector<V>& y) {
    const Pair r = parallelReduce(
        lat.size(), Pair{},
        [&](Pair& acc, Index p) {
            if (fixed[at(p)]) return;
            const int n = neighbourCount(lat, p);
            if (n == 0) return;
            acc.b += prob.scaleTerm(p, n, y);
            if (held && (*held)[at(p)]) return;
            acc.a += (prob.implied(p, y) - Real(n) * y[at(p)]).squaredNorm();
        },
        [](Pair x, const Pair& z) {
            x.a += z.a;
            x.b += z.b;
            return x;
        });
    return r;
}

Real relative(const Pair& r) {
    if (r.b <= 0) return r.a <= 0 ? Real(0) : std::sqrt(r.a);
    return std::sqrt(r.a / r.b);
}

template <typename V, typename P>
Real residualOf(const Lattice& lat, const P& prob, const std::vector<unsigned char>& fixed,
                const std::vector<unsigned char>* held, const std::vector<V>& y) {
    return relative(residualParts<V>(lat, prob, fixed, held, y));
}

template <typename V, typename P>
SolveReport iterate(const Lattice& lat, const P& prob, const std::vector<unsigned char>& fixed, const GatherSettings& s,
                    std::vector<V>& y) {
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    DGV_CHECK_EQ(static_cast<Index>(y.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(fixed.size()), lat.size());
    DGV_CHECK(s.validate().empty());

    // Free points with neighbours, by colour; their neighbour counts.
    std::vector<Index> colour[2];
    std::vector<Index> all;
    std::vector<Real> invN(at(lat.size()), 0);
    for (Index p = 0; p < lat.size(); ++p) {
        const int n = neighbourCount(lat, p);
        if (fixed[at(p)] || n == 0) continue;
        invN[at(p)] = Real(1) / Real(n);
        const Vec3i& u = lat.coords[at(p)];
        colour[(u.x() + u.y() + u.z()) & 1].push_back(p);
        all.push_back(p);
    }
    std::vector<V> jOld(y.size(), V::Zero());
    std::vector<V> corr;
    std::vector<unsigned char> held(y.size(), 0);
    constexpr bool kPositions = std::is_same_v<V, Vec3>;
    const bool useWall = kPositions && static_cast<bool>(s.wall);

    SolveReport report;
    const Pair first = residualParts<V>(lat, prob, fixed, &held, y);
    // Divergence: the raw residual past 1e30 times the initial scale (for frames the scale grows
    // with the iterate, so the relative figure alone would not show it).
    const Real blowUp = Real(1e30) * std::sqrt(std::max({first.b, first.a, Real(1e-200)}));
    report.residual = relative(first);
    report.converged = report.residual <= s.tolerance;
    const Real w = s.gain;
    auto loopOver = [](const std::vector<Index>& list, auto&& f) {
        parallelFor(static_cast<Index>(list.size()), [&](Index i) { f(list[at(i)]); });
    };
    auto applyWall = [&](const std::vector<Index>& list) {
        if constexpr (kPositions) {
            if (useWall) loopOver(list, [&](Index p) { held[at(p)] = s.wall(p, y[at(p)]) ? 1 : 0; });
        }
    };
    for (int it = 1; it <= s.maxIterations && !report.converged; ++it) {
        switch (s.method) {
            case GatherMethod::Jacobi:
            case GatherMethod::JacobiSummed: {
                const bool summed = s.method == GatherMethod::JacobiSummed;
                loopOver(all, [&](Index p) {
                    jOld[at(p)] = summed ? prob.implied(p, y) : V(prob.implied(p, y) * invN[at(p)]);
                });
                loopOver(all, [&](Index p) { y[at(p)] = jOld[at(p)]; });
                break;
            }
            case GatherMethod::Sor:
                // The wall is applied after each colour (projected SOR, Cryer 1971: convergent
                // for 0 < w < 2 on convex constraints), not only after the sweep.
                if (s.sorForm == SorForm::Standard) {
                    for (int c = 0; c < 2; ++c) {
                        loopOver(colour[c], [&](Index p) {
                            y[at(p)] = (1 - w) * y[at(p)] + w * invN[at(p)] * prob.implied(p, y);
                        });
                        applyWall(colour[c]);
                    }
                } else {
                    loopOver(all, [&](Index p) { jOld[at(p)] = prob.implied(p, y) * invN[at(p)]; });
                    loopOver(colour[0], [&](Index p) { y[at(p)] = jOld[at(p)]; });
                    applyWall(colour[0]);
                    loopOver(colour[1], [&](Index p) {
                        const V latest = prob.implied(p, y) * invN[at(p)];
                        y[at(p)] = jOld[at(p)] + w * (latest - jOld[at(p)]);
                    });
                    applyWall(colour[1]);
                }
                break;
            case GatherMethod::AdaptiveGain: {
                // eq 31: J_old everywhere; the first colour takes it (its correction is zero);
                // the second colour's correction C = J_latest - J_old.
                loopOver(all, [&](Index p) { jOld[at(p)] = prob.implied(p, y) * invN[at(p)]; });
                corr.assign(y.size(), V::Zero());
                std::vector<V> yOld1(colour[1].size());
                for (std::size_t i = 0; i < colour[1].size(); ++i) yOld1[i] = y[at(colour[1][i])];
                loopOver(colour[0], [&](Index p) { y[at(p)] = jOld[at(p)]; });
                loopOver(colour[1], [&](Index p) { corr[at(p)] = prob.implied(p, y) * invN[at(p)] - jOld[at(p)]; });
                // eq 33 over the second colour (C = 0 elsewhere), in a fixed order.
                const Index n1 = static_cast<Index>(colour[1].size());
                const Pair nd = parallelReduce(
                    n1, Pair{},
                    [&](Pair& acc, Index i) {
                        const Index p = colour[1][at(i)];
                        acc.a += dot<V>(jOld[at(p)] - yOld1[at(i)], corr[at(p)]);
                        acc.b += corr[at(p)].squaredNorm();
                    },
                    [](Pair x, const Pair& z) {
                        x.a += z.a;
                        x.b += z.b;
                        return x;
                    });
                const Real wPlus = nd.b > 0 ? -nd.a / nd.b : Real(0);
                loopOver(colour[1], [&](Index p) { y[at(p)] = jOld[at(p)] + wPlus * corr[at(p)]; });
                break;
            }
        }
        if (s.method != GatherMethod::Sor) applyWall(all);
        report.iterations = it;
        if (it % s.checkEvery == 0 || it == s.maxIterations) {
            const Pair parts = residualParts<V>(lat, prob, fixed, &held, y);
            report.residual = relative(parts);
            report.converged = report.residual <= s.tolerance;
            if (!(std::sqrt(parts.a) <= blowUp)) {  // also catches NaN
                report.diverged = true;
                break;
            }
            if (elapsed() > s.maxSeconds) break;
        }
    }
    report.seconds = elapsed();
    return report;
}

}  // namespace

std::vector<std::string> GatherSettings::validate() const {
    std::vector<std::string> problems;
    if (!(gain > 0 && gain < 2)) problems.push_back("gain: must be in (0, 2)");
    if (!(tolerance > 0)) problems.push_back("tolerance: must be positive");
    if (maxIterations < 0) problems.push_back("maxIterations: must be >= 0");
    if (checkEvery < 1) problems.push_back("checkEvery: must be >= 1");
    if (!(maxSeconds > 0)) problems.push_back("maxSeconds: must be positive");
    return problems;
}

SolveReport gatherFrames(const Lattice& lat, const EdgeTransports& e, const std::vector<unsigned char>& fixed,
                         const GatherSettings& settings, std::vector<Mat3>& frames) {
    DGV_CHECK_EQ(e.size(), lat.size());
    const FrameProblem prob{lat, e};
    return iterate<Mat3>(lat, prob, fixed, settings, frames);
}

SolveReport gatherPositions(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                            const std::vector<unsigned char>& fixed, const GatherSettings& settings,
                            std::vector<Vec3>& positions) {
    DGV_CHECK_EQ(e.size(), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    const auto start = std::chrono::steady_clock::now();
    const PositionProblem prob(lat, e, frames);
    SolveReport r = iterate<Vec3>(lat, prob, fixed, settings, positions);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

Real positionResidual(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                      const std::vector<unsigned char>& fixed, const std::vector<Vec3>& positions) {
    const PositionProblem prob(lat, e, frames);
    return residualOf<Vec3>(lat, prob, fixed, nullptr, positions);
}

Real frameResidual(const Lattice& lat, const EdgeTransports& e, const std::vector<unsigned char>& fixed,
                   const std::vector<Mat3>& frames) {
    const FrameProblem prob{lat, e};
    return residualOf<Mat3>(lat, prob, fixed, nullptr, frames);
}

}  // namespace dgv
