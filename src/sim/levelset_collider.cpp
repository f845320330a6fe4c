// A level-set collider's signed distance in world space (levelset_collider.hpp).

#include "sim/levelset_collider.hpp"

#include "base/check.hpp"

#include <Eigen/Geometry>

#include <cmath>

namespace dgv {

std::function<Real(const Vec3& x, Vec3* gradient)> levelSetDistance(std::shared_ptr<const SdfGrid> grid,
                                                                    const TransformDesc& transform) {
    DGV_CHECK(grid && !grid->empty());
    const Real s = transform.scale.x();
    DGV_CHECK(s > 0 && transform.scale.y() == s && transform.scale.z() == s);
    const Mat3 R = transform.linear() / s;
    const Mat3 Rt = R.transpose();
    const Vec3 t = transform.translate;
    return [grid = std::move(grid), s, R, Rt, t](const Vec3& x, Vec3* gradient) -> Real {
        const Vec3 y = Rt * (x - t) / s;
        if (gradient) *gradient = R * grid->gradient(y);
        return s * grid->distance(y);
    };
}

}  // namespace dgv
