#pragma once
/// @file primitives.hpp
/// @brief Built-in closed primitive meshes, centred at the origin, Y up, outward normals.
/// Every primitive shares its vertices, so analyseMesh() reports it closed and manifold; its
/// volume converges to the analytic one as O(1/segments^2). Invalid parameters (non-positive or
/// non-finite sizes, too few segments) throw InputError("", <parameter name>, what).

#include "base/types.hpp"
#include "geom/triangle_mesh.hpp"

namespace dgv {

/// UV sphere: `segments` around Y (>= 3), `rings` from pole to pole (>= 2).
TriangleMesh makeSphere(Real radius, int segments = 64, int rings = 32);
/// Axis-aligned box with the given full edge lengths, `divisions` quads per edge (>= 1); each
/// quad is two triangles. The volume is exact (to rounding) at any `divisions`.
TriangleMesh makeBox(const Vec3& size, int divisions = 1);
/// Torus around Y: `majorRadius` to the tube centre, `minorRadius` (< majorRadius) of the tube.
TriangleMesh makeTorus(Real majorRadius, Real minorRadius, int majorSegments = 96, int minorSegments = 48);
/// Capsule along Y: a cylinder of `height` (>= 0) between the centres of two hemispheres of
/// `radius`; `rings` latitude bands per hemisphere (>= 1).
TriangleMesh makeCapsule(Real radius, Real height, int segments = 64, int rings = 16);

}  // namespace dgv
