// Tests of the force fields (src/dynamics/forces.hpp): analytic gradient and Hessian of every
// field against central differences (error ∝ h², so halving h divides it by ~4, and the
// Richardson extrapolation of the two agrees with the analytic value to O(h⁴)), the structural
// properties (divergence-free wind and vortex, tangential vortex, curl-free radial fields,
// linearity of sums), keyframes and determinism.
#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "dynamics/forces.hpp"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

using namespace dgv;

namespace {

bool verbose() { return std::getenv("DGV_TEST_VERBOSE") != nullptr; }

ForceTerm gravity() {
    ForceTerm t;
    t.kind = ForceKind::Gravity;
    t.direction = Vec3(0.2, -1, 0.1);
    t.strength = Keyframes::constant(9.81);
    return t;
}
ForceTerm attractor(Real p = 2) {
    ForceTerm t;
    t.kind = ForceKind::Attractor;
    t.centre = Vec3(0.3, -0.2, 0.5);
    t.radius = 1.5;
    t.softening = 0.2;
    t.falloff = p;
    t.strength = Keyframes::constant(3);
    return t;
}
ForceTerm vortex(Real n = 1) {
    ForceTerm t;
    t.kind = ForceKind::Vortex;
    t.centre = Vec3(-0.4, 0.1, 0.2);
    t.axis = Vec3(1, 2, 3);
    t.radius = 0.7;
    t.falloff = n;
    t.strength = Keyframes::constant(2);
    return t;
}
ForceTerm torsion() {
    ForceTerm t;
    t.kind = ForceKind::Torsion;
    t.centre = Vec3(0.2, -0.1, 0.3);
    t.axis = Vec3(0.3, 1, -0.2);
    t.radius = 0.6;
    t.strength = Keyframes::constant(1.5);
    return t;
}
ForceTerm burst() {
    ForceTerm t;
    t.kind = ForceKind::Burst;
    t.centre = Vec3(0.1, 0.2, -0.3);
    t.radius = 0.8;
    t.strength = Keyframes::constant(5);
    return t;
}
ForceTerm wind(std::uint32_t seed = 7) {
    ForceTerm t;
    t.kind = ForceKind::Wind;
    t.direction = Vec3(1, 0, 0.5);
    t.turbulence = 0.8;
    t.scale = 0.9;
    t.seed = seed;
    t.strength = Keyframes::constant(1.5);
    return t;
}
ForceTerm linear() {
    ForceTerm t;
    t.kind = ForceKind::Linear;
    t.centre = Vec3(0.5, 0.5, 0.5);
    t.matrix << 1, 2, 0, -1, 0.5, 3, 0.25, -2, 1;
    t.strength = Keyframes::constant(0.7);
    return t;
}

ForceField fieldOf(const std::vector<ForceTerm>& terms) {
    ForceField f;
    for (const auto& t : terms) f.add(t);
    return f;
}

Real maxAbs(const Mat3& m) { return m.cwiseAbs().maxCoeff(); }

/// Central differences of F (→ gradient) and of the analytic gradient (→ Hessian) at step h.
struct FdDerivs {
    Mat3 gradient;
    std::array<Mat3, 3> hessian;
};
FdDerivs centralDifferences(const ForceField& f, const Vec3& x, Real h) {
    FdDerivs d;
    for (int j = 0; j < 3; ++j) {
        Vec3 e = Vec3::Zero();
        e[j] = h;
        const ForceSample p = f.sample(x + e, 0), m = f.sample(x - e, 0);
        d.gradient.col(j) = (p.value - m.value) / (2 * h);
        const Mat3 dG = (p.gradient - m.gradient) / (2 * h);  // dG(i, l) = ∂²F_i/∂x_l∂x_j
        for (int i = 0; i < 3; ++i) d.hessian[i].col(j) = dG.row(i).transpose();
    }
    return d;
}

struct FdCheck {
    Real errH = 0, errH2 = 0, errRich = 0;  ///< max |FD − analytic| at h, h/2; Richardson
    Real magnitude = 0;                     ///< max |analytic| entry
};

/// Compares the analytic derivatives with central differences at h and h/2. `which` 0: the
/// gradient, 1: the Hessian.
FdCheck fdCheck(const ForceField& f, const Vec3& x, Real h, int which) {
    const ForceSample a = f.sample(x, 0);
    const FdDerivs d1 = centralDifferences(f, x, h), d2 = centralDifferences(f, x, h / 2);
    FdCheck c;
    auto compare = [&](const Mat3& an, const Mat3& fd1, const Mat3& fd2) {
        c.errH = std::max(c.errH, maxAbs(fd1 - an));
        c.errH2 = std::max(c.errH2, maxAbs(fd2 - an));
        c.errRich = std::max(c.errRich, maxAbs((4 * fd2 - fd1) / 3 - an));
        c.magnitude = std::max(c.magnitude, maxAbs(an));
    };
    if (which == 0) {
        compare(a.gradient, d1.gradient, d2.gradient);
    } else {
        for (int i = 0; i < 3; ++i) compare(a.hessian[i], d1.hessian[i], d2.hessian[i]);
    }
    return c;
}

/// The derivative is right when either the central differences are exact to round-off
/// (polynomial parts), or their error falls by 4 (3.6..4.4) when h halves and the Richardson
/// extrapolation is at least 30× closer than the h/2 difference (its error is O(h⁴), here
/// h² ≈ 1e-4 relative to the field's length scale).
void requireConverges(const FdCheck& c, const char* what, const Vec3& x) {
    INFO(what << " at " << x.transpose() << ": err(h) " << c.errH << ", err(h/2) " << c.errH2 << ", Richardson "
              << c.errRich << ", magnitude " << c.magnitude);
    if (verbose())
        std::printf("  %-28s |d| %9.3e  err(h) %9.3e  ratio %6.3f  richardson %9.3e\n", what, c.magnitude, c.errH,
                    c.errH2 > 0 ? c.errH / c.errH2 : 0.0, c.errRich);
    const Real roundoff = 1e-9 * (1 + c.magnitude);
    if (c.errH <= roundoff) {
        REQUIRE(c.errH2 <= 2 * roundoff);
        return;
    }
    const Real ratio = c.errH / c.errH2;
    REQUIRE(ratio > 3.6);
    REQUIRE(ratio < 4.4);
    REQUIRE(c.errRich < c.errH2 / 30);
}

std::vector<Vec3> randomPoints(int n, const Vec3& centre, Real spread, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<Real> u(-1, 1);
    std::vector<Vec3> out;
    for (int i = 0; i < n; ++i) out.push_back(centre + spread * Vec3(u(rng), u(rng), u(rng)));
    return out;
}

}  // namespace

