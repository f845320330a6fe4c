// The dynamics step against its long-run and accuracy goals
// (docs/math.md, "The dynamics step"): 1,000 frames of a jelly under a strong, changing vortex
// with no fault, no inverted cell and bounded energy; and a vortex over a short time against the
// free-particle motion of every material point, with the error shrinking as δt does.
// `DGV_TEST_VERBOSE=1` prints the figures.
#include <catch2/catch.hpp>

#include "dynamics/lattices.hpp"
#include "dynamics/stepper.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace dgv;

namespace {

bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

Lattice ball(int radius, Real h, const Vec3& centre) {
    return test::sphereLattice(radius, h, centre - Vec3::Constant(radius * h));
}

ForceTerm vortex(Keyframes strength, Real radius) {
    ForceTerm t;
    t.kind = ForceKind::Vortex;
    t.strength = std::move(strength);
    t.centre = Vec3::Zero();
    t.axis = Vec3::UnitY();
    t.radius = radius;
    t.falloff = 1;
    return t;
}

/// Root mean square over points of |a − b|.
Real rms(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    Real s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]).squaredNorm();
    return std::sqrt(s / static_cast<Real>(a.size()));
}

/// The part of x that no affine map of `rest` explains (least squares, equal weights).
std::vector<Vec3> nonAffine(const std::vector<Vec3>& x, const std::vector<Vec3>& rest) {
    const std::size_t n = x.size();
    Vec3 cx = Vec3::Zero(), cr = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) cx += x[i], cr += rest[i];
    cx /= static_cast<Real>(n);
    cr /= static_cast<Real>(n);
    Mat3 xr = Mat3::Zero(), rr = Mat3::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        xr += (x[i] - cx) * (rest[i] - cr).transpose();
        rr += (rest[i] - cr) * (rest[i] - cr).transpose();
    }
    const Mat3 A = xr * rr.inverse();
    std::vector<Vec3> out(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = x[i] - (cx + A * (rest[i] - cr));
    return out;
}

}  // namespace

// A stiff jelly (k = 1000/s², ζ = 2/s, 8 voxels' radius) set spinning by a brief off-centre
// vortex, then free flight. Damping should make Σ|δΓ|² settle, and it does for 20 s with the
// reconstruction's frame sweeps (docs/math.md, "Frames that do not depend on the tree"). With
// the spanning tree's frames alone (frameSweeps = 0) the realisation of δΓ has complex
// eigenvalues and the shape memory's oscillator grows through them: ×190 by frame 480, 1.6 by
// frame 720 (it then shakes itself apart). The notes' rotation of δΓ (R(−2θ) in eq 76), which
// grew the twist ×2,000 within 4 s on the tree's frames (taken before as its own defect), stays
// bounded too once the frames are swept.
TEST_CASE("stepper: a stiff spinning jelly keeps its twist bounded in free flight", "[dynamics][stepper][long][slow]") {
    const Real h = 0.0625;
    const Lattice lat = ball(8, h, Vec3(-0.2, 0, 0));
    ForceField field;
    ForceTerm swirl = vortex(Keyframes{{{1, 0}, {4, 4}, {8, 0}}}, 1.0);
    swirl.axis = Vec3::UnitZ();
    field.add(swirl);
    struct Outcome {
        Real afterPush = 0, lastSecond = 0;
        std::string fault;
    };
    auto run = [&](int sweeps, bool rotation, int frames) {
        DynamicsSettings jelly;
        jelly.shapeStiffness = 1000;
        jelly.damping = 2;
        jelly.frameSweeps = sweeps;
        jelly.twistRotation = rotation;
        DeformableBody body(lat, restPositions(lat), jelly);
        Outcome o;
        const int substeps = 4;
        for (int f = 1; f <= frames && o.fault.empty(); ++f)
            for (int s = 0; s < substeps && o.fault.empty(); ++s) {
                const StepReport r = body.step(field, f + static_cast<Real>(s) / substeps, 1.0 / 96, {});
                o.fault = r.fault;
                if (f == 8) o.afterPush = std::max(o.afterPush, r.sumDeltaGamma2);
                if (f > frames - 24) o.lastSecond = std::max(o.lastSecond, r.sumDeltaGamma2);
            }
        return o;
    };
    const DynamicsSettings defaults;
    REQUIRE(defaults.frameSweeps > 0);
    REQUIRE(!defaults.twistRotation);
    const Outcome swept = run(defaults.frameSweeps, false, 480);
    const Outcome tree = run(0, false, 480);
    const Outcome notes = run(defaults.frameSweeps, true, 104);
    if (verbose())
        std::printf(
            "spinning jelly k = 1000: sum dGamma^2 after the push %.3g, largest in the 20th second %.3g (%s); "
            "on the tree's frames %.3g -> %.3g (%s); with the notes' rotation, 4th second %.3g -> %.3g (%s)\n",
            swept.afterPush, swept.lastSecond, swept.fault.c_str(), tree.afterPush, tree.lastSecond, tree.fault.c_str(),
            notes.afterPush, notes.lastSecond, notes.fault.c_str());
    REQUIRE(swept.fault.empty());
    REQUIRE(swept.afterPush > 0);
    CHECK(swept.lastSecond < 0.01 * swept.afterPush);                       // measured 6.4e-8 against 3.7e-5
    CHECK((!tree.fault.empty() || tree.lastSecond > 10 * tree.afterPush));  // measured 7.2e-3 against 3.7e-5
    REQUIRE(notes.fault.empty());
    CHECK(notes.lastSecond < 0.1 * notes.afterPush);  // measured 1.2e-7 against 3.8e-5
}

