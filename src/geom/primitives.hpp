#pragma once
/// @file primitives.hpp
/// @brief Built-in closed primitive meshes, centred at the origin, Y up, outward normals.

#include "base/types.hpp"
#include "geom/triangle_mesh.hpp"

namespace dgv {

/// UV sphere: `segments` around Y (>= 3), `rings` from pole to pole (>= 2).
TriangleMesh makeSphere(Real radius, int segments = 64, int rings = 32);
/// Axis-aligned box with the given full edge lengths, `divisions` quads per edge (>= 1).
TriangleMesh makeBox(const Vec3& size, int divisions = 1);
/// Torus around Y: `majorRadius` to the tube centre, `minorRadius` of the tube.
TriangleMesh makeTorus(Real majorRadius, Real minorRadius, int majorSegments = 96, int minorSegments = 48);
/// Capsule along Y: a cylinder of `height` between the centres of two hemispheres of `radius`.
TriangleMesh makeCapsule(Real radius, Real height, int segments = 64, int rings = 16);

}  // namespace dgv
