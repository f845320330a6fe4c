// Tests of body motion and the force moments (src/dynamics/body.hpp, seed eqs 66-68): cell-share
// masses, the centre of mass under affine maps, free fall (exact with velocity Verlet), the
// harmonic oscillator (second order in dt), and the first moment of a linear field
// (= gradient × second moment), with the least-squares property for a nonlinear one.
#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "dynamics/body.hpp"
#include "dynamics/lattices.hpp"
#include "geom/lattice.hpp"

#include <Eigen/LU>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

using namespace dgv;

namespace {

bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

using test::sphereLattice;

Lattice boxLattice(const Vec3i& dims, Real h) { return test::boxLattice(dims, h, Vec3(0.5, -1, 2)); }

ForceField single(const ForceTerm& t) {
    ForceField f;
    f.add(t);
    return f;
}

ForceTerm linearTerm(const Mat3& G, const Vec3& centre, Real s = 1) {
    ForceTerm t;
    t.kind = ForceKind::Linear;
    t.matrix = G;
    t.centre = centre;
    t.strength = Keyframes::constant(s);
    return t;
}

std::vector<Vec3> affineImage(const Lattice& lat, const Mat3& A, const Vec3& b) {
    std::vector<Vec3> x = restPositions(lat);
    for (Vec3& p : x) p = A * p + b;
    return x;
}

}  // namespace

TEST_CASE("body: cell-share masses add up to density times the cells' volume", "[dynamics][body]") {
    const Real h = 0.1, rho = 1000;
    const Lattice box = boxLattice(Vec3i(5, 4, 3), h);
    const std::vector<Real> m = pointMasses(box, rho);
    const Real cell = rho * h * h * h;
    Real total = 0;
    for (Real v : m) total += v;
    CHECK(total == Approx(cell * 4 * 3 * 2).epsilon(1e-14));
    CHECK(m[static_cast<std::size_t>(box.pointAt(Vec3i(0, 0, 0)))] == Approx(cell / 8).epsilon(1e-15));  // corner
    CHECK(m[static_cast<std::size_t>(box.pointAt(Vec3i(2, 0, 0)))] == Approx(cell / 4).epsilon(1e-15));  // edge
    CHECK(m[static_cast<std::size_t>(box.pointAt(Vec3i(2, 1, 0)))] == Approx(cell / 2).epsilon(1e-15));  // face
    CHECK(m[static_cast<std::size_t>(box.pointAt(Vec3i(2, 1, 1)))] == Approx(cell).epsilon(1e-15));      // inside
    // Voxel rule: one voxel each.
    for (Real v : pointMasses(box, rho, MassRule::Voxel)) CHECK(v == cell);

    // A sphere: total = ρ h³ × (number of complete cells), counted independently here.
    const Lattice s = sphereLattice(5, h, Vec3::Zero());
    int cells = 0;
    for (int k = 0; k + 1 < s.dims.z(); ++k)
        for (int j = 0; j + 1 < s.dims.y(); ++j)
            for (int i = 0; i + 1 < s.dims.x(); ++i) {
                bool all = true;
                for (int c = 0; c < 8; ++c)
                    all = all && s.pointAt(Vec3i(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))) != kNoPoint;
                cells += all ? 1 : 0;
            }
    Real sum = 0;
    for (Real v : pointMasses(s, rho)) sum += v;
    CHECK(cells > 300);
    CHECK(sum == Approx(cell * cells).epsilon(1e-13));

    CHECK_THROWS_AS(pointMasses(box, 0), InputError);
}

TEST_CASE("body: the centre of mass follows affine maps", "[dynamics][body]") {
    const Lattice box = boxLattice(Vec3i(6, 5, 4), 0.2);
    const std::vector<Real> m = pointMasses(box, 1);
    // symmetric box: the geometric centre
    const Vec3 c = centreOfMass(m, restPositions(box));
    CHECK((c - (box.originWorld + 0.2 * Vec3(2.5, 2, 1.5))).norm() < 1e-14);
    // an irregular body, mapped affinely: the centre maps with it
    const Lattice s = sphereLattice(6, 0.1, Vec3(1, 2, 3));
    const std::vector<Real> ms = pointMasses(s, 2);
    Mat3 A;
    A << 1.2, 0.3, -0.1, 0.0, 0.9, 0.4, 0.2, -0.3, 1.1;
    const Vec3 b(0.5, -2, 7);
    const Vec3 c0 = centreOfMass(ms, restPositions(s));
    const Vec3 c1 = centreOfMass(ms, affineImage(s, A, b));
    CHECK((c1 - (A * c0 + b)).norm() < 1e-13 * (1 + c1.norm()));
}

