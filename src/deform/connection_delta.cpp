#include "deform/connection_delta.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "deform/displacement.hpp"

#include <Eigen/LU>

#include <cmath>

namespace dgv {

ConnectionField deformedConnection(const Lattice& lat, const GeometricState& rest, const std::vector<Mat3>& M) {
    const Index n = lat.size();
    DGV_CHECK_EQ(static_cast<Index>(M.size()), n);
    DGV_CHECK_EQ(rest.size(), n);
    // Deformed tangents as world vectors, X_a = sum_c M(a, c) x_c (eq 46), one field per a.
    std::array<std::vector<Vec3>, 3> tangentBar;
    for (auto& v : tangentBar) v.resize(at(n));
    parallelFor(n, [&](Index p) {
        const std::size_t i = at(p);
        for (std::size_t a = 0; a < 3; ++a)
            tangentBar[a][i] = M[i](Eigen::Index(a), 0) * rest.tangent[0][i] +
                               M[i](Eigen::Index(a), 1) * rest.tangent[1][i] +
                               M[i](Eigen::Index(a), 2) * rest.tangent[2][i];
    });
    ConnectionField out;
    for (auto& v : out) v.resize(at(n));
    parallelFor(n, [&](Index p) {
        const std::size_t i = at(p);
        const Mat3& m = M[i];
        const Real det = m.determinant();
        if (!(std::abs(det) > Real(1e-12))) {
            for (std::size_t c = 0; c < 3; ++c) out[c][i] = rest.christoffel[c][i];
            return;
        }
        // Deformed duals X^e = sum_c Q(c, e) x^c, Q = M^-1 (eqs 50-51): rows of dualBar.
        const Mat3 Q = m.inverse();
        Mat3 dual;  // row c = x^c
        for (int c = 0; c < 3; ++c) dual.row(c) = rest.dual[static_cast<std::size_t>(c)][i].transpose();
        const Mat3 dualBar = Q.transpose() * dual;  // row e = sum_c Q(c, e) x^c
        // X_ab = d X_a / du_b = sum_c M^c_{a;b} x_c (eqs 47-48), differenced in world space;
        // Gammabar^e_ab = X^e . X_ab (eqs 49, 52).
        std::array<Vec3, 3> d[3];  // d[a][b] = dX_a/du_b
        bool present[3];
        for (int b = 0; b < 3; ++b)
            for (int a = 0; a < 3; ++a)
                present[b] = latticeDerivative(lat, tangentBar[static_cast<std::size_t>(a)], p, b,
                                               d[a][static_cast<std::size_t>(b)]);
        for (int e = 0; e < 3; ++e) {
            Mat3 g = Mat3::Zero();
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b)
                    if (present[a] && present[b]) g(a, b) = dualBar.row(e).dot(d[a][static_cast<std::size_t>(b)]);
            out[static_cast<std::size_t>(e)][i] = Real(0.5) * (g + g.transpose());
        }
    });
    return out;
}

ConnectionField connectionDelta(const Lattice& lat, const GeometricState& rest, const std::vector<Mat3>& M) {
    ConnectionField d = deformedConnection(lat, rest, M);
    parallelFor(lat.size(), [&](Index p) {
        for (std::size_t c = 0; c < 3; ++c) d[c][at(p)] -= rest.christoffel[c][at(p)];
    });
    return d;
}

Vec3 connectionTrace(const PointConnection& g) {
    // tau_a = sum_b g[b](a, b)
    Vec3 tau;
    for (int a = 0; a < 3; ++a) tau[a] = g[0](a, 0) + g[1](a, 1) + g[2](a, 2);
    return tau;
}

void projectTraceFree(PointConnection& g) {
    const Vec3 tau = connectionTrace(g);
    for (int c = 0; c < 3; ++c) {
        Mat3& gc = g[static_cast<std::size_t>(c)];
        // (delta^c_a tau_b + delta^c_b tau_a) / 4: row c gets tau^T/4, column c gets tau/4.
        gc.row(c) -= Real(0.25) * tau.transpose();
        gc.col(c) -= Real(0.25) * tau;
    }
}

void projectTraceFree(ConnectionField& dGamma) {
    const Index n = static_cast<Index>(dGamma[0].size());
    DGV_CHECK_EQ(static_cast<Index>(dGamma[1].size()), n);
    DGV_CHECK_EQ(static_cast<Index>(dGamma[2].size()), n);
    parallelFor(n, [&](Index p) {
        PointConnection g = {dGamma[0][at(p)], dGamma[1][at(p)], dGamma[2][at(p)]};
        projectTraceFree(g);
        for (std::size_t c = 0; c < 3; ++c) dGamma[c][at(p)] = g[c];
    });
}

}  // namespace dgv
