// The one-solve step (StepSolver::One; dynamics/cell_solve.hpp): references written here, not
// today's output: exact free fall, momentum and spin kept, the wobble at √k/2π, volumes and
// corners through a landing, rest above the ground, a pinned jelly that swings and settles, putty
// that splats and stays, goo at any viscosity.

#include "dynamics/body.hpp"
#include "dynamics/cell_solve.hpp"
#include "dynamics/lattices.hpp"
#include "dynamics/stepper.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace dgv;

namespace {

DynamicsSettings oneSolve(Real k, Real damping = 0, Real viscosity = 0) {
    DynamicsSettings s;
    s.solver = StepSolver::One;
    s.shapeStiffness = k;
    s.damping = damping;
    s.viscosity = viscosity;
    return s;
}

Real minCorner(const DeformableBody& b) {
    Real j = 1;
    for (Index c = 0; c < b.cells().size(); ++c) {
        std::array<Vec3, 8> x;
        for (std::size_t k = 0; k < 8; ++k) x[k] = b.positions()[at(b.cells().corners[at(c)][k])];
        j = std::min(j, CellSolver::minCornerJacobian(x, b.lattice().spacing));
    }
    return j;
}

Vec3 momentumOf(const DeformableBody& b) {
    Vec3 m = Vec3::Zero();
    for (Index p = 0; p < b.lattice().size(); ++p) m += b.masses()[at(p)] * b.velocities()[at(p)];
    return m;
}

Vec3 angularMomentumOf(const DeformableBody& b) {
    const Vec3 c = centreOfMass(b.masses(), b.positions());
    Vec3 l = Vec3::Zero();
    for (Index p = 0; p < b.lattice().size(); ++p)
        l += b.masses()[at(p)] * (b.positions()[at(p)] - c).cross(b.velocities()[at(p)]);
    return l;
}

Real lowestY(const DeformableBody& b) {
    Real y = 1e30;
    for (const Vec3& x : b.positions()) y = std::min(y, x.y());
    return y;
}

ForceField noForces() { return ForceField(); }

}  // namespace

TEST_CASE("one solve: corner Jacobians are 1 at rest and see a fold inside a cell", "[one_solve]") {
    const Real h = 0.1;
    std::array<Vec3, 8> x;
    for (int k = 0; k < 8; ++k) x[static_cast<std::size_t>(k)] = h * Vec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    CHECK(CellSolver::minCornerJacobian(x, h) == Approx(1).epsilon(1e-12));
    CHECK(CellSolver::centreFrame(x, h).isApprox(Mat3::Identity(), 1e-12));
    // Corner 7 pushed through the cell's far corner: the cell's volume stays positive, the
    // corner's own Jacobian does not.
    x[7] = h * Vec3(0.2, 0.2, 0.2);
    std::array<Vec3, 8> g;
    CHECK(hexVolumeGradient(x, g) > 0);
    CHECK(CellSolver::minCornerJacobian(x, h) < 0);
}

TEST_CASE("one solve: free fall is exact and the body does not deform", "[one_solve]") {
    const Real h = 0.05, dt = 1.0 / 96;
    const Lattice lat = test::sphereLattice(4, h, Vec3(0, 2, 0));
    DeformableBody body(lat, restPositions(lat), oneSolve(300));
    const std::vector<Vec3> x0 = body.positions();
    const ForceField g = test::gravityField();
    const int steps = 48;
    for (int s = 0; s < steps; ++s) {
        const StepReport r = body.step(g, 1, dt, {});
        REQUIRE(r.fault.empty());
    }
    // The reference: backward Euler's first step (no step before it), then BDF2's recurrences
    // x' = (4 x − x⁻)/3 + (2/3) δt v', v' = (4 v − v⁻)/3 − (2/3) δt g, exact for the velocity.
    Real y = 0, yPrev = 0, v = 0, vPrev = 0;
    for (int s = 0; s < steps; ++s) {
        const Real vNew = s == 0 ? v - 9.81 * dt : (4 * v - vPrev) / 3 - (2.0 / 3) * dt * 9.81;
        const Real yNew = s == 0 ? y + dt * vNew : (4 * y - yPrev) / 3 + (2.0 / 3) * dt * vNew;
        yPrev = y;
        vPrev = v;
        y = yNew;
        v = vNew;
    }
    CHECK(v == Approx(-9.81 * dt * steps).epsilon(1e-12));
    for (Index p = 0; p < lat.size(); ++p) {
        CHECK(body.velocities()[at(p)].y() == Approx(v).epsilon(1e-9));
        CHECK((body.positions()[at(p)] - (x0[at(p)] + y * Vec3::UnitY())).norm() < 1e-9);
    }
}

