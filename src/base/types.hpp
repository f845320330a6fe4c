#pragma once
#include <cmath>
/// @file types.hpp
/// @brief dgv's one scalar and its aliases. Double everywhere in the core; float only at the
/// edges (io/vdb_write, render/). See docs/conventions.md.

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products and rotations are used everywhere; an undeclared
                           // cross() compiles but fails to link

#include <cstddef>
#include <cstdint>
#include <limits>

namespace dgv {

using Real = double;
using Index = std::int64_t;
/// An Index as a std::vector subscript (Index is signed; the containers' sizes are not).
inline std::size_t at(Index i) { return static_cast<std::size_t>(i); }

using Vec2 = Eigen::Matrix<Real, 2, 1>;
using Vec3 = Eigen::Matrix<Real, 3, 1>;
using Vec4 = Eigen::Matrix<Real, 4, 1>;
using Mat3 = Eigen::Matrix<Real, 3, 3>;
using Mat4 = Eigen::Matrix<Real, 4, 4>;
using Vec3i = Eigen::Matrix<int, 3, 1>;
using Vec3f = Eigen::Matrix<float, 3, 1>;

/// Axis-aligned box in world units. Empty when min > max in any component.
struct Box3 {
    Vec3 min = Vec3::Constant(std::numeric_limits<Real>::infinity());
    Vec3 max = Vec3::Constant(-std::numeric_limits<Real>::infinity());

    bool empty() const { return (min.array() > max.array()).any(); }
    void extend(const Vec3& p) {
        min = min.cwiseMin(p);
        max = max.cwiseMax(p);
    }
    void extend(const Box3& b) {
        min = min.cwiseMin(b.min);
        max = max.cwiseMax(b.max);
    }
    Vec3 size() const { return max - min; }
    Vec3 centre() const { return 0.5 * (min + max); }
};

/// Component-wise std::isfinite of an Eigen matrix or vector. (Eigen's allFinite() computes
/// x - x, which raises FE_INVALID on infinities and trips the tests' floating-point traps.)
template <typename M>
bool allFiniteNoTrap(const M& m) {
    for (Index i = 0; i < m.size(); ++i)
        if (!std::isfinite(m.data()[i])) return false;
    return true;
}

}  // namespace dgv
