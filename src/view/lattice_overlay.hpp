#pragma once
/// @file lattice_overlay.hpp
/// @brief Which lattice points the render overlay draws as dots (scene key
/// render.overlays.lattice, lattice_set). Dots are drawn on top of everything, so drawing every
/// point stacks the interior into stripes; the default draws the surface layer seen from the
/// camera.

#include "base/types.hpp"
#include "geom/lattice.hpp"

#include <vector>

namespace dgv {

/// Outward direction of boundary point p at positions x (#P), from the deformed lattice itself:
/// for each of the six slots whose neighbour is missing, the direction away from the opposite
/// neighbour (x_p - x_opposite), summed. Zero when no missing slot has an opposite neighbour (a
/// point one voxel thin there), and for interior points.
Vec3 latticeOutward(const Lattice& lat, const std::vector<Vec3>& x, Index p);

/// The positions of the dots: every point of `candidates` (point ids) at positions x, except,
/// when `eye` is given, those whose outward direction (latticeOutward) points away from it
/// (the far side of the surface). A zero direction counts as facing.
std::vector<Vec3> latticeOverlayPoints(const Lattice& lat, const std::vector<Vec3>& x,
                                       const std::vector<Index>& candidates, const Vec3* eye);

}  // namespace dgv
