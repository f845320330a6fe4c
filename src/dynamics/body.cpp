#include "dynamics/body.hpp"

#include "base/check.hpp"
#include "base/errors.hpp"
#include "base/parallel.hpp"

#include <Eigen/LU>

#include <cmath>
#include <string>

namespace dgv {
namespace {

struct MomentSums {
    Real mass = 0;
    Vec3 force = Vec3::Zero();
    Mat3 gradient = Mat3::Zero();
    Mat3 first = Mat3::Zero();
    Mat3 second = Mat3::Zero();
    Vec3 offset = Vec3::Zero();  ///< Σ m ỹ: zero but for the centre's round-off
};

}  // namespace

std::vector<Real> pointMasses(const Lattice& lat, Real density, MassRule rule) {
    if (!(density > 0) || !std::isfinite(density))
        throw InputError("", "density", "expected a positive number, got " + std::to_string(density));
    const Real cellMass = density * lat.spacing * lat.spacing * lat.spacing;
    std::vector<Real> m(static_cast<std::size_t>(lat.size()), cellMass);
    if (rule == MassRule::Voxel) return m;
    parallelFor(lat.size(), [&](Index p) { m[static_cast<std::size_t>(p)] = cellMass * completeCellsAt(lat, p) / 8; });
    return m;
}

Vec3 centreOfMass(const std::vector<Real>& masses, const std::vector<Vec3>& positions) {
    DGV_CHECK_EQ(masses.size(), positions.size());
    using Acc = Eigen::Matrix<Real, 4, 1>;  // (Σ m x, Σ m)
    const Acc s = parallelReduce(
        static_cast<Index>(masses.size()), Acc(Acc::Zero()),
        [&](Acc& acc, Index p) {
            const auto i = static_cast<std::size_t>(p);
            acc.head<3>() += masses[i] * positions[i];
            acc[3] += masses[i];
        },
        [](const Acc& a, const Acc& b) { return Acc(a + b); });
    DGV_CHECK(s[3] > 0);
    return s.head<3>() / s[3];
}

Mat3 ForceMoments::momentGradient() const {
    Eigen::FullPivLU<Mat3> lu(secondMoment);
    DGV_CHECK(lu.isInvertible());
    return firstMoment * lu.inverse();
}

ForceMoments forceMoments(const ForceField& field, const std::vector<Real>& masses, const std::vector<Vec3>& positions,
                          Real frame, bool withGradient) {
    DGV_CHECK_EQ(masses.size(), positions.size());
    ForceMoments out;
    out.centre = centreOfMass(masses, positions);
    const Vec3 c = out.centre;
    const ForceOrder order = withGradient ? ForceOrder::Gradient : ForceOrder::Value;
    const MomentSums s = parallelReduce(
        static_cast<Index>(masses.size()), MomentSums{},
        [&](MomentSums& acc, Index p) {
            const auto i = static_cast<std::size_t>(p);
            const Real m = masses[i];
            if (m == 0) return;
            const ForceSample f = field.sample(positions[i], frame, order);
            const Vec3 y = positions[i] - c;
            acc.mass += m;
            acc.force += m * f.value;
            if (withGradient) acc.gradient += m * f.gradient;
            acc.first += (m * f.value) * y.transpose();
            acc.second += (m * y) * y.transpose();
            acc.offset += m * y;
        },
        [](const MomentSums& a, const MomentSums& b) {
            MomentSums r;
            r.mass = a.mass + b.mass;
            r.force = a.force + b.force;
            r.gradient = a.gradient + b.gradient;
            r.first = a.first + b.first;
            r.second = a.second + b.second;
            r.offset = a.offset + b.offset;
            return r;
        });
    out.mass = s.mass;
    out.meanForce = s.force / s.mass;
    out.meanGradient = s.gradient / s.mass;
    // Centred exactly: Σ m (F − F̄)(ỹ − ȳ)ᵀ = Σ m F ỹᵀ − M F̄ ȳᵀ with ȳ = Σ m ỹ / M, which is zero
    // but for the round-off of the centre; without this, |F̄| |x| ε leaks into the moments.
    const Vec3 ybar = s.offset / s.mass;
    out.firstMoment = s.first / s.mass - out.meanForce * ybar.transpose();
    out.secondMoment = s.second / s.mass - ybar * ybar.transpose();
    return out;
}

Vec3 stepBody(BodyState& body, Real dt, const std::function<Vec3(const Vec3& displacement)>& accelerationAfter) {
    DGV_CHECK(dt > 0);
    body.velocity += (0.5 * dt) * body.acceleration;
    const Vec3 shift = dt * body.velocity;
    body.centre += shift;
    body.acceleration = accelerationAfter(shift);
    body.velocity += (0.5 * dt) * body.acceleration;
    return shift;
}

}  // namespace dgv
