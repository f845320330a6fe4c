// A pinned body under a uniform load (dynamics/load_modes.hpp; docs/math.md, "A pinned body
// under a uniform load"): the Stokes modes, the sag of a jelly to the modal closed form, a box
// held below carrying its weight, goo falling at the modal rate, and checkpoints.
#include <catch2/catch.hpp>

#include "deform/volume.hpp"
#include "dynamics/body.hpp"
#include "dynamics/lattices.hpp"
#include "dynamics/load_modes.hpp"
#include "dynamics/stepper.hpp"
#include "solve/sparse_solve.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace dgv;
using dgv::test::boxLattice;
using dgv::test::gravityField;

namespace {

bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

/// A bar 17 x 5 x 5 points at 0.05 m held by its end plane x = 0 (a cantilever).
struct Cantilever {
    Lattice lat = boxLattice(Vec3i(17, 5, 5), 0.05, Vec3(0, 0.5, 0));
    std::vector<unsigned char> pinned;
    Cantilever() {
        pinned.assign(at(lat.size()), 0);
        for (Index p = 0; p < lat.size(); ++p) pinned[at(p)] = lat.coords[at(p)].x() == 0;
    }
};

DynamicsSettings jelly(Real k, Real damping) {
    DynamicsSettings s;
    s.shapeStiffness = k;
    s.damping = damping;
    return s;
}

}  // namespace

TEST_CASE("load modes: each is volume-keeping, zero at the pins and largest at the free end", "[dynamics][load]") {
    Cantilever c;
    const std::vector<Vec3> rest = restPositions(c.lat);
    const LatticeCells cells = buildCells(c.lat);
    const std::vector<Real> v0 = cellVolumes(cells, rest);
    const std::vector<Real> mass = pointMasses(c.lat, 1000, MassRule::CellShare);
    const PoissonSolver solver(c.lat, c.pinned);
    const LoadModes m = computeLoadModes(c.lat, rest, c.pinned, cells, v0, mass, solver);
    REQUIRE_FALSE(m.empty());
    // J w = 0 to the solve's tolerance, cell by cell: the cells' volume change per unit amplitude
    for (std::size_t i = 0; i < 3; ++i) {
        Real worst = 0, largest = 0;
        for (Index cell = 0; cell < cells.size(); ++cell) {
            std::array<Vec3, 8> x;
            std::array<Vec3, 8> g;
            for (std::size_t k = 0; k < 8; ++k) x[k] = rest[at(cells.corners[at(cell)][k])];
            (void)hexVolumeGradient(x, g);
            Real dv = 0;
            for (std::size_t k = 0; k < 8; ++k) dv += g[k].dot(m.w[i][at(cells.corners[at(cell)][k])]);
            worst = std::max(worst, std::abs(dv) / v0[at(cell)]);
        }
        Index far = 0;
        for (Index p = 0; p < c.lat.size(); ++p) {
            largest = std::max(largest, m.w[i][at(p)].norm());
            if (c.pinned[at(p)]) CHECK(m.w[i][at(p)].norm() == 0);
            if (m.w[i][at(p)].norm() > m.w[i][at(far)].norm()) far = p;
        }
        if (verbose())
            std::printf("load mode %zu: max |J w| per cell %.2e per unit amplitude, largest at x = %d, strain %.3f/m\n",
                        i, worst, c.lat.coords[at(far)].x(), m.strain[static_cast<Index>(i)]);
        // a unit amplitude moves the free end 1 m while no cell changes by more than 1e-5 of its
        // volume: the polish leaves the central difference's O(ε²) and the projection's 1e-11
        // over ε (measured 1.5e-6 for the axial mode, 1.5e-10 for the bending ones; the
        // Schur complement's CG alone, stopped at 1e-2, left about 1e-2 of the Poisson
        // response's O(1) per cell)
        CHECK(worst < 1e-5);
        CHECK(std::abs(largest - 1) < 1e-12);
        CHECK(c.lat.coords[at(far)].x() == 16);
    }
    // the load along y moves the bar down where it pulls down: Σ m w_y · e_y > 0
    Real along = 0;
    for (Index p = 0; p < c.lat.size(); ++p) along += mass[at(p)] * m.w[1][at(p)].y();
    CHECK(along > 0);
    // M_q symmetric positive definite
    CHECK((m.mass - m.mass.transpose()).norm() <= 1e-12 * m.mass.norm());
    CHECK(Eigen::SelfAdjointEigenSolver<Mat3>(m.mass).eigenvalues().minCoeff() > 0);
}

