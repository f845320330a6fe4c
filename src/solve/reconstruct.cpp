#include "solve/reconstruct.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>

namespace dgv {

namespace {

double since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void checkEveryComponentPinned(const Lattice& lat, const std::vector<unsigned char>& fixed) {
    std::vector<unsigned char> has(static_cast<std::size_t>(lat.components), 0);
    for (Index p = 0; p < lat.size(); ++p)
        if (fixed[at(p)]) has[static_cast<std::size_t>(lat.component[at(p)])] = 1;
    for (int c = 0; c < lat.components; ++c) DGV_CHECK_EQ(int(has[static_cast<std::size_t>(c)]), 1);
}

}  // namespace

std::vector<std::string> ReconstructSettings::validate() const { return gather().validate(); }

GatherSettings ReconstructSettings::gather() const {
    GatherSettings g;
    switch (method) {
        case ReconstructMethod::Jacobi:
            g.method = GatherMethod::Jacobi;
            break;
        case ReconstructMethod::JacobiSummed:
            g.method = GatherMethod::JacobiSummed;
            break;
        case ReconstructMethod::AdaptiveGain:
            g.method = GatherMethod::AdaptiveGain;
            break;
        default:
            g.method = GatherMethod::Sor;
            break;
    }
    g.gain = gain;
    g.sorForm = sorForm;
    g.tolerance = tolerance;
    g.maxIterations = maxIterations;
    g.maxSeconds = maxSeconds;
    g.checkEvery = checkEvery;
    g.wall = wall;
    return g;
}

std::vector<unsigned char> fixedPositionMask(const Lattice& lat, const std::vector<Pin>& pins) {
    std::vector<unsigned char> m(at(lat.size()), 0);
    for (const Pin& pin : pins) {
        DGV_CHECK(pin.point >= 0 && pin.point < lat.size());
        if (pin.fixPosition) m[at(pin.point)] = 1;
    }
    return m;
}

std::vector<unsigned char> fixedFrameMask(const Lattice& lat, const std::vector<Pin>& pins) {
    std::vector<unsigned char> m(at(lat.size()), 0);
    for (const Pin& pin : pins) {
        DGV_CHECK(pin.point >= 0 && pin.point < lat.size());
        if (pin.fixFrame) m[at(pin.point)] = 1;
    }
    return m;
}

std::vector<Pin> centrePins(const Lattice& lat, const std::vector<Vec3>& positions, const std::vector<Mat3>& frames) {
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    const std::size_t nc = static_cast<std::size_t>(lat.components);
    std::vector<Vec3> sum(nc, Vec3::Zero());
    std::vector<Index> count(nc, 0);
    for (Index p = 0; p < lat.size(); ++p) {
        const std::size_t c = static_cast<std::size_t>(lat.component[at(p)]);
        sum[c] += lat.coords[at(p)].cast<Real>();
        ++count[c];
    }
    std::vector<Index> best(nc, kNoPoint);
    std::vector<Real> bestD(nc, std::numeric_limits<Real>::infinity());
    for (Index p = 0; p < lat.size(); ++p) {
        const std::size_t c = static_cast<std::size_t>(lat.component[at(p)]);
        const Real d = (lat.coords[at(p)].cast<Real>() - sum[c] / Real(count[c])).squaredNorm();
        if (d < bestD[c]) {
            bestD[c] = d;
            best[c] = p;
        }
    }
    std::vector<Pin> pins;
    for (std::size_t c = 0; c < nc; ++c) {
        Pin pin;
        pin.point = best[c];
        pin.position = positions[at(best[c])];
        pin.frame = frames[at(best[c])];
        pins.push_back(pin);
    }
    return pins;
}

SpanningTree spanningTree(const Lattice& lat, const std::vector<unsigned char>& roots) {
    DGV_CHECK_EQ(static_cast<Index>(roots.size()), lat.size());
    SpanningTree tree;
    tree.parent.assign(at(lat.size()), kNoPoint);
    tree.slot.assign(at(lat.size()), -1);
    std::vector<unsigned char> seen(roots);
    tree.order.reserve(at(lat.size()));
    for (Index p = 0; p < lat.size(); ++p)
        if (roots[at(p)]) tree.order.push_back(p);
    for (std::size_t head = 0; head < tree.order.size(); ++head) {
        const Index p = tree.order[head];
        for (int slot = 0; slot < 6; ++slot) {
            const Index q = lat.neighbours[at(p)][at(slot)];
            if (q == kNoPoint || seen[at(q)]) continue;
            seen[at(q)] = 1;
            tree.parent[at(q)] = p;
            tree.slot[at(q)] = static_cast<signed char>(slot);
            tree.order.push_back(q);
        }
    }
    std::vector<Index> position(at(lat.size()), -1);  // index in `order`
    for (std::size_t i = 0; i < tree.order.size(); ++i) position[at(tree.order[i])] = static_cast<Index>(i);
    tree.parentPosition.resize(tree.order.size());
    for (std::size_t i = 0; i < tree.order.size(); ++i) {
        const Index parent = tree.parent[at(tree.order[i])];
        tree.parentPosition[i] = parent == kNoPoint ? -1 : position[at(parent)];
    }
    return tree;
}

void integrateFramesAlongTree(const Lattice& lat, const EdgeTransports& e, const std::vector<Pin>& pins,
                              std::vector<Mat3>& frames) {
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    for (const Pin& pin : pins)
        if (pin.fixFrame) frames[at(pin.point)] = pin.frame;
    const SpanningTree tree = spanningTree(lat, fixedFrameMask(lat, pins));
    for (const Index q : tree.order) {
        const Index p = tree.parent[at(q)];
        if (p == kNoPoint) continue;
        frames[at(q)] = frames[at(p)] * frameTransport(lat, e, p, tree.slot[at(q)]);  // eq 57
    }
}

void integratePositionsAlongTree(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                                 const std::vector<Pin>& pins, std::vector<Vec3>& positions) {
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    for (const Pin& pin : pins)
        if (pin.fixPosition) positions[at(pin.point)] = pin.position;
    const SpanningTree tree = spanningTree(lat, fixedPositionMask(lat, pins));
    for (const Index q : tree.order) {
        const Index p = tree.parent[at(q)];
        if (p == kNoPoint) continue;
        positions[at(q)] = positions[at(p)] + positionStep(lat, e, frames, p, tree.slot[at(q)]);  // eq 59
    }
}

SolveReport reconstructFrames(const Lattice& lat, const EdgeTransports& e, const std::vector<Pin>& pins,
                              const ReconstructSettings& settings, std::vector<Mat3>& frames) {
    const auto start = std::chrono::steady_clock::now();
    DGV_CHECK(settings.validate().empty());
    DGV_CHECK(!pins.empty());
    const std::vector<unsigned char> fixed = fixedFrameMask(lat, pins);
    checkEveryComponentPinned(lat, fixed);
    if (static_cast<Index>(frames.size()) != lat.size()) {
        Mat3 first = pins.front().frame;
        for (const Pin& pin : pins)
            if (pin.fixFrame) {
                first = pin.frame;
                break;
            }
        frames.assign(at(lat.size()), first);
    }
    SolveReport report;
    if (settings.method == ReconstructMethod::Path || settings.method == ReconstructMethod::LeastSquares) {
        integrateFramesAlongTree(lat, e, pins, frames);
        report.converged = true;
        report.residual = frameResidual(lat, e, fixed, frames);
    } else {
        for (const Pin& pin : pins)
            if (pin.fixFrame) frames[at(pin.point)] = pin.frame;
        report = gatherFrames(lat, e, fixed, settings.gather(), frames);
    }
    report.seconds = since(start);
    return report;
}

SolveReport reconstructPositions(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                                 const std::vector<Pin>& pins, const ReconstructSettings& settings,
                                 std::vector<Vec3>& positions, const PoissonSolver* solver) {
    const auto start = std::chrono::steady_clock::now();
    DGV_CHECK(settings.validate().empty());
    DGV_CHECK(!pins.empty());
    const std::vector<unsigned char> fixed = fixedPositionMask(lat, pins);
    checkEveryComponentPinned(lat, fixed);
    const bool cold = static_cast<Index>(positions.size()) != lat.size();
    if (cold) {
        Vec3 first = pins.front().position;
        for (const Pin& pin : pins)
            if (pin.fixPosition) {
                first = pin.position;
                break;
            }
        positions.assign(at(lat.size()), first);
    }
    for (const Pin& pin : pins)
        if (pin.fixPosition) positions[at(pin.point)] = pin.position;
    SolveReport report;
    switch (settings.method) {
        case ReconstructMethod::Path:
            integratePositionsAlongTree(lat, e, frames, pins, positions);
            report.converged = true;
            report.residual = positionResidual(lat, e, frames, fixed, positions);
            break;
        case ReconstructMethod::LeastSquares: {
            std::unique_ptr<PoissonSolver> own;
            if (!solver || !solver->matches(lat, fixed)) {
                own = std::make_unique<PoissonSolver>(lat, fixed);
                solver = own.get();
            }
            report = solver->solve(lat, e, frames, positions, settings.tolerance,
                                   std::min(settings.maxIterations, 1000), cold || settings.startFromPath);
            if (settings.wall && report.converged) {
                GatherSettings g = settings.gather();
                g.method = GatherMethod::Sor;
                g.sorForm = SorForm::Standard;
                // Apply the wall once; polish only if it moved something.
                bool moved = false;
                for (Index p = 0; p < lat.size(); ++p)
                    if (!fixed[at(p)] && g.wall(p, positions[at(p)])) moved = true;
                if (moved) {
                    const SolveReport polish = gatherPositions(lat, e, frames, fixed, g, positions);
                    report.iterations += polish.iterations;
                    report.residual = polish.residual;
                    report.converged = polish.converged;
                    report.diverged = polish.diverged;
                }
            }
            break;
        }
        default:
            report = gatherPositions(lat, e, frames, fixed, settings.gather(), positions);
            break;
    }
    report.seconds = since(start);
    return report;
}

void connectionChangeSteps(const Lattice& lat, const SpanningTree& tree, const std::array<std::vector<Mat3>, 3>& gamma0,
                           const std::array<std::vector<Mat3>, 3>& gamma1, const std::vector<Mat3>& frames,
                           ConnectionChangeWorkspace& work, std::array<std::vector<Vec3>, 3>& forward,
                           int frameSweeps) {
    DGV_CHECK(frameSweeps >= 0);
    const Index n = lat.size();
    for (std::size_t c = 0; c < 3; ++c) {
        DGV_CHECK_EQ(static_cast<Index>(gamma0[c].size()), n);
        DGV_CHECK_EQ(static_cast<Index>(gamma1[c].size()), n);
    }
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), n);
    DGV_CHECK_EQ(static_cast<Index>(tree.parent.size()), n);
    ConnectionChangeWorkspace& w = work;
    auto clock = std::chrono::steady_clock::now();
    auto lap = [&clock] {  // seconds since the last lap
        const auto now = std::chrono::steady_clock::now();
        const double s = std::chrono::duration<double>(now - clock).count();
        clock = now;
        return s;
    };
    constexpr Real kSweepEdgeBound = 1;  // |S|_1 beyond which an edge's transport is not averaged
    const bool sweeping = frameSweeps > 0;
    for (std::size_t b = 0; b < 3; ++b) {
        w.from0[b].resize(at(n));
        w.to0[b].resize(at(n));
        w.from1[b].resize(at(n));
        w.to1[b].resize(at(n));
        if (sweeping) {  // every edge's transports, for the sweeps only
            w.steep[b].resize(at(n));
            w.up0[b].resize(at(n));
            w.down0[b].resize(at(n));
            w.up1[b].resize(at(n));
            w.down1[b].resize(at(n));
        }
        forward[b].resize(at(n));
    }
    const std::size_t m = tree.order.size();
    w.tree0.resize(at(n));
    w.tree1.resize(at(n));
    // Each edge p -> q = p + e_b once, on p: its step vectors φ1(±S) e_b, and the tree child's
    // transport where it is a tree edge (one writer per child). With sweeps, every edge's
    // transport both ways (up, down), and the steps from φ1(S): φ1(−S) e_b = exp(−S) φ1(S) e_b;
    // without, the steps by edgeSteps and exp(±S) of the tree's edges only (a third of the
    // work). Either way one connection and one axis a pass (below).
    auto generator = [&](const std::array<std::vector<Mat3>, 3>& gamma, Index p, int b, Index q) {
        Mat3 S;  // edgeGenerator(Γ(p), Γ(q), b, +1) without copying the connections
        for (std::size_t c = 0; c < 3; ++c)
            for (int a = 0; a < 3; ++a) S(Index(c), a) = Real(0.5) * (gamma[c][at(p)](a, b) + gamma[c][at(q)](a, b));
        return S;
    };
    auto intoQ = [&](Index p, int b, Index q) { return tree.parent[at(q)] == p && tree.slot[at(q)] == 2 * b + 1; };
    auto intoP = [&](Index p, int b, Index q) { return tree.parent[at(p)] == q && tree.slot[at(p)] == 2 * b; };
    auto treeEdge = [&](const std::array<std::vector<Mat3>, 3>& gamma, Index p, int b, Index q, Vec3& from, Vec3& to,
                        std::vector<Mat3>& treeT) {
        const Mat3 S = generator(gamma, p, b, q);
        Mat3 phi1;
        edgeSteps(S, b, from, to);
        if (intoQ(p, b, q)) expPhi1(S, treeT[at(q)], phi1);
        if (intoP(p, b, q)) expPhi1(-S, treeT[at(p)], phi1);
    };
    // One connection's edges along axis b, swept form, out of the points [begin, end): the
    // edges of consecutive points exponentiated together (expPhi1Batch, the same bits); marks
    // the steep ones in w.steep (`first`: the first connection, which clears the marks).
    auto sweptEdges = [&](const std::array<std::vector<Mat3>, 3>& gamma, int b, Index begin, Index end,
                          std::vector<Vec3>& from, std::vector<Vec3>& to, std::vector<Mat3>& up,
                          std::vector<Mat3>& down, std::vector<Mat3>& treeT, bool first) {
        constexpr int kBatch = 4;
        std::array<Mat3, kBatch> S, E, phi1;
        std::array<Index, kBatch> point{};
        const std::size_t bb = at(b);
        int count = 0;
        auto flush = [&] {
            expPhi1Batch(S.data(), E.data(), phi1.data(), count);
            for (std::size_t l = 0; l < static_cast<std::size_t>(count); ++l) {
                const Index p = point[l];
                const Index q = lat.neighbours[at(p)][at(2 * b + 1)];
                up[at(p)] = E[l];
                down[at(p)] = E[l].inverse();
                from[at(p)] = phi1[l].col(b);
                to[at(p)] = down[at(p)].lazyProduct(from[at(p)]);
                if (intoQ(p, b, q)) treeT[at(q)] = up[at(p)];
                if (intoP(p, b, q)) treeT[at(p)] = down[at(p)];
                if (S[l].cwiseAbs().colwise().sum().maxCoeff() > kSweepEdgeBound) w.steep[bb][at(p)] = 1;
            }
            count = 0;
        };
        for (Index p = begin; p < end; ++p) {
            if (first) w.steep[bb][at(p)] = 0;
            const Index q = lat.neighbours[at(p)][at(2 * b + 1)];
            if (q == kNoPoint) {
                from[at(p)].setZero();
                to[at(p)].setZero();
                continue;
            }
            S[at(count)] = generator(gamma, p, b, q);
            point[at(count++)] = p;
            if (count == kBatch) flush();
        }
        if (count > 0) flush();
    };
    // With sweeps, one connection and one axis a pass: measured at r = 32 (dgv bench step),
    // both connections in one pass (32 arrays written at once) took 95 ms, one connection a pass
    // (16 arrays) 70 ms, one connection and axis a pass (6) 58 ms; the point's record of all six
    // transports (one array of 432-byte records) 80 ms. The hardware follows only so many streams.
    auto sweptPass = [&](const std::array<std::vector<Mat3>, 3>& gamma, std::array<std::vector<Vec3>, 3>& from,
                         std::array<std::vector<Vec3>, 3>& to, std::array<std::vector<Mat3>, 3>& up,
                         std::array<std::vector<Mat3>, 3>& down, std::vector<Mat3>& treeT, bool first) {
        for (int b = 0; b < 3; ++b) {
            const std::size_t bb = at(b);
            parallelForBlocks(
                n,
                [&](Index begin, Index end) {
                    sweptEdges(gamma, b, begin, end, from[bb], to[bb], up[bb], down[bb], treeT, first);
                },
                1024);
        }
    };
    if (sweeping) {
        sweptPass(gamma0, w.from0, w.to0, w.up0, w.down0, w.tree0, true);
        sweptPass(gamma1, w.from1, w.to1, w.up1, w.down1, w.tree1, false);
    } else {
        auto treePass = [&](const std::array<std::vector<Mat3>, 3>& gamma, std::array<std::vector<Vec3>, 3>& from,
                            std::array<std::vector<Vec3>, 3>& to, std::vector<Mat3>& treeT) {
            for (int b = 0; b < 3; ++b) {
                const std::size_t bb = at(b);
                parallelFor(
                    n,
                    [&](Index p) {
                        const Index q = lat.neighbours[at(p)][at(2 * b + 1)];
                        if (q == kNoPoint) {
                            from[bb][at(p)].setZero();
                            to[bb][at(p)].setZero();
                        } else {
                            treeEdge(gamma, p, b, q, from[bb][at(p)], to[bb][at(p)], treeT);
                        }
                    },
                    1024);
            }
        };
        treePass(gamma0, w.from0, w.to0, w.tree0);
        treePass(gamma1, w.from1, w.to1, w.tree1);
    }
    w.edgeSeconds = lap();
    // The frames along the tree (eq 57), both connections at once, in the tree's order (the
    // parents are recent entries), then put back in point order.
    w.ordered0.resize(m);
    w.ordered1.resize(m);
    parallelFor(static_cast<Index>(m), [&](Index i) {  // the transports in the tree's order
        const std::size_t q = at(tree.order[at(i)]);
        w.ordered0[at(i)] = w.tree0[q];
        w.ordered1[at(i)] = w.tree1[q];
    });
    auto integrate = [&](std::vector<Mat3>& ordered) {  // in place: transport -> frame
        for (std::size_t i = 0; i < m; ++i) {
            const Index parent = tree.parentPosition[i];
            ordered[i] = parent < 0 ? frames[at(tree.order[i])] : Mat3(ordered[at(parent)].lazyProduct(ordered[i]));
        }
    };
    parallelInvoke([&] { integrate(w.ordered0); }, [&] { integrate(w.ordered1); });
    if (m < at(n)) {  // points the tree misses (a component without a root) keep `frames`
        w.frames0 = frames;
        w.frames1 = frames;
    } else {
        w.frames0.resize(at(n));
        w.frames1.resize(at(n));
    }
    parallelFor(static_cast<Index>(m), [&](Index i) {
        w.frames0[at(tree.order[at(i)])] = w.ordered0[at(i)];
        w.frames1[at(tree.order[at(i)])] = w.ordered1[at(i)];
    });
    w.treeSeconds = lap();
    // Red-black Gauss-Seidel sweeps over each frame field: every point not a root takes the mean
    // of its neighbours' frames carried across the edges, F(q) ← mean_p F(p) exp(S_pq), the
    // least-squares frame of q given its neighbours (docs/math.md, "Frames that do not depend
    // on the tree"). Along the tree alone the frames of a connection that is not exactly
    // integrable (Γ + δΓ never is) depend on the path to the root; the realisation of δΓ then
    // had complex eigenvalues, through which the shape memory's oscillator grew from round-off.
    // Both fields get the same sweeps, so δΓ = 0 still asks for no step. The roots (a free
    // body's centre, every pinned point) keep their frames: the pins clamp. Freed, with one root a
    // component held for the gauge, a box pinned by its bottom face under gravity crept sideways
    // at 0.1 mm/s (an affine shear keeps the base and has Γ = 0: the memory cannot see it), and a
    // least-squares gauge over the pins still let it creep at a fifth of that. A point on a steep
    // edge (|S|_1 > kSweepEdgeBound in either connection: a fold beginning) keeps its tree
    // frame, a guard: there exp(±S) scales a neighbour's frame by up to e^|S|, and a mean of such
    // predictions is no better a frame than the tree's (a smooth shape's Γ stays well under 1).
    // The points that sweep, per colour (u.x + u.y + u.z even or odd), listed once: not a root,
    // not on a steep edge. A colour's points read only the other colour's frames, so the points
    // of a colour update in any order to the same bits.
    if (sweeping) {
        for (auto& list : w.swept) list.clear();
        for (Index q = 0; q < n; ++q) {
            if (tree.parent[at(q)] == kNoPoint) continue;  // a root, or a point the tree misses
            bool steep = false;
            for (std::size_t b = 0; b < 3; ++b) {
                const Index below = lat.neighbours[at(q)][2 * b];
                if ((below != kNoPoint && w.steep[b][at(below)]) || w.steep[b][at(q)]) steep = true;
            }
            const Vec3i& u = lat.coords[at(q)];
            if (!steep) w.swept[at((u.x() + u.y() + u.z()) & 1)].push_back(q);
        }
    }
    auto meanFrame = [&](const std::array<std::vector<Mat3>, 3>& up, const std::array<std::vector<Mat3>, 3>& down,
                         const std::vector<Mat3>& F, Index q) {
        Mat3 sum = Mat3::Zero();
        int count = 0;
        for (std::size_t b = 0; b < 3; ++b) {
            const Index below = lat.neighbours[at(q)][2 * b], above = lat.neighbours[at(q)][2 * b + 1];
            if (below != kNoPoint) {  // the edge below -> q, stored on below
                sum.noalias() += F[at(below)].lazyProduct(up[b][at(below)]);
                ++count;
            }
            if (above != kNoPoint) {  // the edge q -> above, stored on q, crossed backwards
                sum.noalias() += F[at(above)].lazyProduct(down[b][at(q)]);
                ++count;
            }
        }
        return Mat3(sum / static_cast<Real>(count));
    };
    for (int k = 0; k < frameSweeps; ++k)
        for (const std::vector<Index>& list : w.swept)  // one field at a time: measured, both in one
            for (int field = 0; field < 2; ++field)     // pass took twice as long (twice the streams)
                parallelFor(
                    static_cast<Index>(list.size()),
                    [&](Index i) {
                        const Index q = list[at(i)];
                        if (field == 0)
                            w.frames0[at(q)] = meanFrame(w.up0, w.down0, w.frames0, q);
                        else
                            w.frames1[at(q)] = meanFrame(w.up1, w.down1, w.frames1, q);
                    },
                    512);
    w.sweepSeconds = lap();
    // D1 − D0 per edge (positionStep's arithmetic).
    parallelFor(n, [&](Index p) {
        for (int b = 0; b < 3; ++b) {
            const std::size_t bb = at(b);
            const Index q = lat.neighbours[at(p)][at(2 * b + 1)];
            if (q == kNoPoint) {
                forward[bb][at(p)].setZero();
                continue;
            }
            // lazyProduct: the products inline (Eigen's own call per 3×3 product was 8% of the
            // step's profile), the same arithmetic
            const Vec3 d1 = Real(0.5) * (w.frames1[at(p)].lazyProduct(w.from1[bb][at(p)]) +
                                         w.frames1[at(q)].lazyProduct(w.to1[bb][at(p)]));
            const Vec3 d0 = Real(0.5) * (w.frames0[at(p)].lazyProduct(w.from0[bb][at(p)]) +
                                         w.frames0[at(q)].lazyProduct(w.to0[bb][at(p)]));
            forward[bb][at(p)] = d1 - d0;
        }
    });
}

}  // namespace dgv
