#include "collide/gln_exact.hpp"

#include "base/check.hpp"
#include "base/cpu.hpp"
#include "base/parallel.hpp"

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace dgv {
namespace {

// ---- the scalar pack: four doubles, lane by lane ----------------------------------------------
namespace scalar {

struct Pack {
    double v[4];
};
inline std::uint64_t bitsOf(double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
}
inline double fromBits(std::uint64_t b) {
    double x;
    std::memcpy(&x, &b, sizeof x);
    return x;
}
template <typename F>
inline Pack map2(const Pack& a, const Pack& b, F f) {
    Pack r;
    for (int l = 0; l < 4; ++l) r.v[l] = f(a.v[l], b.v[l]);
    return r;
}
inline Pack ld(const double* p) { return {{p[0], p[1], p[2], p[3]}}; }
inline void st(double* p, const Pack& a) {
    for (int l = 0; l < 4; ++l) p[l] = a.v[l];
}
inline Pack set1(double x) { return {{x, x, x, x}}; }
inline Pack add(const Pack& a, const Pack& b) {
    return map2(a, b, [](double x, double y) { return x + y; });
}
inline Pack sub(const Pack& a, const Pack& b) {
    return map2(a, b, [](double x, double y) { return x - y; });
}
inline Pack mul(const Pack& a, const Pack& b) {
    return map2(a, b, [](double x, double y) { return x * y; });
}
inline Pack dvd(const Pack& a, const Pack& b) {
    return map2(a, b, [](double x, double y) { return x / y; });
}
inline Pack sqr(const Pack& a) {
    Pack r;
    for (int l = 0; l < 4; ++l) r.v[l] = std::sqrt(a.v[l]);
    return r;
}
// _mm256_max_pd semantics: a > b ? a : b.
inline Pack mx(const Pack& a, const Pack& b) {
    return map2(a, b, [](double x, double y) { return x > y ? x : y; });
}
inline Pack bits2(const Pack& a, const Pack& b, std::uint64_t (*f)(std::uint64_t, std::uint64_t)) {
    Pack r;
    for (int l = 0; l < 4; ++l) r.v[l] = fromBits(f(bitsOf(a.v[l]), bitsOf(b.v[l])));
    return r;
}
inline Pack band(const Pack& a, const Pack& b) {
    return bits2(a, b, [](std::uint64_t x, std::uint64_t y) { return x & y; });
}
inline Pack bor(const Pack& a, const Pack& b) {
    return bits2(a, b, [](std::uint64_t x, std::uint64_t y) { return x | y; });
}
inline Pack bxor(const Pack& a, const Pack& b) {
    return bits2(a, b, [](std::uint64_t x, std::uint64_t y) { return x ^ y; });
}
// _mm256_andnot_pd semantics: (~a) & b.
inline Pack bandnot(const Pack& a, const Pack& b) {
    return bits2(a, b, [](std::uint64_t x, std::uint64_t y) { return ~x & y; });
}
inline Pack ab(const Pack& a) { return bandnot(set1(-0.0), a); }
template <typename F>
inline Pack cmp(const Pack& a, const Pack& b, F f) {
    Pack r;
    for (int l = 0; l < 4; ++l) r.v[l] = fromBits(f(a.v[l], b.v[l]) ? ~std::uint64_t(0) : 0);
    return r;
}
inline Pack ge(const Pack& a, const Pack& b) {
    return cmp(a, b, [](double x, double y) { return x >= y; });
}
inline Pack le(const Pack& a, const Pack& b) {
    return cmp(a, b, [](double x, double y) { return x <= y; });
}
inline Pack lt(const Pack& a, const Pack& b) {
    return cmp(a, b, [](double x, double y) { return x < y; });
}
inline Pack eq(const Pack& a, const Pack& b) {
    return cmp(a, b, [](double x, double y) { return x == y; });
}
// _mm256_blendv_pd semantics: b where the sign bit of m is set, else a.
inline Pack blend(const Pack& a, const Pack& b, const Pack& m) {
    Pack r;
    for (int l = 0; l < 4; ++l) r.v[l] = (bitsOf(m.v[l]) >> 63) ? b.v[l] : a.v[l];
    return r;
}
// 2^-e for m in [2^e, 2^(e+1)): (0x7FE << 52) − (exponent bits of m), as integers.
inline Pack normScale(const Pack& m) {
    Pack r;
    for (int l = 0; l < 4; ++l) r.v[l] = fromBits(0x7FE0000000000000ull - (bitsOf(m.v[l]) & 0x7FF0000000000000ull));
    return r;
}

#include "collide/gln_kernel.inc"

}  // namespace scalar

// ---- the AVX2 pack ----------------------------------------------------------------------------
// GCC takes the target from the pragma; clang ignores it and needs the attribute on every
// function of the region (the helpers below are always_inline into AVX2 code).
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
namespace avx2 {

struct Pack {
    __m256d v;
};
#define DGV_AVX inline __attribute__((always_inline))
DGV_AVX Pack ld(const double* p) { return {_mm256_loadu_pd(p)}; }
DGV_AVX void st(double* p, const Pack& a) { _mm256_storeu_pd(p, a.v); }
DGV_AVX Pack set1(double x) { return {_mm256_set1_pd(x)}; }
DGV_AVX Pack add(const Pack& a, const Pack& b) { return {_mm256_add_pd(a.v, b.v)}; }
DGV_AVX Pack sub(const Pack& a, const Pack& b) { return {_mm256_sub_pd(a.v, b.v)}; }
DGV_AVX Pack mul(const Pack& a, const Pack& b) { return {_mm256_mul_pd(a.v, b.v)}; }
DGV_AVX Pack dvd(const Pack& a, const Pack& b) { return {_mm256_div_pd(a.v, b.v)}; }
DGV_AVX Pack sqr(const Pack& a) { return {_mm256_sqrt_pd(a.v)}; }
DGV_AVX Pack mx(const Pack& a, const Pack& b) { return {_mm256_max_pd(a.v, b.v)}; }
DGV_AVX Pack band(const Pack& a, const Pack& b) { return {_mm256_and_pd(a.v, b.v)}; }
DGV_AVX Pack bor(const Pack& a, const Pack& b) { return {_mm256_or_pd(a.v, b.v)}; }
DGV_AVX Pack bxor(const Pack& a, const Pack& b) { return {_mm256_xor_pd(a.v, b.v)}; }
DGV_AVX Pack bandnot(const Pack& a, const Pack& b) { return {_mm256_andnot_pd(a.v, b.v)}; }
DGV_AVX Pack ab(const Pack& a) { return {_mm256_andnot_pd(_mm256_set1_pd(-0.0), a.v)}; }
DGV_AVX Pack ge(const Pack& a, const Pack& b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ)}; }
DGV_AVX Pack le(const Pack& a, const Pack& b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_LE_OQ)}; }
DGV_AVX Pack lt(const Pack& a, const Pack& b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ)}; }
DGV_AVX Pack eq(const Pack& a, const Pack& b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_EQ_OQ)}; }
DGV_AVX Pack blend(const Pack& a, const Pack& b, const Pack& m) { return {_mm256_blendv_pd(a.v, b.v, m.v)}; }
DGV_AVX Pack normScale(const Pack& m) {
    const __m256i e = _mm256_and_si256(_mm256_castpd_si256(m.v), _mm256_set1_epi64x(0x7FF0000000000000ll));
    return {_mm256_castsi256_pd(_mm256_sub_epi64(_mm256_set1_epi64x(0x7FE0000000000000ll), e))};
}
#undef DGV_AVX