TEST_CASE("stepper: a jelly under a strong alternating vortex for 1000 frames", "[dynamics][stepper][long][slow]") {
    // A ball of 4 voxels' radius whose centre is 0.1 m from the axis of a vortex (so the axis runs
    // through it and the core turns faster than the rim), strength swinging between +4 and −4 m/s²
    // every 24 frames at 24 fps, 2 substeps: 2,000 steps; a linear trap keeps it near the axis.
    // The field keeps doing work on the body, so "bounded" means no growth: the peaks of kinetic
    // energy about the centre and of Σ|δΓ|² in the second half stay at the first half's level. The level is the mean
    // over the half's 50-frame windows (each holds a full period) of each window's peak: the
    // windows' peaks of Σ|δΓ|² vary 3× with the vortex's phase, so the halves' single largest
    // peaks are a noisy figure (0.0686 → 0.0781 while every window after frame 672 stayed below
    // 0.068, measured).
    const Real h = 0.05;
    const Lattice lat = ball(4, h, Vec3(0.1, 0, 0));
    DynamicsSettings jelly;
    jelly.shapeStiffness = 50;
    jelly.damping = 1;
    DeformableBody body(lat, restPositions(lat), jelly);
    std::vector<std::pair<Real, Real>> keys{{1, 0}};
    for (int f = 12; f <= 1001; f += 24) keys.emplace_back(f, (f / 24) % 2 == 0 ? 4.0 : -4.0);
    ForceField field;
    field.add(vortex(Keyframes{keys}, 0.4));
    // A harmonic trap toward the axis (linear: no Hessian, it moves only body and flex) keeps the
    // body in the vortex's core instead of letting it fly off along the tangent.
    ForceTerm trap;
    trap.kind = ForceKind::Linear;
    trap.strength = Keyframes::constant(1);
    trap.centre = Vec3::Zero();
    trap.matrix = Vec3(-4, 0, -4).asDiagonal();
    field.add(trap);

    const int frames = 1000, substeps = 2;
    const Real dt = 1.0 / (24.0 * substeps);
    Real maxErr = 0, maxDrift = 0;
    constexpr int kWindow = 50;
    std::vector<Real> keWindow(frames / kWindow, 0), dgWindow(frames / kWindow, 0);
    Index inverted = 0;
    bool finite = true;
    std::string fault;
    for (int f = 1; f <= frames && fault.empty(); ++f)
        for (int s = 0; s < substeps; ++s) {
            const StepReport r = body.step(field, f + static_cast<Real>(s) / substeps, dt, {});
            if (!r.fault.empty()) {
                fault = "frame " + std::to_string(f) + ": " + r.fault;
                break;
            }
            const std::size_t w = static_cast<std::size_t>((f - 1) / kWindow);
            // The kinetic energy about the centre (flex and twist): the centre's own is its orbit
            // in the trap, exact by eqs 66-67 and quasi-periodic (its 50-frame peaks range 9-33 J
            // in either half), so it says nothing of the step's stability.
            const Real internal = r.kineticEnergy - Real(0.5) * body.totalMass() * body.centreVelocity().squaredNorm();
            keWindow[w] = std::max(keWindow[w], internal);
            dgWindow[w] = std::max(dgWindow[w], r.sumDeltaGamma2);
            maxErr = std::max(maxErr, r.maxCellVolumeError);
            maxDrift = std::max(maxDrift, std::abs(r.totalVolumeDrift));
            inverted = std::max(inverted, r.invertedCells);
            finite = finite && std::isfinite(r.kineticEnergy) && std::isfinite(r.sumDeltaGamma2);
        }
    for (const Vec3& x : body.positions()) finite = finite && x.allFinite();
    Real keHalf[2] = {0, 0}, dgHalf[2] = {0, 0};  // the mean window peak of each half
    const std::size_t windows = keWindow.size();
    for (std::size_t w = 0; w < windows; ++w) {
        const std::size_t half = 2 * w < windows ? 0 : 1;
        keHalf[half] += keWindow[w] / static_cast<Real>(windows / 2);
        dgHalf[half] += dgWindow[w] / static_cast<Real>(windows / 2);
    }
    const Real axisDistance = std::hypot(body.centre().x(), body.centre().z());
    if (verbose()) std::printf("jelly: centre %.3f m from the vortex axis after 1000 frames\n", axisDistance);
    if (verbose())
        std::printf(
            "jelly, 1000 frames of an alternating vortex: mean 50-frame peak of KE about the centre %.4g J (first "
            "half) / "
            "%.4g J (second), of sum dGamma^2 %.3g / %.3g, max cell error %.2e, max |drift| %.2e, "
            "inverted %lld\n",
            keHalf[0], keHalf[1], dgHalf[0], dgHalf[1], maxErr, maxDrift, static_cast<long long>(inverted));
    INFO(fault);
    REQUIRE(fault.empty());
    CHECK(finite);
    CHECK(inverted == 0);
    CHECK(keHalf[0] > 1);                // the field really drives it (4.6 J about the centre, 30 J with the orbit)
    CHECK(dgHalf[1] > 0.1 * dgHalf[0]);  // and still deforms it at the end
    CHECK(axisDistance < 1.0);           // still where the vortex is strong (2.5 m/s² at 0.65 m, measured)
    // measured (mean window peaks, with the flex keeping its spin): 4.594 →
    // 4.595 J about the centre and 0.0609 → 0.0545 (while the flex lost its spin: 2.93 → 2.41 J;
    // the whole kinetic energy's window peaks, 22.5 → 26.8 J, rise and fall with the orbit).
    // Earlier, with the whole kinetic energy: 24.8 → 24.5 J and 0.0468 → 0.0460 (the old gauge:
    // 0.067 → 0.073); as the halves' largest peaks 31.5 → 31.5 J and 0.0686 → 0.0781 (0.127 →
    // 0.129 with the old gauge; 31.5 → 34.5 J and 0.379 → 0.372 before the mass-weighted volume
    // projection and the flex's SHAKE step). A growing solution would double.
    CHECK(keHalf[1] <= 1.1 * keHalf[0]);
    CHECK(dgHalf[1] <= 1.1 * dgHalf[0]);
    CHECK(maxErr <= 1e-4);
    CHECK(maxDrift <= 1e-5);
}