TEST_CASE("forces: keyframes interpolate linearly and hold outside the keys", "[dynamics][forces]") {
    Keyframes k{{{1, 0}, {11, 5}, {21, -5}}};
    CHECK(k.at(-3) == 0);
    CHECK(k.at(1) == 0);
    CHECK(k.at(6) == Approx(2.5).margin(1e-15));
    CHECK(k.at(11) == 5);
    CHECK(k.at(13.5) == Approx(2.5).margin(1e-15));
    CHECK(k.at(21) == -5);
    CHECK(k.at(400) == -5);
    CHECK(Keyframes{}.at(3) == 0);
    CHECK(Keyframes::constant(4).at(-100) == 4);

    // The field's strength follows the keys: F scales with the keyed value.
    ForceTerm t = vortex();
    t.strength = k;
    const ForceField f = fieldOf({t});
    const ForceTerm one = [&] {
        ForceTerm u = vortex();
        u.strength = Keyframes::constant(1);
        return u;
    }();
    const ForceField unit = fieldOf({one});
    const Vec3 x(0.3, 0.9, -0.2);
    const ForceSample s1 = unit.sample(x, 0);
    for (Real frame : {0.0, 3.0, 6.0, 11.0, 13.5, 17.25, 30.0}) {
        const ForceSample s = f.sample(x, frame);
        const Real w = k.at(frame);
        CHECK((s.value - w * s1.value).norm() <= 1e-14 * (1 + s1.value.norm() * std::abs(w)));
        CHECK(maxAbs(s.gradient - w * s1.gradient) <= 1e-14 * (1 + maxAbs(s1.gradient) * std::abs(w)));
        for (int i = 0; i < 3; ++i)
            CHECK(maxAbs(s.hessian[i] - w * s1.hessian[i]) <= 1e-14 * (1 + maxAbs(s1.hessian[i]) * std::abs(w)));
    }
}

