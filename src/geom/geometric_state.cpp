#include "geom/geometric_state.hpp"

#include "base/check.hpp"
#include "base/mat3.hpp"
#include "base/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>

namespace dgv {

namespace {

/// Neighbour of p in `slot`, or kNoPoint (also when p itself is kNoPoint).
inline Index step(const Lattice& lat, Index p, int slot) {
    return p == kNoPoint ? kNoPoint : lat.neighbours[at(p)][static_cast<std::size_t>(slot)];
}

/// First and (optionally) second derivative of a lattice field along one axis.
template <typename T>
struct AxisDerivative {
    T first = T::Zero();
    T second = T::Zero();
    bool present = false;  ///< false: no neighbour on either side (first, second = 0)
};

/// The 1-D stencils of geometric_state.hpp for field f at point p along axis a.
template <typename T, bool kSecond>
AxisDerivative<T> axisDerivative(const Lattice& lat, const std::vector<T>& f, Index p, int a, bool realisable = false) {
    AxisDerivative<T> d;
    const std::array<Index, 6>& nb = lat.neighbours[at(p)];
    const Index lo = nb[static_cast<std::size_t>(2 * a)];
    const Index hi = nb[static_cast<std::size_t>(2 * a + 1)];
    const T& f0 = f[at(p)];
    if (lo != kNoPoint && hi != kNoPoint) {
        d.first = Real(0.5) * (f[at(hi)] - f[at(lo)]);
        if constexpr (kSecond) {
            d.second = (f[at(hi)] - f0) + (f[at(lo)] - f0);
        } else {
            d.second.setZero();
        }
        d.present = true;
        return d;
    }
    d.second.setZero();
    if (lo == kNoPoint && hi == kNoPoint) {
        d.first.setZero();
        return d;
    }
    d.present = true;
    const int slot = hi != kNoPoint ? 2 * a + 1 : 2 * a;
    const Real sign = hi != kNoPoint ? Real(1) : Real(-1);
    const Index q1 = hi != kNoPoint ? hi : lo;
    const Index q2 = step(lat, q1, slot);
    if (q2 == kNoPoint) {
        d.first = sign * (f[at(q1)] - f0);
        return d;
    }
    const T& f1 = f[at(q1)];
    const T& f2 = f[at(q2)];
    d.first = (sign * Real(0.5)) * (Real(4) * (f1 - f0) - (f2 - f0));
    if constexpr (kSecond) {
        const Index q3 = step(lat, q2, slot);
        if (q3 == kNoPoint || realisable) {
            d.second = (f2 - f1) - (f1 - f0);
        } else {
            const T& f3 = f[at(q3)];
            // 2 f0 - 5 f1 + 4 f2 - f3, written in differences (exact zero for affine data)
            d.second = Real(2) * ((f2 - f1) - (f1 - f0)) - ((f3 - f2) - (f2 - f1));
        }
    }
    return d;
}

/// d/du_along of the tangent field x_axis at p for BoundaryStencils::Realisable: central where
/// both neighbours along `along` have x_axis, else the one-sided first difference towards the one
/// that has it, else 0. (x_axis is "present" at a point with a neighbour along `axis`.)
Vec3 tangentDifference(const Lattice& lat, const std::vector<Vec3>& x, Index p, int along, int axis) {
    const std::array<Index, 6>& nb = lat.neighbours[at(p)];
    const Index lo = nb[static_cast<std::size_t>(2 * along)], hi = nb[static_cast<std::size_t>(2 * along + 1)];
    AxisDerivative<Vec3> dLo, dHi;
    if (lo != kNoPoint) dLo = axisDerivative<Vec3, false>(lat, x, lo, axis);
    if (hi != kNoPoint) dHi = axisDerivative<Vec3, false>(lat, x, hi, axis);
    if (dLo.present && dHi.present) return Real(0.5) * (dHi.first - dLo.first);
    const AxisDerivative<Vec3> here = axisDerivative<Vec3, false>(lat, x, p, axis);
    if (!here.present) return Vec3::Zero();
    if (dHi.present) return dHi.first - here.first;
    if (dLo.present) return here.first - dLo.first;
    return Vec3::Zero();
}

/// Mixed second derivative x_ab (a != b): the central cross stencil where it exists; elsewhere
/// the mean of the available quadrant stencils (Accurate) or ½ (∂_b x_a + ∂_a x_b) by
/// tangentDifference (Realisable).
Vec3 mixedDerivative(const Lattice& lat, const std::vector<Vec3>& x, Index p, int a, int b, bool realisable) {
    const std::array<Index, 6>& nb = lat.neighbours[at(p)];
    const Index am = nb[static_cast<std::size_t>(2 * a)], ap = nb[static_cast<std::size_t>(2 * a + 1)];
    const Index bm = nb[static_cast<std::size_t>(2 * b)], bp = nb[static_cast<std::size_t>(2 * b + 1)];
    const int slotBm = 2 * b, slotBp = 2 * b + 1;
    const Index pp = step(lat, ap, slotBp), pm = step(lat, ap, slotBm);
    const Index mp = step(lat, am, slotBp), mm = step(lat, am, slotBm);
    if (pp != kNoPoint && pm != kNoPoint && mp != kNoPoint && mm != kNoPoint && bm != kNoPoint && bp != kNoPoint) {
        return Real(0.25) * ((x[at(pp)] - x[at(pm)]) - (x[at(mp)] - x[at(mm)]));
    }
    if (realisable) return Real(0.5) * (tangentDifference(lat, x, p, b, a) + tangentDifference(lat, x, p, a, b));
    const Vec3& x0 = x[at(p)];
    Vec3 sum = Vec3::Zero();
    int count = 0;
    const Index sideA[2] = {am, ap};
    const Index sideB[2] = {bm, bp};
    const Index diag[2][2] = {{mm, mp}, {pm, pp}};
    for (int s = 0; s < 2; ++s) {
        for (int t = 0; t < 2; ++t) {
            const Index qa = sideA[s], qb = sideB[t], qd = diag[s][t];
            if (qa == kNoPoint || qb == kNoPoint || qd == kNoPoint) continue;
            const Vec3 e = (x[at(qd)] - x[at(qa)]) - (x[at(qb)] - x0);
            sum += (s == t) ? e : Vec3(-e);
            ++count;
        }
    }
    if (count == 0) return Vec3::Zero();
    return sum / Real(count);
}

/// Fills tangents missing at p (no neighbour along that axis) with the mean of the same tangent at
/// p's 6-neighbours that have it (slot order, so deterministic), marking them present. Exact for
/// affine maps; leaves axes that no neighbour has (thin sheets and rods) missing.
void extrapolateFrame(const Lattice& lat, const std::vector<Vec3>& x, Index p, std::array<Vec3, 3>& tangent,
                      std::array<bool, 3>& present) {
    const std::array<Index, 6>& nb = lat.neighbours[at(p)];
    std::array<Vec3, 3> sum = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    std::array<int, 3> count = {0, 0, 0};
    for (int slot = 0; slot < 6; ++slot) {
        const Index q = nb[static_cast<std::size_t>(slot)];
        if (q == kNoPoint) continue;
        for (int c = 0; c < 3; ++c) {
            if (present[static_cast<std::size_t>(c)]) continue;
            const AxisDerivative<Vec3> d = axisDerivative<Vec3, false>(lat, x, q, c);
            if (!d.present) continue;
            sum[static_cast<std::size_t>(c)] += d.first;
            ++count[static_cast<std::size_t>(c)];
        }
    }
    for (std::size_t c = 0; c < 3; ++c) {
        if (count[c] == 0) continue;
        tangent[c] = sum[c] / Real(count[c]);
        present[c] = true;
    }
}

/// Smallest rotation taking unit vector `from` to unit vector `to`.
Mat3 rotationBetween(const Vec3& from, const Vec3& to) {
    const Real c = from.dot(to);
    if (c <= Real(-1) + Real(1e-12)) {
        // Half turn about an axis perpendicular to `from`.
        Vec3 k = from.unitOrthogonal();
        return Real(2) * k * k.transpose() - Mat3::Identity();
    }
    const Vec3 v = from.cross(to);
    Mat3 vx;
    vx << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return Mat3::Identity() + vx + (vx * vx) / (Real(1) + c);
}

}  // namespace

void completeFrame(std::array<Vec3, 3>& tangent, const std::array<bool, 3>& present, Real spacing) {
    const Real h = spacing;
    const int n = int(present[0]) + int(present[1]) + int(present[2]);
    if (n == 3) return;
    if (n == 0) {
        for (int a = 0; a < 3; ++a) tangent[static_cast<std::size_t>(a)] = h * Vec3::Unit(a);
        return;
    }
    if (n == 2) {
        const int c = !present[0] ? 0 : (!present[1] ? 1 : 2);
        const Vec3 normal =
            tangent[static_cast<std::size_t>((c + 1) % 3)].cross(tangent[static_cast<std::size_t>((c + 2) % 3)]);
        const Real nn = normal.squaredNorm();
        tangent[static_cast<std::size_t>(c)] =
            nn > Real(1e-12) * h * h * h * h ? Vec3(normal * (h * h * h / nn)) : Vec3(h * Vec3::Unit(c));
        return;
    }
    const int a = present[0] ? 0 : (present[1] ? 1 : 2);
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const Vec3& xa = tangent[static_cast<std::size_t>(a)];
    const Real len = xa.norm();
    if (len <= Real(1e-12) * h) {
        tangent[static_cast<std::size_t>(b)] = h * Vec3::Unit(b);
        tangent[static_cast<std::size_t>(c)] = h * Vec3::Unit(c);
        return;
    }
    const Mat3 r = rotationBetween(Vec3::Unit(a), xa / len);
    const Real scale = h * std::sqrt(h / len);
    tangent[static_cast<std::size_t>(b)] = scale * r.col(b);
    tangent[static_cast<std::size_t>(c)] = scale * r.col(c);
}

bool invertMetric(const Mat3& g, Mat3& gInv) {
    // The adjugate, cof(g)ᵀ (equal to cof(g) for the symmetric g).
    const Mat3 adj = cofactor(g).transpose();
    const Real det = g(0, 0) * adj(0, 0) + g(0, 1) * adj(1, 0) + g(0, 2) * adj(2, 0);
    const Real t = g.trace() / Real(3);
    if (t > Real(0) && det > Real(1e-14) * t * t * t) {
        gInv = adj / det;
        return true;
    }
    Eigen::SelfAdjointEigenSolver<Mat3> eig;
    eig.computeDirect(g);
    const Vec3 lambda = eig.eigenvalues();  // increasing
    const Real largest = lambda(2);
    gInv.setZero();
    if (!(largest > Real(0))) return false;
    for (int i = 0; i < 3; ++i) {
        if (lambda(i) > Real(1e-12) * largest) {
            const Vec3 v = eig.eigenvectors().col(i);
            gInv += (v * v.transpose()) / lambda(i);
        }
    }
    return false;
}

void computeGeometricState(const Lattice& lat, const std::vector<Vec3>& positions, GeometricState& state,
                           BoundaryStencils stencils) {
    const bool realisable = stencils == BoundaryStencils::Realisable;
    const Index n = lat.size();
    DGV_CHECK_EQ(static_cast<Index>(positions.size()), n);
    const std::size_t sz = at(n);
    state.position.resize(sz);
    state.metric.resize(sz);
    state.metricInv.resize(sz);
    for (auto& v : state.tangent) v.resize(sz);
    for (auto& v : state.dual) v.resize(sz);
    for (auto& v : state.second) v.resize(sz);
    for (auto& v : state.christoffel) v.resize(sz);
    const Real h = lat.spacing;

    parallelFor(n, [&](Index p) {
        const std::size_t i = at(p);
        std::array<Vec3, 3> tangent;
        std::array<bool, 3> present;
        Vec3 second[6];
        for (int a = 0; a < 3; ++a) {
            const AxisDerivative<Vec3> d = axisDerivative<Vec3, true>(lat, positions, p, a, realisable);
            tangent[static_cast<std::size_t>(a)] = d.first;
            second[a] = d.second;
            present[static_cast<std::size_t>(a)] = d.present;
        }
        second[3] = mixedDerivative(lat, positions, p, 0, 1, realisable);
        second[4] = mixedDerivative(lat, positions, p, 0, 2, realisable);
        second[5] = mixedDerivative(lat, positions, p, 1, 2, realisable);
        if (!(present[0] && present[1] && present[2])) {
            extrapolateFrame(lat, positions, p, tangent, present);
            completeFrame(tangent, present, h);
        }

        Mat3 frame;  // columns x_a
        frame << tangent[0], tangent[1], tangent[2];
        const Mat3 g = frame.transpose() * frame;
        Mat3 gInv;
        invertMetric(g, gInv);
        const Mat3 dualFrame = frame * gInv;  // columns x^a = g^ab x_b (g^ab symmetric)

        state.position[i] = positions[i];
        state.metric[i] = g;
        state.metricInv[i] = gInv;
        for (int a = 0; a < 3; ++a) {
            state.tangent[static_cast<std::size_t>(a)][i] = tangent[static_cast<std::size_t>(a)];
            state.dual[static_cast<std::size_t>(a)][i] = dualFrame.col(a);
        }
        // proj(c, k) = x^c . x_{pair k}
        Eigen::Matrix<Real, 3, 6> secondM;
        for (int k = 0; k < 6; ++k) {
            secondM.col(k) = second[k];
            state.second[static_cast<std::size_t>(k)][i] = second[k];
        }
        const Eigen::Matrix<Real, 3, 6> proj = dualFrame.transpose() * secondM;
        for (int c = 0; c < 3; ++c) {
            Mat3 gamma;
            gamma(0, 0) = proj(c, 0);
            gamma(1, 1) = proj(c, 1);
            gamma(2, 2) = proj(c, 2);
            gamma(0, 1) = gamma(1, 0) = proj(c, 3);
            gamma(0, 2) = gamma(2, 0) = proj(c, 4);
            gamma(1, 2) = gamma(2, 1) = proj(c, 5);
            state.christoffel[static_cast<std::size_t>(c)][i] = gamma;
        }
    });
}

std::vector<Mat3> covariantDerivative(const Lattice& lat, const GeometricState& state, const std::vector<Vec3>& f) {
    const Index n = lat.size();
    DGV_CHECK_EQ(static_cast<Index>(f.size()), n);
    DGV_CHECK_EQ(state.size(), n);
    std::vector<Mat3> result(at(n));
    parallelFor(n, [&](Index p) {
        const std::size_t i = at(p);
        Mat3 r;
        for (int a = 0; a < 3; ++a) {
            r.col(a) = axisDerivative<Vec3, false>(lat, f, p, a).first;
        }
        // + sum_c f^c Gamma^b_ca: entry (b, a) += (Gamma^b f)_a, Gamma^b symmetric.
        for (int b = 0; b < 3; ++b) {
            r.row(b) += (state.christoffel[static_cast<std::size_t>(b)][i] * f[i]).transpose();
        }
        result[i] = r;
    });
    return result;
}

}  // namespace dgv