TEST_CASE("stepper: a vortex over a short time matches the free-particle motion of every point",
          "[dynamics][stepper]") {
    // Goo has no internal stress, so over a short time every material point should move like a free
    // particle in the field, x'' = F(x) from rest; the truth is integrated per point with RK4 at
    // 1/4000 s. The step splits the motion into body, flex (the force's first moment) and twist
    // (eq 76's Hessian term): it follows the truth to first order in the force's amplitude s, so its
    // error is C δt (first order in the time step: the twist update) plus a floor that grows like
    // s² (measured: 1.78e-3 → 7.05e-3 → 2.80e-2 → 0.110 voxel for s = 0.1 … 0.8, ratio 3.96-4.0;
    // the same without the volume projection, so it is the model's, not the constraint's).
    const Real h = 0.05, T = 0.5;
    const Lattice lat = ball(5, h, Vec3(0.15, 0, 0));
    const std::vector<Vec3> rest = restPositions(lat);
    const std::vector<Vec3> zero(rest.size(), Vec3::Zero());
    auto truthFor = [&](const ForceField& field) {
        std::vector<Vec3> truth = rest;
        const int n = 2000;
        const Real dt = T / n;
        for (Vec3& x0 : truth) {
            Vec3 x = x0, v = Vec3::Zero();
            for (int s = 0; s < n; ++s) {
                const Vec3 k1x = v, k1v = field.value(x, 1);
                const Vec3 k2x = v + 0.5 * dt * k1v, k2v = field.value(x + 0.5 * dt * k1x, 1);
                const Vec3 k3x = v + 0.5 * dt * k2v, k3v = field.value(x + 0.5 * dt * k2x, 1);
                const Vec3 k4x = v + dt * k3v, k4v = field.value(x + dt * k3x, 1);
                x += dt / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
                v += dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
            }
            x0 = x;
        }
        return truth;
    };
    DynamicsSettings goo;
    goo.damping = 0;  // the truth is undamped
    auto errorFor = [&](const ForceField& field, const std::vector<Vec3>& truth, int steps) {
        DeformableBody body(lat, rest, goo);
        for (int s = 0; s < steps; ++s) {
            const StepReport r = body.step(field, 1, T / steps, {});
            REQUIRE(r.fault.empty());
        }
        return rms(body.positions(), truth);
    };

    ForceField weak, twice;
    weak.add(vortex(Keyframes::constant(0.1), 0.4));
    twice.add(vortex(Keyframes::constant(0.2), 0.4));
    const std::vector<Vec3> truthWeak = truthFor(weak), truthTwice = truthFor(twice);
    const Real moved = rms(truthWeak, rest), movedNA = rms(nonAffine(truthWeak, rest), zero);
    std::vector<Real> e;
    for (int steps : {3, 6, 12, 48}) e.push_back(errorFor(weak, truthWeak, steps));
    const Real floorTwice = errorFor(twice, truthTwice, 48);
    if (verbose())
        std::printf(
            "vortex vs free particles, s = 0.1, T = %.1f s: rms motion %.4f voxel (non-affine %.4f); rms error "
            "%.3e / %.3e / %.3e / %.3e voxel at 3 / 6 / 12 / 48 steps; s = 0.2 at 48 steps: %.3e (ratio %.2f)\n",
            T, moved / h, movedNA / h, e[0] / h, e[1] / h, e[2] / h, e[3] / h, floorTwice / h, floorTwice / e[3]);
    CHECK(moved > 0.15 * h);
    CHECK(movedNA > 0.1 * moved);  // a real non-affine part (15%), which the flex alone cannot follow
    // first order in δt while the step error dominates
    CHECK(e[0] / e[1] > 1.7);
    CHECK(e[1] / e[2] > 1.6);
    // the floor: second order in the amplitude, and at s = 0.1 under 2% of the motion
    CHECK(floorTwice / e[3] > 3.5);
    CHECK(floorTwice / e[3] < 4.5);
    CHECK(e[3] < 0.02 * moved);
}