TEST_CASE("forces: closed-form magnitudes of each field", "[dynamics][forces]") {
    // Gravity: s times the unit direction, no derivatives.
    {
        const ForceSample s = fieldOf({gravity()}).sample(Vec3(3, 4, 5), 0);
        CHECK((s.value - 9.81 * Vec3(0.2, -1, 0.1).normalized()).norm() < 1e-14);
        CHECK(maxAbs(s.gradient) == 0);
    }
    // Attractor, inverse square, softening negligible: |F| = s at |d| = R, pointing inward.
    {
        ForceTerm t = attractor();
        t.softening = 1e-6;
        const Vec3 dir = Vec3(1, -2, 2).normalized();
        const Vec3 x = t.centre + t.radius * dir;
        const Vec3 F = fieldOf({t}).value(x, 0);
        CHECK((F + 3 * dir).norm() < 1e-10);
        // ... and 1/r² beyond: at 2R, s/4.
        CHECK(fieldOf({t}).value(t.centre + 2 * t.radius * dir, 0).norm() == Approx(0.75).epsilon(1e-10));
    }
    // Attractor at its centre: F = 0, ∇F = −s R^p ε^−(p+1) 1 (no singularity).
    for (Real p : {0.0, 1.0, 2.0, 3.5}) {
        const ForceTerm t = attractor(p);
        const ForceSample s = fieldOf({t}).sample(t.centre, 0);
        CHECK(s.value.norm() == 0);
        const Real g = -3 * std::pow(t.radius, p) * std::pow(t.softening, -(p + 1));
        CHECK(maxAbs(s.gradient - g * Mat3::Identity()) <= 1e-13 * std::abs(g));
        for (int i = 0; i < 3; ++i) CHECK(maxAbs(s.hessian[i]) == 0);
    }
    // Vortex: |F| = s exactly at ρ = R, whatever the falloff and the position along the axis.
    for (Real n : {0.0, 1.0, 2.0}) {
        const ForceTerm t = vortex(n);
        const Vec3 a = t.axis.normalized();
        const Vec3 perp = a.cross(Vec3::UnitX()).normalized();
        const Vec3 x = t.centre + 5.0 * a + t.radius * perp;
        const Vec3 F = fieldOf({t}).value(x, 0);
        CHECK(F.norm() == Approx(2).epsilon(1e-13));
        CHECK((F.normalized() - a.cross(perp)).norm() < 1e-13);  // right-hand rule about a
    }
    // Burst: outward, peak s at |d| = R.
    {
        const ForceTerm t = burst();
        const Vec3 dir = Vec3(-1, 4, 2).normalized();
        CHECK((fieldOf({t}).value(t.centre + t.radius * dir, 0) - 5 * dir).norm() < 1e-13);
        CHECK(fieldOf({t}).value(t.centre, 0).norm() == 0);
        const Real inner = fieldOf({t}).value(t.centre + 0.9 * t.radius * dir, 0).norm();
        const Real outer = fieldOf({t}).value(t.centre + 1.1 * t.radius * dir, 0).norm();
        CHECK(inner < 5);
        CHECK(outer < 5);
    }
    // Wind without turbulence: the mean only.
    {
        ForceTerm t = wind();
        t.turbulence = 0;
        const ForceSample s = fieldOf({t}).sample(Vec3(1, 2, 3), 0);
        CHECK((s.value - 1.5 * Vec3(1, 0, 0.5).normalized()).norm() < 1e-14);
        CHECK(maxAbs(s.gradient) == 0);
    }
}

