// GLN networks and the contact set R (collide/gln_network.hpp; docs/gln.md, "GLN networks and
// the contact set R"), and the response through the simulation (stats.csv's max_penetration,
// contact_precision, contact_recall).

#include "base/errors.hpp"
#include "collide/gln_network.hpp"
#include "dynamics/forces.hpp"
#include "dynamics/stepper.hpp"
#include "io/scene_json.hpp"
#include "sim/simulation.hpp"

#include "../dynamics/lattices.hpp"

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

using namespace dgv;

namespace {

SignedDistance plane(Real height) {
    return [height](const Vec3& x, Vec3* g) {
        if (g) *g = Vec3::UnitY();
        return x.y() - height;
    };
}

SignedDistance sphere(const Vec3& c, Real r) {
    return [c, r](const Vec3& x, Vec3* g) {
        const Vec3 d = x - c;
        if (g) *g = d.normalized();
        return d.norm() - r;
    };
}

/// An axis-aligned box [lo, hi] as an exact signed distance (a level-set collider's stand-in).
SignedDistance box(const Vec3& lo, const Vec3& hi) {
    return [lo, hi](const Vec3& x, Vec3* g) {
        const Vec3 c = 0.5 * (lo + hi), e = 0.5 * (hi - lo);
        const Vec3 q = (x - c).cwiseAbs() - e;
        const Vec3 qp = q.cwiseMax(Real(0));
        Real v;
        Vec3 grad;
        if (qp.squaredNorm() > 0) {
            v = qp.norm();
            grad = qp / v;
        } else {
            int k = 0;
            for (int i = 1; i < 3; ++i)
                if (q[i] > q[k]) k = i;
            v = q[k];
            grad = Vec3::Unit(k);
        }
        for (int i = 0; i < 3; ++i)
            if (x[i] < c[i]) grad[i] = -grad[i];
        if (g) *g = grad;
        return v;
    };
}

struct Score {
    Index r = 0, truth = 0, both = 0;
};

Score score(const std::vector<Vec3>& x, const SignedDistance& phi, const std::vector<unsigned char>& R) {
    Score s;
    for (std::size_t p = 0; p < x.size(); ++p) {
        const bool t = phi(x[p], nullptr) < 0;
        s.r += R[p];
        s.truth += t;
        s.both += t && R[p];
    }
    return s;
}

}  // namespace

