#pragma once
/// @file levelset_collider.hpp
/// @brief A level-set collider (scene collider type "levelset"): the loaded SdfGrid placed in
/// the world by the collider's transform, as the signed distance a dynamics Collider evaluates.

#include "base/types.hpp"
#include "geom/sdf_grid.hpp"
#include "sim/scene.hpp"

#include <functional>
#include <memory>

namespace dgv {

/// The signed distance (negative inside, world units) and its gradient of `grid` moved by
/// `transform` (scale s, uniform; rotation R; translation t): for a world point x,
/// φ(x) = s·grid.distance(y) and ∇φ(x) = R·grid.gradient(y), with y = Rᵀ(x − t)/s the point in
/// the grid's frame. Far from the surface (beyond the grid's narrow band) φ is at least the band
/// outside and at most minus the band inside, with a zero gradient there (SdfGrid).
/// The transform's scale must be uniform (checked: the scene reader refuses anything else).
std::function<Real(const Vec3& x, Vec3* gradient)> levelSetDistance(std::shared_ptr<const SdfGrid> grid,
                                                                    const TransformDesc& transform);

}  // namespace dgv