TEST_CASE("forces: gradients and Hessians match central differences for every field", "[dynamics][forces]") {
    struct Case {
        const char* name;
        std::vector<ForceTerm> terms;
        Vec3 centre;  ///< where to sample around
        Real length;  ///< the field's length scale: h = 0.01 length
    };
    std::vector<Case> cases = {
        {"gravity", {gravity()}, Vec3(0, 0, 0), 1},
        {"attractor p=2", {attractor(2)}, attractor().centre, 0.2},
        {"attractor p=1", {attractor(1)}, attractor().centre, 0.2},
        {"attractor p=0.5", {attractor(0.5)}, attractor().centre, 0.2},
        {"repeller p=3",
         {[] {
             ForceTerm t = attractor(3);
             t.strength = Keyframes::constant(-2);
             return t;
         }()},
         attractor().centre,
         0.2},
        {"vortex n=1", {vortex(1)}, vortex().centre, 0.7},
        {"vortex n=2.5", {vortex(2.5)}, vortex().centre, 0.7},
        {"burst", {burst()}, burst().centre, 0.8},
        {"wind", {wind()}, Vec3(0.3, 0.1, -0.2), 0.6},  // the shortest wavelength, scale / 1.5
        {"linear", {linear()}, Vec3(0, 0, 0), 1},
        {"torsion", {torsion()}, torsion().centre, 0.6},
        {"sum of all", {gravity(), attractor(), vortex(), burst(), wind(), linear(), torsion()}, Vec3(0, 0, 0), 0.2},
    };
    for (const Case& c : cases) {
        const ForceField f = fieldOf(c.terms);
        std::vector<Vec3> points = randomPoints(6, c.centre, 2 * c.length, 17);
        // near the (softened) centre: on it, and inside and at the softening radius
        points.push_back(c.centre);
        points.push_back(c.centre + 0.3 * c.length * Vec3(1, 0.5, -0.25).normalized());
        points.push_back(c.centre + 1.0 * c.length * Vec3(-0.3, 1, 0.2).normalized());
        points.push_back(c.centre + 8.0 * c.length * Vec3(0.6, -0.2, 1).normalized());  // far field
        if (verbose()) std::printf("%s\n", c.name);
        const Real h = 0.01 * c.length;
        for (const Vec3& x : points) {
            requireConverges(fdCheck(f, x, h, 0), (std::string(c.name) + " gradient").c_str(), x);
            requireConverges(fdCheck(f, x, h, 1), (std::string(c.name) + " Hessian").c_str(), x);
            // each hessian[i] is symmetric
            const ForceSample s = f.sample(x, 0);
            for (int i = 0; i < 3; ++i)
                CHECK(maxAbs(s.hessian[i] - s.hessian[i].transpose()) <= 1e-14 * (1 + maxAbs(s.hessian[i])));
        }
    }
}

TEST_CASE("forces: wind turbulence and the vortex are divergence-free to round-off", "[dynamics][forces]") {
    const ForceField w = fieldOf({wind(3)}), v = fieldOf({vortex(1)}), v2 = fieldOf({vortex(2.5)});
    Real worst = 0;
    for (const Vec3& x : randomPoints(200, Vec3(0.5, -1, 2), 5, 5)) {
        for (const ForceField* f : {&w, &v, &v2}) {
            const ForceSample s = f->sample(x, 0);
            const Real rel = std::abs(s.gradient.trace()) / s.gradient.norm();
            worst = std::max(worst, rel);
            REQUIRE(rel < 1e-14);
            // and the divergence's gradient, Σ_i ∂²F_i/∂x_i∂x_k, vanishes too
            Vec3 dd = Vec3::Zero();
            Real scale = 0;
            for (int i = 0; i < 3; ++i) {
                dd += s.hessian[i].row(i).transpose();
                scale = std::max(scale, maxAbs(s.hessian[i]));
            }
            REQUIRE(dd.norm() <= 1e-14 * scale);
        }
    }
    if (verbose()) std::printf("max |div F| / |grad F| = %.3e\n", worst);
    // The turbulence is not trivial: its gradient is of the size its wavelength implies.
    const ForceSample s = w.sample(Vec3(0.1, 0.2, 0.3), 0);
    CHECK(s.gradient.norm() > 0.1);
}

