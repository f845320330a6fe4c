#pragma once
/// @file curve_distance.hpp
/// @brief Closest approach between closed polylines (the notes' figure 2 and 4 abscissa).

#include "base/types.hpp"
#include "collide/gln_exact.hpp"

namespace dgv {

/// Distance between segments p0→p1 and q0→q1 (either may have zero length). Exact to rounding:
/// the closest points are found by clamped parameters (Ericson, Real-Time Collision Detection 5.1.9).
Real segmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1);

/// min over all segment pairs of segmentDistance: the closest approach of the two curves.
/// Pairs whose bounding boxes are farther apart than the best distance so far are skipped.
Real curveDistance(const ClosedCurve& a, const ClosedCurve& b);

}  // namespace dgv
