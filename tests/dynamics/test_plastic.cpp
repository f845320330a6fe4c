// Plasticity (DynamicsSettings::yieldStrain; docs/math.md, "Plasticity: the rest shape yields"):
// the rest shape of a body with shape memory follows it where its elastic strain passes the
// yield, so a stretch beyond the yield leaves a permanent set of exactly the excess (radial
// return along fixed axes), one within it springs back, the twist's rest connection yields
// likewise, and a plastic ball dropped on the ground stops spreading where goo spreads on.
#include <catch2/catch.hpp>

#include "dynamics/lattices.hpp"
#include "dynamics/stepper.hpp"
#include "geom/lattice.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

using namespace dgv;

namespace {

bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

/// |log U| of A = R U: the length of A's logarithmic strain.
Real logStrain(const Mat3& A) {
    Eigen::SelfAdjointEigenSolver<Mat3> es;
    es.computeDirect(A.transpose() * A);
    return (Real(0.5) * es.eigenvalues().array().log()).matrix().norm();
}

/// Γ − Γ_p and Γ at one point, Frobenius norms over the 27 components.
Real norm27(const std::array<std::vector<Mat3>, 3>& g, std::size_t p) {
    Real s = 0;
    for (const auto& c : g) s += c[p].squaredNorm();
    return std::sqrt(s);
}

struct Stretch {
    Real peak = 0;       ///< largest |log U(A)| over the steps
    Real final = 0;      ///< |log U(A)| at the end
    Real finalRest = 0;  ///< |log U(P)| at the end
    Real finalElastic = 0;
    bool yielded = false;
};

/// A ball of 4 voxels (0.2 m) with shape memory k = 100/s² and damping 4/s, no forces, given a
/// trace-free stretch rate diag(2s, −s, −s) along fixed axes, run 4 s.
Stretch stretchAndRelease(Real rate, Real yield) {
    const Lattice lat = test::sphereLattice(4, 0.05, Vec3::Zero());
    DynamicsSettings set;
    set.shapeStiffness = 100;
    set.damping = 4;
    set.yieldStrain = yield;
    DeformableBody body(lat, restPositions(lat), set);
    body.setAffineVelocity(Vec3::Zero(), Vec3(2 * rate, -rate, -rate).asDiagonal());
    Stretch out;
    const ForceField none;
    for (int s = 0; s < 4 * 96; ++s) {
        const StepReport r = body.step(none, 1, 1.0 / 96, {});
        REQUIRE(r.fault.empty());
        out.peak = std::max(out.peak, logStrain(body.flex()));
    }
    out.final = logStrain(body.flex());
    out.finalRest = logStrain(body.plasticFlex());
    out.finalElastic = logStrain(body.flex() * body.plasticFlex().inverse());
    out.yielded = !body.plasticFlex().isApprox(Mat3::Identity(), 1e-12);
    return out;
}

}  // namespace

TEST_CASE(
    "plasticity: a stretch beyond the yield leaves the excess as a permanent set, within it the body springs back",
    "[dynamics][plastic][slow]") {
    const Real yield = 0.1;
    // Beyond: the elastic strain is capped at the yield while the stretch grows, so at the peak
    // the rest shape holds peak − yield; released, the memory and damping take the elastic part
    // back to 0 (it overshoots the other way by less than the yield: no reverse yielding).
    const Stretch big = stretchAndRelease(1.5, yield);
    if (verbose())
        std::printf("stretch: peak %.5f, final %.5f (rest %.5f, elastic %.2e), peak - yield %.5f\n", big.peak,
                    big.final, big.finalRest, big.finalElastic, big.peak - yield);
    REQUIRE(big.peak > 2 * yield);
    CHECK(big.yielded);
    CHECK(big.finalElastic < 1e-3);
    CHECK(std::abs(big.finalRest - (big.peak - yield)) < 2e-3);
    CHECK(std::abs(big.final - (big.peak - yield)) < 3e-3);

    // Within: the rest shape is untouched and the body returns to it.
    const Stretch small = stretchAndRelease(0.2, yield);
    if (verbose()) std::printf("small stretch: peak %.5f, final %.2e\n", small.peak, small.final);
    REQUIRE(small.peak < yield);
    REQUIRE(small.peak > yield / 4);
    CHECK(!small.yielded);
    CHECK(small.final < 1e-3);

    // Without plasticity the big stretch springs back as well.
    const Stretch elastic = stretchAndRelease(1.5, 0);
    CHECK(elastic.final < 1e-3);
}

