#pragma once
// Lattices and set-ups shared by the dynamics tests: a ball of material points, a full box,
// uniform gravity and a ground plane.

#include "dynamics/forces.hpp"
#include "dynamics/stepper.hpp"
#include "geom/lattice.hpp"

#include <vector>

namespace dgv::test {

/// The points within radius + 0.3 voxels of the centre of a (2 radius + 1)^3 grid with spacing h
/// whose lowest corner is at `origin`; the ball's centre moved by `offset` voxels (< 0.5 each)
/// makes a lopsided voxel ball, as voxelising a mesh does. Without its loose points (the material
/// lattice a scene builds: withoutLoosePoints).
inline Lattice sphereLattice(int radius, Real h, const Vec3& origin, const Vec3& offset = Vec3::Zero()) {
    const int n = 2 * radius + 1;
    const Vec3i dims(n, n, n);
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if ((Vec3(i - radius, j - radius, k - radius) - offset).norm() <= radius + 0.3)
                    mask[static_cast<std::size_t>(i + n * (j + n * k))] = 1;
    return withoutLoosePoints(buildLattice(origin, h, dims, mask));
}

/// Every point of a dims grid with spacing h, lowest corner at `origin`.
inline Lattice boxLattice(const Vec3i& dims, Real h, const Vec3& origin) {
    return buildLattice(origin, h, dims, std::vector<unsigned char>(static_cast<std::size_t>(dims.prod()), 1));
}

/// Uniform gravity of 9.81 m/s² (down y).
inline ForceField gravityField() {
    ForceTerm t;
    t.kind = ForceKind::Gravity;
    t.strength = Keyframes::constant(9.81);
    ForceField g;
    g.add(t);
    return g;
}

/// A vortex about the vertical axis through `centre` (strength in m/s² at the radius, falloff 1).
inline ForceTerm vortexTerm(Real strength, const Vec3& centre, Real radius) {
    ForceTerm v;
    v.kind = ForceKind::Vortex;
    v.strength = Keyframes::constant(strength);
    v.centre = centre;
    v.axis = Vec3::UnitY();
    v.radius = radius;
    v.falloff = 1;
    return v;
}

/// The ground plane y = 0 (normal +y, no friction, no restitution).
inline Collider groundPlane() {
    Collider ground;
    ground.kind = Collider::Kind::Plane;
    ground.point = Vec3::Zero();
    return ground;
}

}  // namespace dgv::test