TEST_CASE("gln network: fine rings enclose their point, coarse rings cover the boundary", "[collide][gln][network]") {
    const Lattice lat = test::sphereLattice(6, 0.1, Vec3::Zero());
    GlnNetworkSettings st;
    st.coarseToFine = true;
    const GlnNetwork net(lat, st);
    Index boundary = 0;
    for (Index p = 0; p < lat.size(); ++p)
        for (Index q : lat.neighbours[static_cast<std::size_t>(p)])
            if (q == kNoPoint) {
                ++boundary;
                break;
            }
    CHECK(static_cast<Index>(net.fine().size()) + net.pointsWithoutRing() == boundary);
    CHECK(net.pointsWithoutRing() == 0);
    const std::vector<Vec3> x = restPositions(lat);
    // Each fine ring winds once around the short segment through its centre along the normal.
    for (std::size_t k = 0; k < net.fine().size(); k += 7) {
        const Index p = net.fine()[k].centre;
        const Vec3 c = x[static_cast<std::size_t>(p)];
        const Vec3 out = (c - Vec3::Constant(0.6)).normalized();  // the ball's centre is (0.6, 0.6, 0.6)
        const ClosedCurve ring = net.fineCurve(k, x);
        // a thin closed loop along the normal through c: up, and back down beside it (0.4 h away
        // is still inside the quarter-way ring only for the first leg)
        const Vec3 side = out.cross(std::abs(out.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).normalized();
        const ClosedCurve probe = {c - 0.05 * out, c + 0.05 * out, c + 0.05 * out + 0.09 * side,
                                   c - 0.05 * out + 0.09 * side};
        INFO("point " << p);
        CHECK(loopsLinked(ring, probe));
    }
    std::vector<unsigned char> covered(static_cast<std::size_t>(lat.size()), 0);
    for (const NetworkRing& r : net.coarse())
        for (Index q : r.interior) covered[static_cast<std::size_t>(q)] = 1;
    for (const NetworkRing& r : net.fine()) CHECK(covered[static_cast<std::size_t>(r.centre)] == 1);
}

TEST_CASE("gln network: R of a ball pressed into a plane and a sphere matches the signed distance",
          "[collide][gln][network]") {
    const Real h = 0.1;
    const Lattice lat = test::sphereLattice(8, h, Vec3::Zero());  // centre (0.8, 0.8, 0.8), radius 0.8
    const std::vector<Vec3> rest = restPositions(lat);
    for (bool coarse : {false, true}) {
        GlnNetworkSettings st;
        st.coarseToFine = coarse;
        const GlnNetwork net(lat, st);
        std::vector<unsigned char> R;
        // apart: nothing
        ContactSetReport rep = net.contactSet(rest, plane(-0.5), R);
        CHECK(rep.contacts == 0);
        CHECK(rep.colliderLoops == 0);
        for (Real depth :
             {0.05, 0.3, 0.75}) {  // voxels above the lowest point (less than a layer: only surface points are inside)
            for (const SignedDistance& phi : {plane(depth * h), sphere(Vec3(0.8, -2.0 + depth * h, 0.83), 2.0),
                                              box(Vec3(-1, -2, -1), Vec3(3, depth * h, 3))}) {
                rep = net.contactSet(rest, phi, R);
                const Score s = score(rest, phi, R);
                INFO("coarse " << coarse << ", depth " << depth << " voxels: |R| " << s.r << ", truth " << s.truth
                               << ", both " << s.both << ", pairs " << rep.candidatePairs);
                REQUIRE(s.truth > 0);
                CHECK(s.both >= 0.9 * s.r);
                CHECK(s.both >= 0.9 * s.truth);
            }
        }
    }
}

TEST_CASE("gln network: R is the same for any thread count", "[collide][gln][network]") {
    const Real h = 0.05;
    const Lattice lat = test::sphereLattice(16, h, Vec3::Zero());  // > 2048 boundary points: parallel
    std::vector<Vec3> x = restPositions(lat);
    for (std::size_t p = 0; p < x.size(); ++p) {  // a smooth deformation, so the rings tilt
        const Vec3 u = x[p];
        x[p] += 0.2 * h * Vec3(std::sin(7 * u.y()), std::cos(5 * u.z()), std::sin(3 * u.x() + 1));
    }
    const SignedDistance phi = sphere(Vec3(0.8, -1.5 + 0.8 * h, 0.81), 1.5);
    for (bool coarse : {false, true}) {
        GlnNetworkSettings st;
        st.coarseToFine = coarse;
        const GlnNetwork net(lat, st);
        REQUIRE(net.fine().size() > 2048);
        std::vector<unsigned char> r1, r2;
        ContactSetReport a, b;
        {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
            a = net.contactSet(x, phi, r1);
        }
        {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 3);
            b = net.contactSet(x, phi, r2);
        }
        CHECK(a.contacts > 10);
        CHECK(r1 == r2);
        CHECK(a.candidatePairs == b.candidatePairs);
        CHECK(a.linkedPairs == b.linkedPairs);
    }
}

TEST_CASE("gln contacts: the scene's collision setting", "[collide][gln][scene]") {
    const std::string obj = R"("objects": [{"primitive": {"type": "sphere"}}])";
    CHECK(parseScene("{" + obj + "}", "a.json").collision.detect == CollisionDesc::Detect::Sdf);
    const SceneDesc g =
        parseScene("{" + obj + R"(, "collision": {"detect": "gln", "coarse_to_fine": true}})", "a.json");
    CHECK(g.collision.detect == CollisionDesc::Detect::Gln);
    CHECK(g.collision.coarseToFine);
    try {
        parseScene("{" + obj + R"(, "collision": {"detect": "linking"}})", "a.json");
        FAIL("no error");
    } catch (const InputError& e) {
        CHECK(std::string(e.what()).find("collision.detect") != std::string::npos);
    }
}