TEST_CASE("forces: the vortex is tangential and the radial fields are curl-free", "[dynamics][forces]") {
    for (Real n : {0.0, 1.0, 3.0}) {
        const ForceTerm t = vortex(n);
        const Vec3 a = t.axis.normalized();
        const ForceField f = fieldOf({t});
        for (const Vec3& x : randomPoints(100, t.centre, 3, 11)) {
            const Vec3 F = f.value(x, 0);
            const Vec3 d = x - t.centre;
            REQUIRE(std::abs(F.dot(d)) <= 1e-14 * F.norm() * d.norm());
            REQUIRE(std::abs(F.dot(a)) <= 1e-14 * F.norm());
        }
    }
    for (const ForceTerm& t : {attractor(2), attractor(0.5), burst()}) {
        const ForceField f = fieldOf({t});
        for (const Vec3& x : randomPoints(100, t.centre, 3, 13)) {
            const Mat3 g = f.sample(x, 0).gradient;
            REQUIRE(maxAbs(g - g.transpose()) <= 1e-14 * maxAbs(g));
        }
    }
}

TEST_CASE("forces: a sum of fields is the sum of their samples", "[dynamics][forces]") {
    const std::vector<ForceTerm> terms = {gravity(), attractor(), vortex(), burst(), wind(), linear()};
    const ForceField all = fieldOf(terms);
    for (const Vec3& x : randomPoints(50, Vec3::Zero(), 2, 23)) {
        ForceSample sum;
        for (const ForceTerm& t : terms) {
            const ForceSample s = fieldOf({t}).sample(x, 0);
            sum.value += s.value;
            sum.gradient += s.gradient;
            for (int i = 0; i < 3; ++i) sum.hessian[i] += s.hessian[i];
        }
        const ForceSample s = all.sample(x, 0);
        REQUIRE((s.value - sum.value).norm() <= 1e-14 * (1 + sum.value.norm()));
        REQUIRE(maxAbs(s.gradient - sum.gradient) <= 1e-14 * (1 + maxAbs(sum.gradient)));
        for (int i = 0; i < 3; ++i)
            REQUIRE(maxAbs(s.hessian[i] - sum.hessian[i]) <= 1e-14 * (1 + maxAbs(sum.hessian[i])));
        // lower orders: the same values, higher orders left zero
        const ForceSample v = all.sample(x, 0, ForceOrder::Value);
        REQUIRE(v.value == s.value);
        REQUIRE(maxAbs(v.gradient) == 0);
        const ForceSample g = all.sample(x, 0, ForceOrder::Gradient);
        REQUIRE(g.gradient == s.gradient);
        REQUIRE(maxAbs(g.hessian[0]) == 0);
    }
}

TEST_CASE("forces: evaluation is deterministic (seeds, bulk vs point, thread count)",
          "[dynamics][forces][determinism]") {
    const std::vector<ForceTerm> terms = {attractor(), vortex(), burst(), wind(42)};
    const std::vector<Vec3> points = randomPoints(20000, Vec3::Zero(), 2, 29);
    ForceSamples one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        fieldOf(terms).sample(points, 3.5, ForceOrder::Hessian, one);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        fieldOf(terms).sample(points, 3.5, ForceOrder::Hessian, two);  // a second, separately built field
    }
    REQUIRE(one.value.size() == points.size());
    REQUIRE(std::memcmp(one.value.data(), two.value.data(), sizeof(Vec3) * points.size()) == 0);
    REQUIRE(std::memcmp(one.gradient.data(), two.gradient.data(), sizeof(Mat3) * points.size()) == 0);
    for (int i = 0; i < 3; ++i)
        REQUIRE(std::memcmp(one.hessian[i].data(), two.hessian[i].data(), sizeof(Mat3) * points.size()) == 0);
    // bulk equals per point, bit for bit
    const ForceField f = fieldOf(terms);
    for (std::size_t p = 0; p < points.size(); p += 997) {
        const ForceSample s = f.sample(points[p], 3.5);
        REQUIRE(s.value == one.value[p]);
        REQUIRE(s.gradient == one.gradient[p]);
        REQUIRE(s.hessian[2] == one.hessian[2][p]);
    }
    // bulk at lower order leaves the higher orders empty
    ForceSamples v;
    f.sample(points, 3.5, ForceOrder::Value, v);
    REQUIRE(v.gradient.empty());
    REQUIRE(v.hessian[0].empty());
    // the seed picks the noise: the same seed the same field, another seed another field
    const Vec3 x(0.25, -0.5, 0.75);
    REQUIRE(fieldOf({wind(42)}).value(x, 0) == fieldOf({wind(42)}).value(x, 0));
    REQUIRE((fieldOf({wind(42)}).value(x, 0) - fieldOf({wind(43)}).value(x, 0)).norm() > 1e-3);
}