#include "collide/gln_kernel.inc"

}  // namespace avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

bool useAvx2(GlnKernel k) {
    if (k == GlnKernel::Scalar) return false;
    if (k == GlnKernel::Avx2) {
        DGV_CHECK(glnAvx2Available());
        return true;
    }
    return glnAvx2Available();
}

constexpr double kTwoPi = 2 * M_PI;

}  // namespace

bool glnAvx2Available() { return cpuHasAvx2(); }

GlnSum& GlnSum::operator+=(const GlnSum& o) {
    halfAngle += o.halfAngle;
    bound += o.bound;
    absHalfAngle += o.absHalfAngle;
    pairs += o.pairs;
    intersections += o.intersections;
    illConditioned += o.illConditioned;
    return *this;
}

Real segmentPairSolidAngle(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, bool* intersect) {
    using L = long double;
    auto v = [](const Vec3& x, const Vec3& y) {
        return std::array<L, 3>{L(x[0]) - L(y[0]), L(x[1]) - L(y[1]), L(x[2]) - L(y[2])};
    };
    auto dot = [](const std::array<L, 3>& x, const std::array<L, 3>& y) {
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    };
    const auto a = v(q0, p0), b = v(q0, p1), c = v(q1, p1), d = v(q1, p0), e1 = v(p1, p0), e2 = v(q1, q0);
    const std::array<L, 3> k = {e2[1] * e1[2] - e2[2] * e1[1], e2[2] * e1[0] - e2[0] * e1[2],
                                e2[0] * e1[1] - e2[1] * e1[0]};
    const L T = dot(a, k);
    const L na = std::sqrt(dot(a, a)), nb = std::sqrt(dot(b, b)), nc = std::sqrt(dot(c, c)), nd = std::sqrt(dot(d, d));
    const L N1 = na * nb * nc + dot(a, b) * nc + dot(b, c) * na + dot(c, a) * nb;
    const L N2 = na * nc * nd + dot(c, d) * na + dot(d, a) * nc + dot(a, c) * nd;
    const bool touch = T == 0 && (N1 <= 0 || N2 <= 0);
    if (intersect) *intersect = touch;
    if (touch) return 0;
    return static_cast<Real>(2 * (std::atan2(T, N1) + std::atan2(T, N2)));
}

