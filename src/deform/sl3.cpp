#include "deform/sl3.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>

namespace dgv {

namespace {

/// det(1 + t D) = 1 + c t + b t^2 + a t^3 with a = det D, b = s2, c = tr D.
struct Cubic {
    Real a, b, c;
    Real operator()(Real t) const { return Real(1) + t * (c + t * (b + t * a)); }
};

Cubic deformationCubic(const Mat3& M) {
    const Mat3 D = M - Mat3::Identity();
    const Real tr = D.trace();
    const Real s2 = Real(0.5) * (tr * tr - (D * D).trace());
    return Cubic{D.determinant(), s2, tr};
}

/// Whether det(1 + t D) > 0 for every t between 0 and f (p(0) = 1): checks the end point and
/// the critical points of the cubic inside the interval.
bool pathStaysPositive(const Cubic& p, Real f) {
    const Real lo = std::min(Real(0), f), hi = std::max(Real(0), f);
    if (!(p(f) > 0)) return false;
    // p'(t) = c + 2 b t + 3 a t^2
    const Real qa = 3 * p.a, qb = 2 * p.b, qc = p.c;
    auto inside = [&](Real t) { return t > lo && t < hi; };
    const Real scale = std::max({std::abs(qa), std::abs(qb), std::abs(qc)});
    if (scale == 0) return true;
    if (std::abs(qa) <= Real(1e-14) * scale) {
        if (qb != 0) {
            const Real t = -qc / qb;
            if (inside(t) && !(p(t) > 0)) return false;
        }
        return true;
    }
    const Real disc = qb * qb - 4 * qa * qc;
    if (disc < 0) return true;
    const Real q = Real(-0.5) * (qb + std::copysign(std::sqrt(disc), qb));
    const Real t1 = q / qa;
    if (inside(t1) && !(p(t1) > 0)) return false;
    if (q != 0) {
        const Real t2 = qc / q;
        if (inside(t2) && !(p(t2) > 0)) return false;
    }
    return true;
}

}  // namespace

Sl3Result projectToSL3Scale(const Mat3& M) {
    Sl3Result r;
    r.matrix = M;
    const Real det = M.determinant();
    if (!(det > 0)) {
        r.reason = Sl3Failure::kNonPositiveDet;
        return r;
    }
    r.f = Real(1) / std::cbrt(det);
    r.matrix = M * r.f;
    r.ok = true;
    return r;
}

Eq82Roots eq82Roots(const Mat3& M) {
    const Cubic p = deformationCubic(M);
    Eq82Roots roots;
    auto add = [&](Real f) {
        if (f != 0 && std::isfinite(f)) roots.f[roots.count++] = f;
    };
    const Real scale = std::max({std::abs(p.a), std::abs(p.b), std::abs(p.c)});
    if (scale == 0) return roots;  // D = 0 (or nilpotent-like): only f = 0
    if (std::abs(p.a) <= Real(1e-14) * scale) {
        // linear: b f + c = 0
        if (std::abs(p.b) > Real(1e-14) * scale) add(-p.c / p.b);
    } else {
        const Real disc = p.b * p.b - 4 * p.a * p.c;
        if (disc >= 0) {
            const Real q = Real(-0.5) * (p.b + std::copysign(std::sqrt(disc), p.b));
            add(q / p.a);
            if (q != 0) add(p.c / q);
        }
    }
    if (roots.count == 2 && std::abs(roots.f[1]) < std::abs(roots.f[0])) std::swap(roots.f[0], roots.f[1]);
    return roots;
}

Sl3Result projectToSL3Deformation(const Mat3& M) {
    Sl3Result r;
    r.matrix = M;
    const Real det = M.determinant();
    if (!(det > 0)) {
        r.reason = Sl3Failure::kNonPositiveDet;
        return r;
    }
    if (std::abs(det - 1) <= Real(1e-15)) {
        r.ok = true;
        return r;
    }
    const Eq82Roots roots = eq82Roots(M);
    if (roots.count == 0) {
        r.reason = Sl3Failure::kNoRealRoot;
        return r;
    }
    const Cubic p = deformationCubic(M);
    for (int i = 0; i < roots.count; ++i) {
        const Real f = roots.f[i];
        if (!pathStaysPositive(p, f)) continue;
        r.f = f;
        r.matrix = Mat3::Identity() + f * (M - Mat3::Identity());
        r.ok = true;
        return r;
    }
    r.reason = Sl3Failure::kInverts;
    return r;
}

namespace {

/// Root of f on [a, b] with f(a) < 0 < f(b) by Newton steps kept inside the shrinking bracket
/// (bisection when a step leaves it). `fdf(x, f, df)` evaluates f and f'. Stops when |f| is at
/// round-off or a step is below `tol` (absolute, in x). Returns the root; `iterations` counts
/// evaluations.
template <typename F>
Real bracketedNewton(F fdf, Real a, Real b, Real x, Real tol, int& iterations) {
    for (iterations = 1; iterations <= 200; ++iterations) {
        Real f = 0, df = 0;
        fdf(x, f, df);
        if (std::abs(f) <= Real(2e-16)) return x;  // ln(product) at round-off
        (f < 0 ? a : b) = x;
        Real next = std::isfinite(df) && df != 0 ? x - f / df : Real(0.5) * (a + b);
        if (!(next >= a && next <= b)) next = Real(0.5) * (a + b);  // NaN-safe
        if (std::abs(next - x) <= tol || b - a <= tol) return next;
        x = next;
    }
    return x;
}

}  // namespace

Sl3Result projectToSL3Nearest(const Mat3& M) {
    Sl3Result r;
    r.matrix = M;
    const Real det = M.determinant();
    if (!(det > 0)) {
        r.reason = Sl3Failure::kNonPositiveDet;
        return r;
    }
    if (det == 1) {
        r.ok = true;
        r.f = 0;
        return r;
    }
    // M = U diag(s) V^T with U, V rotations (det M > 0: flip the last column of both if the
    // SVD returned reflections; s stays non-negative, decreasing, s[2] the smallest).
    const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 U = svd.matrixU(), V = svd.matrixV();
    const Vec3 s = svd.singularValues();
    if (U.determinant() < 0) {
        U.col(2) = -U.col(2);
        V.col(2) = -V.col(2);
    }
    // Stationary points: t_i (t_i - s_i) = lambda for every i, t_i = (s_i ± sqrt(s_i^2 + 4 lambda))/2.
    // Main branch (all +): g(lambda) = sum ln t_i is increasing on [lo, inf), lo = -s_3^2 / 4, with
    // g(0) = ln det M; it has the root iff g(lo) <= 0.
    const Real lo = -Real(0.25) * s[2] * s[2];
    auto plusRoot = [&](Real lambda, int i, Real& root) {
        root = std::sqrt(std::max(Real(0), s[i] * s[i] + 4 * lambda));
        return Real(0.5) * (s[i] + root);
    };
    auto g = [&](Real lambda, Real& value, Real& slope) {
        value = 0;
        slope = 0;
        for (int i = 0; i < 3; ++i) {
            Real root = 0;
            const Real ti = plusRoot(lambda, i, root);
            value += std::log(ti);
            // At lambda = lo the smallest root is 0 and the slope is infinite (no division: the
            // existence check g(lo) evaluates there).
            slope += root > 0 ? Real(1) / (ti * root) : std::numeric_limits<Real>::infinity();
        }
    };
    Vec3 t;
    Real gLo = 0, unused = 0;
    g(lo, gLo, unused);
    if (det < 1 || gLo <= 0) {
        Real a = lo, b = 0;
        if (det < 1) {  // the root is above 0: grow the bracket until g > 0
            a = 0;
            b = s[0] * s[0];
            Real gb = 0;
            for (g(b, gb, unused); gb <= 0; g(b, gb, unused)) b *= 4;
        }
        const Real lambda = bracketedNewton(g, a, b, det < 1 ? a : b, Real(1e-15) * s[0] * s[0], r.iterations);
        for (int i = 0; i < 3; ++i) {
            Real root = 0;
            t[i] = plusRoot(lambda, i, root);
        }
        r.f = lambda;
    } else {
        // Volume errors of order 100% or more (g(lo) > 0): the smallest singular value takes the
        // other branch. Parametrised by t_3 in (0, s_3/2]: lambda = t_3 (t_3 - s_3); the
        // product runs from 0 to exp(g(lo)) > 1, so bisection-safe Newton finds the root.
        auto h = [&](Real t3, Real& value, Real& slope) {
            const Real lambda = t3 * (t3 - s[2]);
            value = std::log(t3);
            Real sum = 0;
            for (int i = 0; i < 2; ++i) {
                Real root = 0;
                const Real ti = plusRoot(lambda, i, root);
                value += std::log(ti);
                sum += Real(1) / (ti * root);
            }
            slope = Real(1) / t3 + (2 * t3 - s[2]) * sum;
        };
        const Real t3 =
            bracketedNewton(h, Real(0), Real(0.5) * s[2], Real(0.25) * s[2], Real(1e-15) * s[2], r.iterations);
        const Real lambda = t3 * (t3 - s[2]);
        for (int i = 0; i < 2; ++i) {
            Real root = 0;
            t[i] = plusRoot(lambda, i, root);
        }
        t[2] = t3;
        r.f = lambda;
    }
    r.matrix = U * t.asDiagonal() * V.transpose();
    r.ok = std::abs(r.matrix.determinant() - 1) <= Real(1e-13);
    if (!r.ok) {
        r.matrix = M;
        r.reason = Sl3Failure::kNotConverged;
    }
    return r;
}

Sl3Result projectToSL3(const Mat3& M) {
    Sl3Result r = projectToSL3Nearest(M);
    if (r.ok || r.reason == Sl3Failure::kNonPositiveDet) return r;
    return projectToSL3Scale(M);
}

}  // namespace dgv