TEST_CASE("one solve: a spinning jelly keeps its momentum and spin, and every cell its volume", "[one_solve]") {
    const Real h = 0.05, dt = 1.0 / 96;
    const Lattice lat = test::sphereLattice(4, h, Vec3::Zero(), Vec3(0.2, 0.1, 0.3));
    DeformableBody body(lat, restPositions(lat), oneSolve(300, 0, 0.01));
    body.setRigidVelocity(Vec3(0.3, 0, 0), Vec3(0, 4, 1));
    const Vec3 p0 = body.totalMass() * Vec3(0.3, 0, 0);
    Vec3 l0 = Vec3::Zero();
    for (int s = 0; s < 96; ++s) {
        const StepReport r = body.step(noForces(), 1, dt, {});
        REQUIRE(r.fault.empty());
        CHECK(r.maxCellVolumeError <= 1e-5);
        if (s == 0) l0 = angularMomentumOf(body);
    }
    CHECK((momentumOf(body) - p0).norm() <= 1e-9 * p0.norm());
    // One second of spin at 4 rad/s: the spin is kept to within 1 % (backward Euler's own
    // damping of the centrifugal stretch is the only loss).
    CHECK((angularMomentumOf(body) - l0).norm() <= 0.01 * l0.norm());
    CHECK(minCorner(body) > 0.5);
}

TEST_CASE("one solve: a squashed jelly wobbles at sqrt(k)/2pi", "[one_solve][slow]") {
    // A ball given a volume-keeping squash rate and left alone: its flex's xx strain oscillates
    // at the wobble frequency √k/2π (the stiffness's definition, scenes/README.md).
    const Real h = 0.05, dt = 1.0 / 240, k = 400;  // 3.18 Hz
    const Lattice lat = test::sphereLattice(6, h, Vec3::Zero());
    DeformableBody body(lat, restPositions(lat), oneSolve(k));
    const Real eps = 0.6;
    body.setAffineVelocity(Vec3::Zero(), Vec3(eps, -eps / 2, -eps / 2).asDiagonal());
    std::vector<Real> crossings;
    Real prev = 0;
    for (int s = 0; s < 240; ++s) {
        const StepReport r = body.step(noForces(), 1, dt, {});
        REQUIRE(r.fault.empty());
        const Real strain = body.flex()(0, 0) - 1;
        if (s > 0 && prev > 0 && strain <= 0) crossings.push_back((s + prev / (prev - strain)) * dt);
        prev = strain;
    }
    REQUIRE(crossings.size() >= 2);
    const Real period = (crossings.back() - crossings.front()) / static_cast<Real>(crossings.size() - 1);
    CHECK(1 / period == Approx(std::sqrt(k) / (2 * M_PI)).epsilon(0.05));
}

TEST_CASE("one solve: a jelly dropped at 3 m/s squashes, rebounds and rests on the ground", "[one_solve][slow]") {
    const Real h = 0.05, dt = 1.0 / 96;
    const int r = 5;
    const Lattice lat = test::sphereLattice(r, h, Vec3(0, 0.1, 0) - Vec3(r * h, 0, r * h));
    // k of the default sag (0.1 of the half height r: k = 5 g / (0.1 r)), 3 wobbles to a tenth
    const Real k = 5 * 9.81 / (0.1 * r * h), zeta = 2 * (std::sqrt(k) / (2 * M_PI)) * std::log(10.0) / 3;
    DeformableBody body(lat, restPositions(lat), oneSolve(k, zeta));
    body.setRigidVelocity(Vec3(0, -3, 0), Vec3::Zero());
    Collider ground = test::groundPlane();
    ground.friction = 0.5;
    const ForceField g = test::gravityField();
    const Real height0 = 2 * r * h;
    Real minHeight = 1e30, worstJ = 1, worstVolume = 0, ke = 0;
    bool rebounded = false;
    for (int s = 0; s < 192; ++s) {
        const StepReport rep = body.step(g, 1, dt, {ground});
        REQUIRE(rep.fault.empty());
        worstVolume = std::max(worstVolume, rep.maxCellVolumeError);
        worstJ = std::min(worstJ, minCorner(body));
        Real top = -1e30;
        for (const Vec3& x : body.positions()) top = std::max(top, x.y());
        minHeight = std::min(minHeight, top - lowestY(body));
        if (s > 2 && body.centreVelocity().y() > 0.3) rebounded = true;
        // held half a voxel out, where its surface is, to 0.5 % of its size (issue's bound)
        CHECK(lowestY(body) > 0.5 * h - 0.005 * 2 * r * h);
        ke = rep.kineticEnergy;
        if (std::getenv("DGV_TEST_VERBOSE") && s % 4 == 0)
            std::printf("step %d centre %.4f %.4f vy %.3f ke %.4f lowest %.4f iters %d\n", s, body.centre().x(),
                        body.centre().y(), body.centreVelocity().y(), ke, lowestY(body), rep.reconstructIterations);
    }
    CHECK(minHeight < 0.9 * height0);  // it squashed
    CHECK(rebounded);                  // and threw itself back up
    CHECK(worstJ > 0);
    CHECK(worstVolume <= 1e-5);
    // At rest after 2 s: its weight on the ground, kinetic energy below a millijoule per kg.
    CHECK(ke < 1e-3 * body.totalMass());
    CHECK(lowestY(body) == Approx(0.5 * h).margin(0.02 * h));
}