namespace {

/// A ball of radius 6 voxels (h = 0.05) dropped from 0.02 above the collider at 1.5 m/s, 16
/// frames at 24 fps with 4 substeps, GLN detection; sums the contact figures over the frames
/// with contact.
void dropBall(const std::string& collider, bool coarse) {
    const std::string json = std::string(R"({"frames": {"start": 1, "end": 16, "fps": 24}, "substeps": 4,
        "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.3}, "velocity": [0, -1.5, 0],
                     "material": {"damping": 2}}],
        "forces": [{"type": "gravity"}],
        "collision": {"detect": "gln", "coarse_to_fine": )") +
                             (coarse ? "true" : "false") + R"(},
        "colliders": [)" + collider +
                             "]}";
    const SceneDesc scene = parseScene(json, "dir/drop.json");
    // lowest point at y = 0.02 (the collider's top is at y = 0)
    const Lattice lat = test::sphereLattice(6, 0.05, Vec3(-0.3, 0.02, -0.3));
    Simulation sim(scene, {&lat});
    REQUIRE(sim.active());
    Index r = 0, truth = 0, both = 0, frames = 0;
    Real worst = 0;
    for (int f = 2; f <= 16; ++f) {
        const FrameStats s = sim.advanceTo(f);
        worst = std::max(worst, s.maxPenetration);
        if (s.contactSetSize + s.contactTruth == 0) continue;
        ++frames;
        r += s.contactSetSize;
        truth += s.contactTruth;
        both += s.contactTruePositive;
    }
    INFO(collider << ", coarse " << coarse << ": frames with contact " << frames << ", |R| " << r << ", truth " << truth
                  << ", both " << both << ", max penetration " << worst << " voxels");
    REQUIRE(frames >= 5);
    CHECK(worst < 0.1);
    CHECK(both >= 0.9 * r);
    CHECK(both >= 0.9 * truth);
}

}  // namespace

TEST_CASE("gln contacts: a small ball dropped on the ground", "[collide][gln][network][sim]") {
    // (Landing on a sphere collider folds this ball within 2-3 frames of contact with either
    // detection, sdf included: a dynamics limit, docs/gln.md; R against a sphere is checked above.)
    dropBall(R"({"type": "ground", "height": 0})", false);
    dropBall(R"({"type": "ground", "height": 0})", true);
}