TEST_CASE("plasticity: the twist's rest connection yields, a bent-in shape stays", "[dynamics][plastic]") {
    // A box bar 12 x 4 x 4 voxels with k = 100, given a non-affine push: a δΓ that bends it
    // (Γ^1_00 = β x_1-ward curvature at every point). Elastic: Γ returns to ~0. Plastic: a
    // permanent Γ stays, and at rest no point holds more than the yield elastically.
    const Lattice lat = test::boxLattice(Vec3i(12, 4, 4), 0.05, Vec3::Zero());
    auto run = [&](Real yield, Real& gammaAfter, Real& elasticAfter, Real& tau) {
        DynamicsSettings set;
        set.shapeStiffness = 100;
        set.damping = 4;
        set.yieldStrain = yield;
        DeformableBody body(lat, restPositions(lat), set);
        for (Index p = 0; p < lat.size(); ++p) body.deltaGamma()[1][static_cast<std::size_t>(p)](0, 0) = 0.01;
        const ForceField none;
        for (int s = 0; s < 4 * 96; ++s) {
            const StepReport r = body.step(none, 1, 1.0 / 96, {});
            REQUIRE(r.fault.empty());
        }
        gammaAfter = 0;
        elasticAfter = 0;
        std::array<std::vector<Mat3>, 3> elastic = body.state().christoffel;
        for (std::size_t p = 0; p < static_cast<std::size_t>(lat.size()); ++p) {
            gammaAfter = std::max(gammaAfter, norm27(body.state().christoffel, p));
            if (yield > 0)
                for (std::size_t c = 0; c < 3; ++c) elastic[c][p] -= body.plasticGamma()[c][p];
            elasticAfter = std::max(elasticAfter, norm27(elastic, p));
        }
        tau = body.gammaYield();
    };
    Real gElastic, eElastic, tauNone;
    run(0, gElastic, eElastic, tauNone);
    Real gPlastic, ePlastic, tau;
    run(0.02, gPlastic, ePlastic, tau);
    if (verbose())
        std::printf("bent bar: elastic max|Γ| %.2e; plastic max|Γ| %.2e, max|Γ - Γp| %.2e (yield of Γ %.2e)\n",
                    gElastic, gPlastic, ePlastic, tau);
    CHECK(gElastic < 0.2 * gPlastic);  // it springs back
    CHECK(gPlastic > 2 * tau);         // a bend beyond the yield stayed
    CHECK(ePlastic <= tau * (1 + 1e-9));
}

TEST_CASE("plasticity: a putty ball dropped on the ground keeps a squash and settles, goo spreads on",
          "[dynamics][plastic][contact][slow]") {
    // The ball of "contact: a goo ball resting on the ground ..." (0.5 m, 20 voxels across,
    // 1.5 m/s onto the ground, 2 substeps at 24 fps, 5 s), as goo, as jelly (k = 300: its
    // resting sag needs an elastic strain of about 0.27) and as putty (k = 300, yield 0.25). The
    // putty yields until its flattened rest shape carries the weight within the yield (the
    // memory's force k (A P⁻¹ − R) P⁻ᵀ grows as P flattens), then rests with the squash kept.
    const int r = 10;
    const Real h = 0.05;
    const Lattice lat = test::sphereLattice(r, h, Vec3(0, 0.56, 0) - Vec3::Constant(r * h));
    const Real k = 300, yield = 0.25;
    struct Run {
        Real squash = 0, restSquash = 1, energyAt1s = 0, energyEnd = 0, lowest = 1, mostElastic = 0;
    };
    auto run = [&](Real stiffness, Real yieldStrain) {
        DynamicsSettings set;
        set.shapeStiffness = stiffness;
        set.yieldStrain = yieldStrain;
        DeformableBody body(lat, restPositions(lat), set);
        body.setRigidVelocity(Vec3(0, -1.5, 0), Vec3::Zero());
        Run out;
        for (int s = 0; s < 240; ++s) {
            const StepReport rep = body.step(test::gravityField(), 1, 1.0 / 48, {test::groundPlane()});
            INFO("step " << s << ": " << rep.fault);
            REQUIRE(rep.fault.empty());
            CHECK(rep.maxCellVolumeError <= 1e-4);
            if (s == 47) out.energyAt1s = rep.kineticEnergy;
            out.energyEnd = rep.kineticEnergy;
            out.mostElastic = std::max(out.mostElastic, logStrain(body.flex() * body.plasticFlex().inverse()));
            if (s % 10 == 9) {
                const GeometricState& st = body.state();
                for (Index p = 0; p < lat.size(); ++p) {
                    Mat3 F;
                    F << st.tangent[0][p], st.tangent[1][p], st.tangent[2][p];
                    out.lowest = std::min(out.lowest, F.determinant() / (h * h * h));
                }
            }
        }
        out.squash = body.flex()(1, 1);
        out.restSquash = body.plasticFlex()(1, 1);
        return out;
    };
    const Run goo = run(0, 0), jelly = run(k, 0), putty = run(k, yield);
    if (verbose())
        for (const auto& [name, x] : {std::pair{"goo", goo}, std::pair{"jelly", jelly}, std::pair{"putty", putty}})
            std::printf(
                "%-5s: A_yy %.3f (rest P_yy %.3f), kinetic energy %.2e J at 1 s, %.2e J at 5 s, largest elastic strain "
                "%.4f, lowest det F/h^3 %.3f\n",
                name, x.squash, x.restSquash, x.energyAt1s, x.energyEnd, x.mostElastic, x.lowest);
    CHECK(goo.squash < 0.25);                          // goo spreads on (measured 0.201)
    CHECK(goo.energyEnd > 50 * putty.energyEnd);       // and is still flowing (0.76 J)
    CHECK(jelly.restSquash == 1);                      // no plasticity: no rest change
    CHECK(jelly.mostElastic > yield);                  // the load is beyond the putty's yield...
    CHECK(putty.mostElastic <= yield + 1e-12);         // ...which the putty never passes
    CHECK(putty.restSquash < 0.97);                    // so its rest shape yielded
    CHECK(putty.squash < jelly.squash - 0.02);         // and it keeps more of a squash
    CHECK(putty.squash > goo.squash + 0.4);            // but stops far short of the goo
    CHECK(putty.energyEnd < 0.02 * putty.energyAt1s);  // settling
    CHECK(putty.lowest > 0.5);
}
