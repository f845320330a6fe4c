#pragma once
// A test body for the resampler and the VDB caches: a ball of lattice points (radius `r` steps,
// spacing h, shifted origin), twisted about the vertical axis through its centre by `twist`
// radians per world unit of height; velocity affine in the material coordinates, v = A u + b;
// contact on the points of the lowest layers.

#include "deform/volume.hpp"
#include "geom/lattice.hpp"

#include <cmath>
#include <vector>

namespace dgv::test {

struct TwistedBall {
    Lattice lat;
    LatticeCells cells;
    std::vector<Vec3> x, v;
    std::vector<unsigned char> contact;
    Mat3 A = Mat3::Zero();
    Vec3 b{1.0, -2.0, 0.5};
    Vec3 centre = Vec3::Zero();
    Real twist = 0;

    /// The twist applied to a world point.
    Vec3 twisted(const Vec3& p) const {
        const Vec3 d = p - centre;
        const Real a = twist * d.y(), cs = std::cos(a), sn = std::sin(a);
        return centre + Vec3(cs * d.x() + sn * d.z(), d.y(), -sn * d.x() + cs * d.z());
    }
};

inline TwistedBall makeTwistedBall(Real r, Real h, const Vec3& origin, Real twist) {
    TwistedBall f;
    const int n = static_cast<int>(std::ceil(2 * r)) + 3;
    const Vec3 c = Vec3::Constant(Real(n - 1) / 2);
    std::vector<unsigned char> mask(static_cast<std::size_t>(n * n * n), 0);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if ((Vec3(i, j, k) - c).norm() <= r) mask[static_cast<std::size_t>(i + n * (j + n * k))] = 1;
    f.lat = buildLattice(origin, h, Vec3i(n, n, n), mask);
    f.cells = buildCells(f.lat);
    f.centre = origin + h * c;
    f.twist = twist;
    f.A << 0.1, 0.0, 0.2, 0.0, -0.3, 0.0, 0.05, 0.0, 0.0;
    for (Index p = 0; p < f.lat.size(); ++p) {
        const Vec3i& u = f.lat.coords[static_cast<std::size_t>(p)];
        f.x.push_back(f.twisted(f.lat.restPosition(p)));
        f.v.push_back(f.A * u.cast<Real>() + f.b);
        f.contact.push_back(u.y() <= 2 ? 1 : 0);
    }
    return f;
}

}  // namespace dgv::test
