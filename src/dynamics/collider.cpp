// Colliders as signed distances (collider.hpp).

#include "dynamics/collider.hpp"

#include "base/parallel.hpp"

#include <algorithm>

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

Real liftOutOfColliders(const std::vector<Collider>& colliders, std::vector<Vec3>& points) {
    constexpr int kSteps = 4;  // a distance grid's gradient is unit only approximately
    return parallelReduce(
        static_cast<Index>(points.size()), Real(0),
        [&](Real& deepest, Index i) {
            Vec3& x = points[static_cast<std::size_t>(i)];
            for (const Collider& c : colliders) {
                if (c.object) continue;
                for (int step = 0; step < kSteps; ++step) {
                    Vec3 g;
                    const Real phi = c.evaluate(x, g);
                    const Real g2 = g.squaredNorm();
                    if (!(phi < 0) || !(g2 > 0)) break;
                    if (step == 0) deepest = std::max(deepest, -phi / std::sqrt(g2));
                    x -= (phi / g2) * g;
                }
            }
        },
        [](Real a, Real b) { return std::max(a, b); });
}

}  // namespace dgv