TEST_CASE("one solve: a jelly hanging from a small pin swings and settles", "[one_solve][slow]") {
    const Real h = 0.05, dt = 1.0 / 96;
    const int r = 4;
    const Lattice lat = test::sphereLattice(r, h, Vec3::Zero());
    std::vector<unsigned char> pinned(at(lat.size()), 0);
    const Vec3 centre = Vec3::Constant(r * h);
    Index count = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        const Vec3 d = lat.restPosition(p) - centre;
        // a cap of the top: the points within a voxel of the top, within 1.5 voxels of the axis
        if (d.y() >= (r - 1) * h - 1e-9 && std::hypot(d.x(), d.z()) <= 1.5 * h) {
            pinned[at(p)] = 1;
            ++count;
        }
    }
    REQUIRE(count >= 4);
    DeformableBody body(lat, restPositions(lat), oneSolve(300, 2), pinned);
    body.setRigidVelocity(Vec3(1, 0, 0), Vec3::Zero());
    const ForceField g = test::gravityField();
    Real swing = 0, ke = 0;
    for (int s = 0; s < 288; ++s) {
        const StepReport rep = body.step(g, 1, dt, {});
        REQUIRE(rep.fault.empty());
        CHECK(rep.maxCellVolumeError <= 1e-5);
        swing = std::max(swing, std::abs(body.centre().x() - centre.x()));
        ke = rep.kineticEnergy;
    }
    CHECK(swing > 0.5 * h);  // it swung
    CHECK(minCorner(body) > 0);
    CHECK(ke < 1e-3 * body.totalMass());  // and settled, hanging below its pin
    CHECK(body.centre().y() < centre.y());
    CHECK(std::abs(body.centre().x() - centre.x()) < 0.1 * h);
}

TEST_CASE("one solve: putty at 10 m/s splats on the ground and stays splatted", "[one_solve][slow]") {
    const Real h = 0.05, dt = 1.0 / 192;
    const int r = 4;
    const Lattice lat = test::sphereLattice(r, h, Vec3(0, 0.05, 0) - Vec3(r * h, 0, r * h));
    DynamicsSettings set = oneSolve(300, 4);
    set.yieldStrain = 0.1;
    DeformableBody body(lat, restPositions(lat), set);
    body.setRigidVelocity(Vec3(0, -10, 0), Vec3::Zero());
    Collider ground = test::groundPlane();
    ground.friction = 0.5;
    const ForceField g = test::gravityField();
    for (int s = 0; s < 192; ++s) {
        const StepReport rep = body.step(g, 1, dt, {ground});
        REQUIRE(rep.fault.empty());
        CHECK(rep.maxCellVolumeError <= 1e-5);
    }
    Real top = -1e30, wide = 0;
    for (const Vec3& x : body.positions()) {
        top = std::max(top, x.y());
        wide = std::max(wide, std::hypot(x.x(), x.z()));
    }
    CHECK(top - lowestY(body) < 0.7 * 2 * r * h);  // flattened and stays so after a second
    CHECK(wide > 1.2 * r * h);
    CHECK(minCorner(body) > 0);
}

TEST_CASE("one solve: goo is stable from water to tar at the default substeps", "[one_solve][slow]") {
    const Real h = 0.05, dt = 1.0 / 96;
    const int r = 4;
    const Lattice lat = test::sphereLattice(r, h, Vec3(0, 0.05, 0) - Vec3(r * h, 0, r * h));
    const ForceField g = test::gravityField();
    Collider ground = test::groundPlane();
    ground.friction = 0.5;
    for (const Real nu : {1e-6, 1e-2, 1.0, 10.0}) {
        DeformableBody body(lat, restPositions(lat), oneSolve(0, 0, nu));
        body.setRigidVelocity(Vec3(0, -2, 0), Vec3::Zero());
        for (int s = 0; s < 96; ++s) {
            const StepReport rep = body.step(g, 1, dt, {ground});
            INFO("nu " << nu << " step " << s);
            REQUIRE(rep.fault.empty());
            CHECK(rep.maxCellVolumeError <= 1e-5);
        }
        CHECK(minCorner(body) > 0);
        CHECK(lowestY(body) > 0.5 * h - 0.005 * 2 * r * h);
    }
}