TEST_CASE("load modes: a pinned jelly bar sags under gravity to the modal closed form and rests there",
          "[dynamics][load][slow]") {
    Cantilever c;
    const Real k = GENERATE(Real(200), Real(800));
    DeformableBody body(c.lat, restPositions(c.lat), jelly(k, 4), c.pinned);
    const ForceField g = gravityField();
    const Real dt = 1.0 / 48;
    StepReport last;
    Real maxErr = 0;
    for (int s = 0; s < 480; ++s) {
        last = body.step(g, 1, dt, {});
        REQUIRE(last.fault.empty());
        maxErr = std::max(maxErr, last.maxCellVolumeError);
    }
    // q* = M_q⁻¹ F_q / k with F_q,i = Σ m w_i · (0, −g, 0)
    const LoadModes& m = body.loadModes();
    Vec3 f = Vec3::Zero();
    for (Index p = 0; p < c.lat.size(); ++p)
        for (int i = 0; i < 3; ++i) f[i] += body.masses()[at(p)] * m.w[at(i)][at(p)].dot(Vec3(0, -9.81, 0));
    const Vec3 qStar = Vec3(m.mass.ldlt().solve(f)) / k;
    const Vec3 q = body.loadAmplitude();
    // every point where the mode puts it (the twist's memory holds the displaced rest shape)
    const std::vector<Vec3> rest = restPositions(c.lat);
    Real off = 0;
    for (Index p = 0; p < c.lat.size(); ++p) {
        const Vec3 target = rest[at(p)] + q[0] * m.w[0][at(p)] + q[1] * m.w[1][at(p)] + q[2] * m.w[2][at(p)];
        off = std::max(off, (body.positions()[at(p)] - target).norm());
    }
    const Index tip = c.lat.pointAt(Vec3i(16, 2, 2));
    const Real sag = rest[at(tip)].y() - body.positions()[at(tip)].y();
    if (verbose())
        std::printf(
            "cantilever k = %.0f: q_y %.6f (closed form %.6f), tip sag %.4f m, largest point off the mode %.2e m, "
            "kinetic energy %.2e J, max cell error %.2e\n",
            k, q.y(), qStar.y(), sag, off, last.kineticEnergy, maxErr);
    CHECK(std::abs(q.y() - qStar.y()) <= 1e-6 * std::abs(qStar.y()));  // 10 s: the damping's e^(-20)
    CHECK(std::abs(q.x()) <= 1e-9 * std::abs(qStar.y()));
    CHECK(sag > 0.9 * std::abs(qStar.y()));  // the tip moves almost the mode's largest displacement
    CHECK(off <= 1e-3 * std::abs(qStar.y()));
    CHECK(last.kineticEnergy < 1e-8);
    CHECK(maxErr <= 1e-4);
}

TEST_CASE("load modes: a jelly box held by its bottom face carries its weight without folding",
          "[dynamics][load][slow]") {
    const Real k = GENERATE(Real(100), Real(300), Real(1000));
    const Lattice lat = boxLattice(Vec3i(9, 9, 9), 0.05, Vec3(-0.2, 0, -0.2));
    std::vector<unsigned char> pinned(at(lat.size()), 0);
    for (Index p = 0; p < lat.size(); ++p) pinned[at(p)] = lat.coords[at(p)].y() == 0;
    DeformableBody body(lat, restPositions(lat), jelly(k, 4), pinned);
    const ForceField g = gravityField();
    const Real dt = 1.0 / 96;
    Real peak = 0, maxErr = 0, lastKe = 0;
    Index inverted = 0;
    for (int s = 0; s < 960; ++s) {
        const StepReport r = body.step(g, 1, dt, {});
        INFO("step " << s << ": " << r.fault);
        REQUIRE(r.fault.empty());
        peak = std::max(peak, r.kineticEnergy);
        maxErr = std::max(maxErr, r.maxCellVolumeError);
        inverted = std::max(inverted, r.invertedCells);
        lastKe = r.kineticEnergy;
    }
    const Index top = lat.pointAt(Vec3i(4, 8, 4));
    const Real sag = restPositions(lat)[at(top)].y() - body.positions()[at(top)].y();
    const Real strain = body.loadAmplitude().cwiseAbs().dot(body.loadModes().strain);
    if (verbose())
        std::printf(
            "box on its bottom face, k = %.0f: top sag %.4f m, mode strain %.3f, kinetic energy %.2e J "
            "(peak %.2e), max cell error %.2e\n",
            k, sag, strain, lastKe, peak, maxErr);
    CHECK(sag > 0);
    CHECK(strain <= body.settings().maxLoadStrain * (1 + 1e-12));
    CHECK(inverted == 0);
    CHECK(maxErr <= 1e-4);
    CHECK(lastKe < 1e-3 * peak);  // settles
}