TEST_CASE("forces: wind turbulence has unit rms and the mean direction on average", "[dynamics][forces]") {
    // rms |T|² = Σ|c_m|²/2 = 1 exactly for the space average, where the cross terms between
    // modes average out: over a box of 40 wavelengths sampled at 64k points, the cross terms
    // (496 pairs, each averaging to O(1/(k L)) ≈ 0.004 or less) and the sampling error (≈ 1/√N
    // relative, 0.004) leave |mean − 1| well under 0.05.
    ForceTerm t = wind(9);
    t.strength = Keyframes::constant(1);
    t.turbulence = 1;
    t.direction = Vec3::UnitX();
    ForceTerm mean = t;
    mean.turbulence = 0;
    const ForceField f = fieldOf({t});
    const Vec3 m = fieldOf({mean}).value(Vec3::Zero(), 0);
    const std::vector<Vec3> points = randomPoints(65536, Vec3::Zero(), 20 * t.scale, 31);
    Real sum2 = 0;
    Vec3 sum = Vec3::Zero();
    for (const Vec3& x : points) {
        const Vec3 T = f.value(x, 0) - m;
        sum2 += T.squaredNorm();
        sum += T;
    }
    const Real rms2 = sum2 / points.size();
    if (verbose()) std::printf("wind: mean |T|^2 = %.4f, |mean T| = %.4f\n", rms2, (sum / points.size()).norm());
    CHECK(std::abs(rms2 - 1) < 0.05);
    CHECK((sum / points.size()).norm() < 0.05);
}

TEST_CASE("forces: invalid terms are rejected by field name", "[dynamics][forces]") {
    auto messageOf = [](const ForceTerm& t) -> std::string {
        try {
            ForceField f;
            f.add(gravity());
            f.add(t);
        } catch (const InputError& e) {
            return e.what();
        }
        return "";
    };
    ForceTerm a = attractor();
    a.softening = 0;
    CHECK(messageOf(a) == "force field: terms[1].softening: expected a positive number, got 0");
    ForceTerm v = vortex();
    v.axis = Vec3::Zero();
    CHECK(messageOf(v) == "force field: terms[1].axis: expected a non-zero direction");
    ForceTerm w = wind();
    w.scale = -1;
    CHECK(messageOf(w) == "force field: terms[1].scale: expected a positive number, got -1");
    ForceTerm k = burst();
    k.strength.keys = {{2, 1}, {2, 3}};
    CHECK(messageOf(k) == "force field: terms[1].strength[1]: key frames must increase");
    CHECK(messageOf(vortex()).empty());
}

TEST_CASE("forces: sinCos agrees with the library to 2 ulp", "[dynamics][forces]") {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<Real> wide(-1e5, 1e5), narrow(-10, 10);
    Real worst = 0;
    for (int i = 0; i < 200000; ++i) {
        const Real t = i % 2 ? wide(rng) : narrow(rng);
        Real s, c;
        sinCos(t, s, c);
        // 2 ulp of a value of magnitude <= 1 is <= 2^-52 = 2.2e-16 absolute
        const Real err = std::max(std::abs(s - std::sin(t)), std::abs(c - std::cos(t)));
        worst = std::max(worst, err);
        REQUIRE(err <= 2.3e-16);
    }
    for (Real t : {0.0, 1e-300, -0.7853981633974483, 1.5707963267948966, 3.141592653589793, 1e5, -1e5, 1e7, -3e12}) {
        Real s, c;
        sinCos(t, s, c);
        REQUIRE(std::abs(s - std::sin(t)) <= 2.3e-16);
        REQUIRE(std::abs(c - std::cos(t)) <= 2.3e-16);
    }
    if (verbose()) std::printf("sinCos: max |error| %.3e\n", worst);
}