CurveSoA toSoA(const ClosedCurve& curve, Real scale) {
    CurveSoA s;
    const std::size_t n = curve.size();
    s.x.resize(n + 1);
    s.y.resize(n + 1);
    s.z.resize(n + 1);
    s.len.resize(n);
    for (std::size_t i = 0; i <= n; ++i) {
        const Vec3& p = curve[i % n];
        s.x[i] = p.x() * scale;
        s.y[i] = p.y() * scale;
        s.z[i] = p.z() * scale;
    }
    for (std::size_t i = 0; i < n; ++i) {
        const double dx = s.x[i + 1] - s.x[i], dy = s.y[i + 1] - s.y[i], dz = s.z[i + 1] - s.z[i];
        s.len[i] = std::sqrt(dx * dx + dy * dy + dz * dz);
    }
    return s;
}

Real unitScale(const ClosedCurve& a, const ClosedCurve& b) {
    Real m = 0;
    for (const ClosedCurve* c : {&a, &b})
        for (const Vec3& p : *c) m = std::max(m, p.cwiseAbs().maxCoeff());
    if (!(m > 0) || !std::isfinite(m)) return 1;
    int e = 0;
    std::frexp(m, &e);  // m = f·2^e with f in [0.5, 1)
    return std::ldexp(1.0, -e);
}

GlnSum glnTile(const CurveSoA& a, Index i0, Index i1, const CurveSoA& b, Index j0, Index j1, GlnKernel kernel) {
    DGV_CHECK(0 <= i0 && i0 <= i1 && i1 <= a.segments());
    DGV_CHECK(0 <= j0 && j0 <= j1 && j1 <= b.segments());
    if (i0 == i1 || j0 == j1) return {};
    return useAvx2(kernel) ? avx2::tileKernel(a, i0, i1, b, j0, j1) : scalar::tileKernel(a, i0, i1, b, j0, j1);
}

