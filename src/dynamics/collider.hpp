#pragma once
/// @file collider.hpp
/// @brief What a body collides with, as the dynamics sees it: a signed distance and its
/// gradient (sim/simulation makes them from the scene's colliders and the other bodies).

#include "base/types.hpp"

#include <functional>
#include <vector>

namespace dgv {

/// A collider as a signed distance (negative inside) with its gradient: static (a plane, a
/// sphere, a mesh or level set), or another body's surface (`object`), which moves with
/// `velocity` and takes its part of the push itself.
struct Collider {
    enum class Kind { Plane, Sphere, Distance };
    Kind kind = Kind::Plane;
    Vec3 point = Vec3::Zero();    ///< plane: a point on it; sphere: the centre
    Vec3 normal = Vec3::UnitY();  ///< plane: unit normal pointing out of the solid side
    Real radius = 1;              ///< sphere
    /// Distance: signed distance at x, gradient written to *gradient (unit near the surface).
    std::function<Real(const Vec3& x, Vec3* gradient)> distance;
    Real friction = 0.5;   ///< 0 slip .. 1 stick (fraction of the tangential step removed)
    Real restitution = 0;  ///< 0..1: contact points go out beyond the surface by this × their
                           ///< depth (normal reflection), and on the normal part of the body velocity
    /// Another body's surface (docs/gln.md, "Objects colliding"): the body's points take `share`
    /// of each push the prediction asked for (the other body's points take the rest), friction
    /// acts on the step relative to `velocity` (the other body's centre velocity), and the
    /// penetration left is measured by the caller once both bodies have moved
    /// (StepReport::maxPenetration leaves it out). The caller also puts the pair's momentum right.
    bool object = false;
    Real share = 1;                ///< fraction of each push this body's points take (1: a static collider)
    Vec3 velocity = Vec3::Zero();  ///< the collider's velocity, world units/s
    bool pairContact = false;      ///< the two bodies touch this step (decided by the caller for both)
    int body = -1;                 ///< the other body's index in the caller's list (-1: none)

    /// Signed distance and its gradient at x.
    Real evaluate(const Vec3& x, Vec3& gradient) const;
};

/// Moves each point that lies inside one of the static `colliders` (another body's surface is
/// skipped) out onto that collider's surface along its distance's gradient (Newton steps on φ = 0:
/// one for a plane or a sphere, a few for a distance grid). In parallel. Returns the largest
/// depth a point was moved from (0: none was inside).
Real liftOutOfColliders(const std::vector<Collider>& colliders, std::vector<Vec3>& points);

}  // namespace dgv
