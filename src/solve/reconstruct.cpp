#include "solve/reconstruct.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>

namespace dgv {

namespace {

inline std::size_t at(Index p) { return static_cast<std::size_t>(p); }

double since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Breadth-first order from the marked points (in point order), neighbours in slot order:
/// returns the visit order; parent/slot give each visited point's tree edge (parent -> point).
std::vector<Index> bfsOrder(const Lattice& lat, const std::vector<unsigned char>& roots,
                            std::vector<Index>& parent, std::vector<signed char>& slotFromParent) {
    parent.assign(at(lat.size()), kNoPoint);
    slotFromParent.assign(at(lat.size()), -1);
    std::vector<unsigned char> seen(roots);
    std::vector<Index> order;
    order.reserve(at(lat.size()));
    for (Index p = 0; p < lat.size(); ++p)
        if (roots[at(p)]) order.push_back(p);
    for (std::size_t head = 0; head < order.size(); ++head) {
        const Index p = order[head];
        for (int slot = 0; slot < 6; ++slot) {
            const Index q = lat.neighbours[at(p)][at(slot)];
            if (q == kNoPoint || seen[at(q)]) continue;
            seen[at(q)] = 1;
            parent[at(q)] = p;
            slotFromParent[at(q)] = static_cast<signed char>(slot);
            order.push_back(q);
        }
    }
    return order;
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
        case ReconstructMethod::Jacobi: g.method = GatherMethod::Jacobi; break;
        case ReconstructMethod::JacobiSummed: g.method = GatherMethod::JacobiSummed; break;
        case ReconstructMethod::AdaptiveGain: g.method = GatherMethod::AdaptiveGain; break;
        default: g.method = GatherMethod::Sor; break;
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

std::vector<Pin> centrePins(const Lattice& lat, const std::vector<Vec3>& positions,
                            const std::vector<Mat3>& frames) {
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

void integrateFramesAlongTree(const Lattice& lat, const EdgeTransports& e,
                              const std::vector<Pin>& pins, std::vector<Mat3>& frames) {
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    for (const Pin& pin : pins)
        if (pin.fixFrame) frames[at(pin.point)] = pin.frame;
    std::vector<Index> parent;
    std::vector<signed char> slot;
    const std::vector<Index> order = bfsOrder(lat, fixedFrameMask(lat, pins), parent, slot);
    for (const Index q : order) {
        const Index p = parent[at(q)];
        if (p == kNoPoint) continue;
        frames[at(q)] = frames[at(p)] * frameTransport(lat, e, p, slot[at(q)]);  // eq 57
    }
}

void integratePositionsAlongTree(const Lattice& lat, const EdgeTransports& e,
                                 const std::vector<Mat3>& frames, const std::vector<Pin>& pins,
                                 std::vector<Vec3>& positions) {
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(frames.size()), lat.size());
    for (const Pin& pin : pins)
        if (pin.fixPosition) positions[at(pin.point)] = pin.position;
    std::vector<Index> parent;
    std::vector<signed char> slot;
    const std::vector<Index> order = bfsOrder(lat, fixedPositionMask(lat, pins), parent, slot);
    for (const Index q : order) {
        const Index p = parent[at(q)];
        if (p == kNoPoint) continue;
        positions[at(q)] = positions[at(p)] + positionStep(lat, e, frames, p, slot[at(q)]);  // eq 59
    }
}

SolveReport reconstructFrames(const Lattice& lat, const EdgeTransports& e,
                              const std::vector<Pin>& pins, const ReconstructSettings& settings,
                              std::vector<Mat3>& frames) {
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
    if (settings.method == ReconstructMethod::Path ||
        settings.method == ReconstructMethod::LeastSquares) {
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

SolveReport reconstructPositions(const Lattice& lat, const EdgeTransports& e,
                                 const std::vector<Mat3>& frames, const std::vector<Pin>& pins,
                                 const ReconstructSettings& settings, std::vector<Vec3>& positions,
                                 const PoissonSolver* solver) {
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
                                   std::min(settings.maxIterations, 1000),
                                   cold || settings.startFromPath);
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

}  // namespace dgv
