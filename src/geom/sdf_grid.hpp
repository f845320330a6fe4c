#pragma once
/// @file sdf_grid.hpp
/// @brief A dense grid of signed-distance samples (negative inside), e.g. a level set loaded from
/// a .vdb file (io/vdb_read.hpp), usable as a static collider.
///
/// Sample (i, j, k), 0 <= i < dims.x ..., sits at origin + spacing * (i, j, k) (world units);
/// values are stored i fastest: values[i + dims.x * (j + dims.y * k)].
/// Inside the box [origin, origin + spacing * (dims - 1)]: trilinear interpolation of the samples.
/// Outside it: distance(x) = distance(c) + |x - c|, c = x clamped to the box (the samples on the
/// box boundary lie outside the object for a grid loaded from a level set, so this grows like a
/// distance away from the box); gradient() is the exact gradient of that rule.
/// A narrow-band level set holds true distances only within `narrowBand` of the surface; farther
/// samples are +-narrowBand (clamped), where the gradient is zero.

#include "base/types.hpp"

#include <vector>

namespace dgv {

struct SdfGrid {
    Vec3 origin = Vec3::Zero();  ///< world position of sample (0, 0, 0)
    Real spacing = 1;            ///< world units between samples (> 0)
    Vec3i dims = Vec3i::Zero();  ///< samples per axis (each >= 2)
    Real narrowBand = 0;         ///< |distance| is exact below this (0: everywhere)
    std::vector<float> values;   ///< dims.prod() signed distances, world units

    bool empty() const { return values.empty(); }
    Index linearIndex(int i, int j, int k) const { return i + Index(dims.x()) * (j + Index(dims.y()) * k); }
    float at(int i, int j, int k) const { return values[static_cast<std::size_t>(linearIndex(i, j, k))]; }
    /// World box spanned by the samples.
    Box3 bounds() const;
    /// Signed distance at x (rule above). The grid must not be empty.
    Real distance(const Vec3& x) const;
    /// Gradient of distance() at x (not normalised; about unit length in the narrow band).
    Vec3 gradient(const Vec3& x) const;
};

}  // namespace dgv
