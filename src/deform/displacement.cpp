#include "deform/displacement.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

namespace dgv {

std::vector<Vec3> displacementCoefficients(const GeometricState& rest, const std::vector<Vec3>& positions) {
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), rest.size());
    std::vector<Vec3> eps(positions.size());
    parallelFor(rest.size(), [&](Index p) {
        const std::size_t i = at(p);
        const Vec3 d = positions[i] - rest.position[i];
        eps[i] = Vec3(rest.dual[0][i].dot(d), rest.dual[1][i].dot(d), rest.dual[2][i].dot(d));
    });
    return eps;
}

std::vector<Vec3> displacedPositions(const GeometricState& rest, const std::vector<Vec3>& eps) {
    DGV_CHECK_EQ(static_cast<Index>(eps.size()), rest.size());
    std::vector<Vec3> x(eps.size());
    parallelFor(rest.size(), [&](Index p) {
        const std::size_t i = at(p);
        x[i] = rest.position[i] + eps[i][0] * rest.tangent[0][i] + eps[i][1] * rest.tangent[1][i] +
               eps[i][2] * rest.tangent[2][i];
    });
    return x;
}

bool latticeDerivative(const Lattice& lat, const std::vector<Vec3>& field, Index p, int axis, Vec3& derivative) {
    const std::array<Index, 6>& nb = lat.neighbours[at(p)];
    const Index lo = nb[static_cast<std::size_t>(2 * axis)];
    const Index hi = nb[static_cast<std::size_t>(2 * axis + 1)];
    const Vec3& f0 = field[at(p)];
    if (lo != kNoPoint && hi != kNoPoint) {
        derivative = Real(0.5) * (field[at(hi)] - field[at(lo)]);
        return true;
    }
    if (lo == kNoPoint && hi == kNoPoint) {
        derivative.setZero();
        return false;
    }
    const int slot = hi != kNoPoint ? 2 * axis + 1 : 2 * axis;
    const Real sign = hi != kNoPoint ? Real(1) : Real(-1);
    const Index q1 = hi != kNoPoint ? hi : lo;
    const Index q2 = lat.neighbours[at(q1)][static_cast<std::size_t>(slot)];
    if (q2 == kNoPoint) {
        derivative = sign * (field[at(q1)] - f0);
    } else {
        derivative = (sign * Real(0.5)) * (Real(4) * (field[at(q1)] - f0) - (field[at(q2)] - f0));
    }
    return true;
}

std::vector<Mat3> deformationMatrices(const Lattice& lat, const GeometricState& rest, const std::vector<Vec3>& eps) {
    DGV_CHECK_EQ(rest.size(), lat.size());
    DGV_CHECK_EQ(static_cast<Index>(eps.size()), lat.size());
    // World displacement dx = sum_b eps^b x_b; eps^c_{;a} = x^c . d(dx)/du_a (eq 10 read from
    // right to left), so that X_a = x_a + d(dx)/du_a = sum_c M(a, c) x_c holds on the lattice
    // exactly (docs/math.md, "Discrete covariant derivatives").
    std::vector<Vec3> dx(eps.size());
    parallelFor(lat.size(), [&](Index p) {
        const std::size_t i = at(p);
        dx[i] = eps[i][0] * rest.tangent[0][i] + eps[i][1] * rest.tangent[1][i] + eps[i][2] * rest.tangent[2][i];
    });
    std::vector<Mat3> M(eps.size());
    parallelFor(lat.size(), [&](Index p) {
        const std::size_t i = at(p);
        Mat3 m = Mat3::Identity();
        for (int a = 0; a < 3; ++a) {
            Vec3 d;
            if (!latticeDerivative(lat, dx, p, a, d)) continue;  // no neighbour: eps_{;a} = 0
            for (int c = 0; c < 3; ++c) m(a, c) += rest.dual[static_cast<std::size_t>(c)][i].dot(d);
        }
        M[i] = m;
    });
    return M;
}

}  // namespace dgv