TEST_CASE("load modes: goo held at one end falls at the modal rate until the strain bound", "[dynamics][load]") {
    Cantilever c;
    DeformableBody body(c.lat, restPositions(c.lat), jelly(0, 4), c.pinned);
    const ForceField g = gravityField();
    const Real dt = 1.0 / 48, zeta = 4;
    const LoadModes& m = body.loadModes();
    Vec3 f = Vec3::Zero();
    for (Index p = 0; p < c.lat.size(); ++p)
        for (int i = 0; i < 3; ++i) f[i] += body.masses()[at(p)] * m.w[at(i)][at(p)].dot(Vec3(0, -9.81, 0));
    const Real a = Vec3(m.mass.ldlt().solve(f)).y();
    // the semi-implicit recurrence q̇ ← (q̇ + δt a) / (1 + ζ δt): q̇_n = (a/ζ)(1 − (1 + ζ δt)^−n)
    Real q = 0;
    int n = 0;
    for (; n < 2000; ++n) {
        REQUIRE(body.step(g, 1, dt, {}).fault.empty());
        const Real rateN = (a / zeta) * (1 - std::pow(1 + zeta * dt, -(n + 1)));
        const Real qNext = q + dt * rateN;
        if (std::abs(qNext) * m.strain[1] > body.settings().maxLoadStrain) break;  // the bound from here
        q = qNext;
        REQUIRE(std::abs(body.loadRate().y() - rateN) <= 1e-12 * std::abs(a / zeta));
        REQUIRE(std::abs(body.loadAmplitude().y() - q) <= 1e-12 * std::abs(a / zeta));
    }
    for (int s = 0; s < 96; ++s) REQUIRE(body.step(g, 1, dt, {}).fault.empty());
    const Real strain = body.loadAmplitude().cwiseAbs().dot(m.strain);
    if (verbose())
        std::printf("goo cantilever: terminal rate %.4f m/s, %d steps to the strain bound, strain there %.6f\n",
                    a / zeta, n, strain);
    CHECK(n >= 5);  // 0.3 / 2.44 per metre = 0.12 m at up to 3.1 m/s
    CHECK(n < 2000);
    CHECK(std::abs(strain - body.settings().maxLoadStrain) <= 1e-9);
    CHECK(body.loadRate().norm() <= 1e-12);
}

TEST_CASE("load modes: off, or with nothing pinned, a body moves as before", "[dynamics][load]") {
    Cantilever c;
    DynamicsSettings off = jelly(200, 4);
    off.pinnedLoad = false;
    DeformableBody still(c.lat, restPositions(c.lat), off, c.pinned);
    CHECK(still.loadModes().empty());
    const ForceField g = gravityField();
    for (int s = 0; s < 24; ++s) REQUIRE(still.step(g, 1, 1.0 / 48, {}).fault.empty());
    // the notes' step alone: a uniform field does not move a pinned body (the shape memory's
    // response to the round-off of the rest connection aside)
    const std::vector<Vec3> rest = restPositions(c.lat);
    Real moved = 0;
    for (Index p = 0; p < c.lat.size(); ++p) moved = std::max(moved, (still.positions()[at(p)] - rest[at(p)]).norm());
    CHECK(moved < 1e-12);
    DeformableBody free(c.lat, restPositions(c.lat), jelly(200, 4));
    CHECK(free.loadModes().empty());
    DeformableBody held(c.lat, restPositions(c.lat), jelly(200, 4), std::vector<unsigned char>(at(c.lat.size()), 1));
    CHECK(held.loadModes().empty());  // nothing free to move
    for (int s = 0; s < 4; ++s) REQUIRE(held.step(g, 1, 1.0 / 48, {}).fault.empty());
    CHECK(held.positions() == restPositions(c.lat));
}

TEST_CASE("load modes: a checkpoint restores the modes' amplitudes and the run continues bit-identically",
          "[dynamics][load]") {
    Cantilever c;
    const ForceField g = gravityField();
    const Real dt = 1.0 / 48;
    DeformableBody a(c.lat, restPositions(c.lat), jelly(200, 2), c.pinned);
    for (int s = 0; s < 20; ++s) REQUIRE(a.step(g, 1, dt, {}).fault.empty());
    const DeformableBodyState saved = a.saveState();
    CHECK(saved.loadAmplitude.y() < 0);
    CHECK(saved.loadRate.norm() > 0);
    for (int s = 0; s < 20; ++s) REQUIRE(a.step(g, 1, dt, {}).fault.empty());
    DeformableBody b(c.lat, restPositions(c.lat), jelly(200, 2), c.pinned);
    REQUIRE(b.stateFits(saved));
    b.restoreState(saved);
    for (int s = 0; s < 20; ++s) REQUIRE(b.step(g, 1, dt, {}).fault.empty());
    CHECK(b.positions() == a.positions());
    CHECK(b.loadAmplitude() == a.loadAmplitude());
}
