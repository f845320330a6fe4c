#pragma once
/// @file tube.hpp
/// @brief A closed triangle-mesh tube around a closed polyline, for drawing curves (the GLN
/// figures). Cross-sections are regular `sides`-gons of `radius` in the plane normal to the
/// curve at each vertex, oriented by a rotation-minimising frame (projected parallel transport,
/// with the closing twist spread evenly), so the tube has no kinks or seams.

#include "base/types.hpp"
#include "geom/triangle_mesh.hpp"

#include <vector>

namespace dgv {

/// Tube of `radius` with `sides` (>= 3) around the closed polyline `curve` (>= 3 vertices, the
/// last joined to the first). n·sides vertices, 2·n·sides triangles, CCW from outside; closed
/// and manifold. Consecutive duplicate vertices are allowed (their tangent is borrowed).
TriangleMesh makeTube(const std::vector<Vec3>& curve, Real radius, int sides = 12);

}  // namespace dgv