TEST_CASE("body: free fall under uniform gravity is exact", "[dynamics][body]") {
    const Lattice s = sphereLattice(4, 0.05, Vec3(0, 3, 0));
    const std::vector<Real> m = pointMasses(s, 1000);
    ForceTerm g;
    g.kind = ForceKind::Gravity;
    g.direction = Vec3(0, -1, 0);
    g.strength = Keyframes::constant(9.81);
    const ForceField field = single(g);
    std::vector<Vec3> x = restPositions(s);
    const Real fps = 24, dt = 1 / fps / 4;
    BodyState body;
    body.centre = centreOfMass(m, x);
    body.velocity = Vec3(1.5, 4, -0.5);
    body.acceleration = forceMoments(field, m, x, 1).meanForce;
    const Vec3 c0 = body.centre, v0 = body.velocity, a(0, -9.81, 0);
    CHECK((body.acceleration - a).norm() < 1e-14);
    const int steps = 240;
    for (int n = 1; n <= steps; ++n) {
        const Real frame = 1 + n * dt * fps;
        const Vec3 shift = stepBody(body, dt, [&](const Vec3& d) {
            std::vector<Vec3> moved = x;
            for (Vec3& p : moved) p += d;
            return forceMoments(field, m, moved, frame, false).meanForce;
        });
        for (Vec3& p : x) p += shift;
    }
    const Real t = steps * dt;
    const Vec3 exact = c0 + v0 * t + 0.5 * a * t * t;
    if (verbose())
        std::printf("free fall: |x - exact| = %.3e, |v - exact| = %.3e\n", (body.centre - exact).norm(),
                    (body.velocity - (v0 + a * t)).norm());
    CHECK((body.centre - exact).norm() < 1e-12 * exact.norm());
    CHECK((body.velocity - (v0 + a * t)).norm() < 1e-12 * (v0 + a * t).norm());
    // the lattice moved with it
    CHECK((centreOfMass(m, x) - body.centre).norm() < 1e-12 * exact.norm());
}

TEST_CASE("body: harmonic motion converges at second order in dt", "[dynamics][body]") {
    // F = −ω² (x − c): the centre of mass is a harmonic oscillator,
    // x(t) = c + (x0 − c) cos ωt + (v0/ω) sin ωt. Velocity Verlet's error is O(dt²).
    const Lattice s = sphereLattice(3, 0.1, Vec3(1, 0.5, -0.5));
    const std::vector<Real> m = pointMasses(s, 1);
    const Real omega = 2.0;
    const Vec3 centre(0, 0, 0);
    const ForceField field = single(linearTerm(-omega * omega * Mat3::Identity(), centre));
    const std::vector<Vec3> x0 = restPositions(s);
    const Vec3 v0(0.3, -0.2, 0.8);
    const Real T = 2.0;
    auto errorAt = [&](int steps) {
        const Real dt = T / steps;
        std::vector<Vec3> x = x0;
        BodyState body;
        body.centre = centreOfMass(m, x);
        body.velocity = v0;
        body.acceleration = forceMoments(field, m, x, 0, false).meanForce;
        const Vec3 c0 = body.centre;
        for (int n = 0; n < steps; ++n) {
            const Vec3 shift = stepBody(body, dt, [&](const Vec3& d) {
                std::vector<Vec3> moved = x;
                for (Vec3& p : moved) p += d;
                return forceMoments(field, m, moved, 0, false).meanForce;
            });
            for (Vec3& p : x) p += shift;
        }
        const Vec3 exact = centre + (c0 - centre) * std::cos(omega * T) + v0 / omega * std::sin(omega * T);
        return (body.centre - exact).norm();
    };
    const Real e1 = errorAt(50), e2 = errorAt(100), e3 = errorAt(200);
    if (verbose()) std::printf("harmonic: errors %.3e %.3e %.3e, ratios %.3f %.3f\n", e1, e2, e3, e1 / e2, e2 / e3);
    CHECK(e1 / e2 == Approx(4).epsilon(0.05));
    CHECK(e2 / e3 == Approx(4).epsilon(0.05));
    CHECK(e1 < 0.01);
}