// Not a check: the cost of R per step on a ball 24 voxels across, pressed 0.3 voxels into the
// ground, against the whole step with each detection (docs/gln.md). Run with the tag [.bench].
TEST_CASE("gln contacts: cost per step, 24-voxel ball", "[.bench][gln]") {
    const Real h = 0.5 / 12;
    const Lattice lat = test::sphereLattice(12, h, Vec3(-0.5, -0.3 * h, -0.5));
    const std::vector<Vec3> x = restPositions(lat);
    for (bool coarse : {false, true}) {
        GlnNetworkSettings st;
        st.coarseToFine = coarse;
        const auto t0 = std::chrono::steady_clock::now();
        const GlnNetwork net(lat, st);
        const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::vector<unsigned char> R;
        std::vector<double> times;
        ContactSetReport rep;
        for (int k = 0; k < 9; ++k) {
            const auto t1 = std::chrono::steady_clock::now();
            rep = net.contactSet(x, plane(0), R);
            times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
        }
        std::sort(times.begin(), times.end());
        std::printf(
            "gln R, %lld points, %zu fine rings, %zu coarse, coarse_to_fine %d: build %.2f ms, R %.3f ms "
            "(median of 9), %lld loops, %lld pairs, |R| %lld\n",
            static_cast<long long>(lat.size()), net.fine().size(), net.coarse().size(), coarse ? 1 : 0, 1e3 * build,
            1e3 * times[4], static_cast<long long>(rep.colliderLoops), static_cast<long long>(rep.candidatePairs),
            static_cast<long long>(rep.contacts));
    }
    for (bool gln : {false, true}) {
        DeformableBody body(lat, x, DynamicsSettings{});
        GlnNetwork net(lat);
        std::vector<Collider> cols(1);
        cols[0].kind = Collider::Kind::Plane;
        if (gln)
            body.setContactDetector([&](const std::vector<Vec3>& y, const Collider&, std::vector<unsigned char>& R) {
                net.contactSet(y, plane(0), R);
            });
        ForceField f;
        ForceTerm g;
        g.kind = ForceKind::Gravity;
        g.strength = Keyframes::constant(9.81);
        f.add(g);
        std::vector<double> total, collide;
        for (int k = 0; k < 8; ++k) {
            const StepReport r = body.step(f, 1, 1.0 / 96, cols);
            if (k < 3) continue;
            total.push_back(r.totalSeconds);
            collide.push_back(r.collideSeconds);
        }
        std::sort(total.begin(), total.end());
        std::sort(collide.begin(), collide.end());
        std::printf("step with %s detection: %.2f ms per step, collide stage %.3f ms (medians of 5)\n",
                    gln ? "gln" : "sdf", 1e3 * total[2], 1e3 * collide[2]);
    }
}

TEST_CASE("gln contacts: the response reflects the depth by the restitution, with either detection",
          "[collide][gln][network][sim]") {
    const Real h = 0.1;
    const Lattice lat = test::boxLattice(Vec3i(5, 4, 5), h, Vec3(0, -0.03, 0));  // bottom layer 0.3 voxels deep
    // With the affine response (the default) body and flex lift the box first: out of the ground,
    // by at most the reflected depth (1 + e) 0.03 to within its solver's tolerance (1e-3 of it);
    // the restitution's share can be cut by the response's strain bound (0.3 per step, reached
    // here: this box, 4 layers tall, squashes 1.2 times as much as it moves). Without it each point is moved
    // exactly.
    for (bool affine : {false, true})
        for (bool gln : {false, true})
            for (Real e : {0.0, 0.5, 1.0}) {
                DynamicsSettings set;
                set.affineContact = affine;
                DeformableBody body(lat, restPositions(lat), set);
                GlnNetwork net(lat);
                if (gln)
                    body.setContactDetector([&](const std::vector<Vec3>& y, const Collider&,
                                                std::vector<unsigned char>& R) { net.contactSet(y, plane(0), R); });
                std::vector<Collider> cols(1);
                cols[0].kind = Collider::Kind::Plane;
                cols[0].friction = 0;
                cols[0].restitution = e;
                const StepReport r = body.step(ForceField{}, 1, 0.01, cols);
                INFO("affine " << affine << ", gln " << gln << ", restitution " << e);
                CHECK(r.contactTruth == 25);
                CHECK(r.contacts == 25);
                CHECK(r.contactTruePositive == 25);
                CHECK(r.maxPenetration == 0);
                for (Index p = 0; p < lat.size(); ++p)
                    if (lat.coords[static_cast<std::size_t>(p)].y() == 0) {
                        CHECK(body.contact()[static_cast<std::size_t>(p)] == 1);
                        CHECK(body.contactDepth()[static_cast<std::size_t>(p)] == Approx(0.03).margin(1e-12));
                        const Real y = body.positions()[static_cast<std::size_t>(p)].y();
                        if (affine) {
                            CHECK(y >= -1e-12);
                            CHECK(y <= e * 0.03 + 1e-3 * (1 + e) * 0.03);
                        } else {
                            CHECK(y == Approx(e * 0.03).margin(1e-12));
                        }
                    }
            }
}
