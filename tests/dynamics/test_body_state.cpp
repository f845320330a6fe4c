// DeformableBody::saveState / restoreState (src/dynamics/body_state.hpp): a body restored from
// a copy of another's state mid-run continues bit-identically (through contacts); and the volume
// projection's multigrid does change the bits, which is why the state carries what it was built
// from.
#include <catch2/catch.hpp>

#include "dynamics/body_state.hpp"
#include "dynamics/lattices.hpp"
#include "dynamics/stepper.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

using namespace dgv;

namespace {

/// A spinning ball (radius 3 voxels) in gravity and a vortex, 5 cm above a ground plane:
/// contacts from step ~24 on. As the goo drop of test_stepper.cpp: 240 steps per second.
struct Drop {
    Lattice lat = test::sphereLattice(3, 0.05, Vec3(-0.15, 0.05, -0.15));
    DynamicsSettings set;
    ForceField field;
    std::vector<Collider> colliders;
    explicit Drop(bool plastic = false) {
        if (plastic) {  // putty: the rest shape yields (its P and Γ_p are part of the state)
            set.shapeStiffness = 300;
            set.yieldStrain = 0.02;
        }
        set.damping = 1;
        set.volumeTolerance = 1e-9;  // a projection on every step (the default 1e-5 lets most pass)
        ForceTerm t;
        t.kind = ForceKind::Gravity;
        t.strength = Keyframes::constant(9.81);
        field.add(t);
        field.add(test::vortexTerm(3, Vec3(0.2, 0, 0), 0.4));  // shears the ball: δΓ, and cells whose volumes drift
        Collider ground;
        ground.kind = Collider::Kind::Plane;
        ground.point = Vec3::Zero();
        colliders.push_back(ground);
    }
    std::unique_ptr<DeformableBody> body() const {
        auto b = std::make_unique<DeformableBody>(lat, restPositions(lat), set);
        b->setRigidVelocity(Vec3(0.2, 0, 0), Vec3(0, 1.5, 0.5));
        return b;
    }
    /// Steps from..from+steps-1; returns the most points in contact in one step.
    Index run(DeformableBody& b, int from, int steps) const {
        Index most = 0;
        for (int s = from; s < from + steps; ++s) {
            const StepReport r = b.step(field, 1 + s / 240.0, 1.0 / 240, colliders);
            REQUIRE(r.fault.empty());
            if (std::getenv("DGV_TEST_VERBOSE"))
                std::printf("step %d: contacts %lld, volume iterations %d, cache %zu\n", s,
                            static_cast<long long>(r.contacts), r.volumeIterations,
                            b.saveState().volumeCachePositions.size());
            most = std::max(most, r.contacts);
        }
        return most;
    }
};

bool sameBits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

}  // namespace

TEST_CASE("body_state: a body restored mid-run continues bit-identically", "[dynamics][checkpoint]") {
    const bool plastic = GENERATE(false, true);
    INFO("plastic " << plastic);
    const Drop d(plastic);
    auto a = d.body();
    d.run(*a, 0, 12);
    const DeformableBodyState at12 = a->saveState();
    CHECK(at12.havePrev);
    CHECK(at12.positions.size() == static_cast<std::size_t>(d.lat.size()));
    REQUIRE(d.run(*a, 12, 40) > 0);                         // the run did reach the ground after the checkpoint
    REQUIRE(!a->saveState().volumeCachePositions.empty());  // and carries a multigrid

    auto b = d.body();  // a fresh body: what a restarted dgv builds from the scene
    REQUIRE(b->stateFits(at12));
    b->restoreState(at12);
    d.run(*b, 12, 40);
    CHECK(sameBits(a->positions(), b->positions()));
    CHECK(sameBits(a->velocities(), b->velocities()));
    CHECK(a->contact() == b->contact());
    CHECK(a->contactDepth() == b->contactDepth());
    CHECK(a->centre() == b->centre());
    CHECK(a->flex() == b->flex());
    for (std::size_t c = 0; c < 3; ++c) CHECK(a->deltaGamma()[c] == b->deltaGamma()[c]);
    CHECK(a->plasticFlex() == b->plasticFlex());
    for (std::size_t c = 0; c < 3; ++c) CHECK(a->plasticGamma()[c] == b->plasticGamma()[c]);
    if (plastic) {  // it did yield, in the flex and the twist
        CHECK(!a->plasticFlex().isIdentity(1e-9));
        Real yielded = 0;
        for (const Mat3& g : a->plasticGamma()[0]) yielded = std::max(yielded, g.norm());
        CHECK(yielded > 0);
    }
}

TEST_CASE("body_state: the saved state round-trips and a wrong size does not fit", "[dynamics][checkpoint]") {
    const Drop d;
    auto a = d.body();
    d.run(*a, 0, 35);
    const DeformableBodyState s = a->saveState();
    auto b = d.body();
    b->restoreState(s);
    const DeformableBodyState t = b->saveState();
    CHECK(sameBits(s.positions, t.positions));
    CHECK(sameBits(s.displacement, t.displacement));
    CHECK(sameBits(s.displacementPrev, t.displacementPrev));
    CHECK(sameBits(s.volumeCachePositions, t.volumeCachePositions));  // rebuilt from the same input
    CHECK(s.volumeCachePinned == t.volumeCachePinned);
    CHECK(s.centreVelocity == t.centreVelocity);
    CHECK(s.flexVelocity == t.flexVelocity);
    DeformableBodyState shorter = s;
    shorter.velocities.pop_back();
    CHECK_FALSE(b->stateFits(shorter));
    DeformableBodyState noPrev = s;
    noPrev.tangentPrev[1].resize(3);
    CHECK_FALSE(b->stateFits(noPrev));
}

TEST_CASE("body_state: without the volume projection's multigrid inputs the run takes other bits",
          "[dynamics][checkpoint]") {
    // Why the state carries VolumeProjectionCache::builtFrom*: a multigrid built from another
    // step's matrix preconditions the CG differently, and the CG stops at a tolerance.
    const Drop d;
    auto a = d.body();
    d.run(*a, 0, 35);
    DeformableBodyState s = a->saveState();
    REQUIRE(!s.volumeCachePositions.empty());
    d.run(*a, 35, 6);
    s.volumeCachePositions.clear();
    s.volumeCachePinned.clear();
    auto b = d.body();
    b->restoreState(s);
    d.run(*b, 35, 6);
    CHECK_FALSE(sameBits(a->positions(), b->positions()));
    // ... though only in the last bits: the same motion to the volume tolerance.
    Real worst = 0;
    for (std::size_t p = 0; p < a->positions().size(); ++p)
        worst = std::max(worst, (a->positions()[p] - b->positions()[p]).norm());
    CHECK(worst < 1e-4 * 0.05);
}
