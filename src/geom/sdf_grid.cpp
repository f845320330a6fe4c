#include "geom/sdf_grid.hpp"

#include "base/check.hpp"

namespace dgv {

Box3 SdfGrid::bounds() const {
    Box3 b;
    b.min = origin;
    b.max = origin + spacing * (dims.cast<Real>() - Vec3::Ones());
    return b;
}

Real SdfGrid::distance(const Vec3& x) const {
    DGV_CHECK(!values.empty() && (dims.array() >= 2).all());
    return sdfDistance(origin, spacing, dims, x, [this](int i, int j, int k) { return Real(at(i, j, k)); });
}

Vec3 SdfGrid::gradient(const Vec3& x) const {
    DGV_CHECK(!values.empty() && (dims.array() >= 2).all());
    return sdfGradient(origin, spacing, dims, x, [this](int i, int j, int k) { return Real(at(i, j, k)); });
}

}  // namespace dgv