GlnSum glnTileCareful(const CurveSoA& A, Index i0, Index i1, const CurveSoA& B, Index j0, Index j1) {
    using L = long double;
    const L u = 0x1p-64L;
    GlnSum out;
    for (Index i = i0; i < i1; ++i) {
        const std::size_t si = static_cast<std::size_t>(i);
        const L p0[3] = {A.x[si], A.y[si], A.z[si]}, p1[3] = {A.x[si + 1], A.y[si + 1], A.z[si + 1]};
        const L e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        const L len1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
        for (Index j = j0; j < j1; ++j) {
            const std::size_t sj = static_cast<std::size_t>(j);
            const L q0[3] = {B.x[sj], B.y[sj], B.z[sj]}, q1[3] = {B.x[sj + 1], B.y[sj + 1], B.z[sj + 1]};
            L a[3], b[3], c[3], d[3], e2[3];
            for (int k = 0; k < 3; ++k) {
                a[k] = q0[k] - p0[k];
                b[k] = q0[k] - p1[k];
                c[k] = q1[k] - p1[k];
                d[k] = q1[k] - p0[k];
                e2[k] = q1[k] - q0[k];
            }
            auto dot = [](const L* x, const L* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
            const L kx = e2[1] * e1[2] - e2[2] * e1[1], ky = e2[2] * e1[0] - e2[0] * e1[2],
                    kz = e2[0] * e1[1] - e2[1] * e1[0];
            const L T = a[0] * kx + a[1] * ky + a[2] * kz;
            const L na = std::sqrt(dot(a, a)), nb = std::sqrt(dot(b, b)), nc = std::sqrt(dot(c, c)),
                    nd = std::sqrt(dot(d, d));
            const L len2 = std::sqrt(dot(e2, e2));
            const L abc = na * nb * nc, acd = na * nc * nd;
            const L N1 = abc + dot(a, b) * nc + dot(b, c) * na + dot(c, a) * nb;
            const L N2 = acd + dot(c, d) * na + dot(d, a) * nc + dot(c, a) * nd;
            ++out.pairs;
            if (T == 0 && (N1 <= 0 || N2 <= 0)) {
                ++out.intersections;
                continue;
            }
            const L dT = 16 * u * na * len1 * len2, s1 = dT + 64 * u * abc, s2 = dT + 64 * u * acd;
            const L z1 = N1 * N1 + T * T, z2 = N2 * N2 + T * T;
            if (4 * s1 * s1 >= z1 || 4 * s2 * s2 >= z2) {
                ++out.illConditioned;
                out.bound += M_PI;
                continue;
            }
            const L aT = std::abs(T);
            const L e =
                2 * ((std::abs(N1) * dT + aT * 64 * u * abc) / z1 + (std::abs(N2) * dT + aT * 64 * u * acd) / z2);
            const L half = std::atan2(T, N1) + std::atan2(T, N2);
            out.halfAngle += static_cast<double>(half);
            out.absHalfAngle += static_cast<double>(std::abs(half));
            // atan2l, the sum and the rounding to double: a few ulps of π in long double, plus
            // the rounding of each term to double (accounted in toLinkValue through absHalfAngle).
            out.bound += static_cast<double>(e + 8 * u * M_PI);
        }
    }
    return out;
}

GlnSum glnDirectSum(const CurveSoA& a, const CurveSoA& b, GlnKernel kernel) {
    const Index n = a.segments(), m = b.segments();
    constexpr Index kRows = 64, kCols = 512;
    const Index rowTiles = (n + kRows - 1) / kRows, colTiles = (m + kCols - 1) / kCols;
    return parallelReduce<GlnSum>(
        rowTiles * colTiles, GlnSum{},
        [&](GlnSum& acc, Index t) {
            const Index r = t / colTiles, c = t % colTiles;
            const Index i0 = r * kRows, i1 = std::min(n, i0 + kRows);
            const Index j0 = c * kCols, j1 = std::min(m, j0 + kCols);
            GlnSum s = glnTile(a, i0, i1, b, j0, j1, kernel);
            if (s.illConditioned > 0) s = glnTileCareful(a, i0, i1, b, j0, j1);
            acc += s;
        },
        [](GlnSum x, const GlnSum& y) { return x += y; }, 1);
}

LinkValue toLinkValue(const GlnSum& s) {
    LinkValue v;
    v.raw = s.halfAngle / kTwoPi;
    // Per pair: the complex products z1·z2 and w·z (≤ 3u each in angle) and the final atan2
    // (2u·π per lane and chunk). Summation: a tree of additions of depth K ≤ (lane chunks per
    // tile ≤ pairs/1024 + 1) + (4 lanes per column pass) + (tiles combined), bounded by
    // pairs/128 + 2^20; its error is at most K·u·Σ|terms| (Higham, ch. 4).
    const double u = 0x1p-53;
    const double perPair = 8 * u * static_cast<double>(s.pairs);
    const double depth = static_cast<double>(s.pairs) / 128 + 0x1p20;
    const double summation = 1.01 * depth * u * s.absHalfAngle;
    v.bound = (s.bound + perPair + summation) / kTwoPi + u * std::abs(v.raw) * 4;
    return v;
}

}  // namespace dgv
