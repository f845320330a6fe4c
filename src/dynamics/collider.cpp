// Colliders as signed distances (collider.hpp).

#include "dynamics/collider.hpp"

namespace dgv {

Real Collider::evaluate(const Vec3& x, Vec3& gradient) const {
    switch (kind) {
        case Kind::Plane:
            gradient = normal;
            return normal.dot(x - point);
        case Kind::Sphere: {
            const Vec3 d = x - point;
            const Real r = d.norm();
            gradient = r > 0 ? Vec3(d / r) : Vec3(Vec3::UnitY());
            return r - radius;
        }
        case Kind::Distance:
            return distance(x, &gradient);
    }
    gradient = Vec3::UnitY();
    return 1;
}

}  // namespace dgv