TEST_CASE("body: first moment of a linear field is its gradient times the second moment", "[dynamics][body]") {
    const Lattice s = sphereLattice(6, 0.1, Vec3(1, 2, 3));
    const std::vector<Real> m = pointMasses(s, 3);
    Mat3 A;
    A << 1.5, 0.2, 0.0, -0.3, 0.8, 0.1, 0.4, 0.0, 0.9;  // a sheared, stretched body
    const std::vector<Vec3> x = affineImage(s, A, Vec3(-1, 0.5, 2));
    Mat3 G;
    G << 0.5, -2, 1, 3, 0.1, -0.7, 0.2, 1.4, -1;  // not symmetric: has a curl
    const Vec3 c(0.3, 0.1, -0.2);
    const Real strength = 1.7;
    const ForceMoments fm = forceMoments(single(linearTerm(G, c, strength)), m, x, 0);
    const Mat3 Gs = strength * G;
    // Round-off: the moments are centred exactly (body.cpp), so what is left is the summation
    // error of Σ m F ỹᵀ, ~ε |F| |ỹ| per term: 1e-14 relative to the moment's scale.
    const Real roundoff = 1e-14 * fm.meanForce.norm() * std::sqrt(fm.secondMoment.trace());
    if (verbose())
        std::printf("linear field: |first - G S| = %.3e, round-off bound %.3e, |first| = %.3e\n",
                    (fm.firstMoment - Gs * fm.secondMoment).norm(), roundoff, fm.firstMoment.norm());
    CHECK((fm.firstMoment - Gs * fm.secondMoment).norm() < roundoff);
    CHECK((fm.momentGradient() - Gs).norm() < roundoff * fm.secondMoment.inverse().norm());
    CHECK((fm.meanGradient - Gs).norm() < 1e-14 * Gs.norm());  // eq 68 agrees for a linear field
    CHECK((fm.meanForce - Gs * (fm.centre - c)).norm() < 1e-13 * fm.meanForce.norm());
    // the second moment of the affine image is A S₀ Aᵀ
    const ForceMoments rest = forceMoments(single(linearTerm(G, c)), m, restPositions(s), 0);
    CHECK((fm.secondMoment - A * rest.secondMoment * A.transpose()).norm() < 1e-13 * fm.secondMoment.norm());
}

TEST_CASE("body: for a nonlinear field the moment gradient is the least-squares affine fit", "[dynamics][body]") {
    // Normal equations of min Σ m |F − a − G ỹ|²: Σ m (F − a − G ỹ) ỹᵀ = 0 with a the mean
    // force. The averaged gradient of eq 68 does not satisfy them for a vortex.
    const Lattice s = sphereLattice(6, 0.1, Vec3(0.2, 0, 0));
    const std::vector<Real> m = pointMasses(s, 1);
    const std::vector<Vec3> x = restPositions(s);
    ForceTerm v;
    v.kind = ForceKind::Vortex;
    v.centre = Vec3::Zero();
    v.axis = Vec3::UnitY();
    v.radius = 0.3;
    v.falloff = 1;
    v.strength = Keyframes::constant(2);
    const ForceField field = single(v);
    const ForceMoments fm = forceMoments(field, m, x, 0);
    auto normalResidual = [&](const Mat3& G) {
        Mat3 r = Mat3::Zero();
        for (std::size_t p = 0; p < x.size(); ++p) {
            const Vec3 y = x[p] - fm.centre;
            r += m[p] * (field.value(x[p], 0) - fm.meanForce - G * y) * y.transpose();
        }
        return r.norm() / fm.mass;
    };
    const Real scale = fm.firstMoment.norm();
    const Real withMoment = normalResidual(fm.momentGradient());
    const Real withMean = normalResidual(fm.meanGradient);
    if (verbose())
        std::printf("vortex: normal-equation residual %.3e (moment) vs %.3e (eq 68 mean), scale %.3e\n", withMoment,
                    withMean, scale);
    CHECK(withMoment < 1e-13 * scale);
    CHECK(withMean > 1e-3 * scale);
}

TEST_CASE("body: moments are bit-identical for any thread count", "[dynamics][body][determinism]") {
    const Lattice s = sphereLattice(16, 0.02, Vec3::Zero());  // ~17k points: several blocks
    const std::vector<Real> m = pointMasses(s, 1);
    ForceTerm t;
    t.kind = ForceKind::Wind;
    t.direction = Vec3::UnitX();
    t.turbulence = 1;
    t.scale = 0.1;
    const ForceField field = single(t);
    const std::vector<Vec3> x = restPositions(s);
    ForceMoments a, b;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        a = forceMoments(field, m, x, 0);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        b = forceMoments(field, m, x, 0);
    }
    REQUIRE(s.size() > 4 * 2048);
    CHECK(std::memcmp(&a, &b, sizeof(ForceMoments)) == 0);
}
