// Resampling deformed lattices onto a world grid (resample.hpp; docs/vdb.md, "How the world grids are resampled").
//
// Each lattice cell is the trilinear image x(s), s in [0,1]^3, of its 8 corners.
// A world voxel (centre p, size vs) takes from cell c the coverage
//     cov_c(p) = prod_a  max(0, min(vs/2, d0_a) + min(vs/2, d1_a)) / vs,
// where s = x^-1(p) (Newton from the cell's affine approximation) and d0_a = s_a / |grad s_a|,
// d1_a = (1 - s_a) / |grad s_a| are the first-order distances from p to the cell's two faces
// across axis a: the separable box filter of the cell, exact for an undeformed cell. Cells do
// not overlap, so the voxel's coverage of the object is the SUM over cells (clamped to 1); on a
// face shared by two cells the two overlaps add up to one voxel, hence no seams, and the
// integral of density equals the object's volume up to second-order terms. vel, rest and
// contact are the coverage-weighted means of the cells' trilinear interpolants.
// Parallel over 8^3 blocks: each block reads the cells overlapping it in increasing cell order
// and owns its voxels, so the result does not depend on the thread count.

#include "deform/resample.hpp"

#include "base/cpu.hpp"
#include "base/parallel.hpp"

#include <tbb/parallel_sort.h>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>

namespace dgv {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr int kLeafDim = kResampleBlockDim;
constexpr int kLeafVoxels = kResampleBlockVoxels;

/// The trilinear map of one cell in monomial form,
/// x(s) = a0 + a1 s0 + a2 s1 + a3 s2 + a4 s0 s1 + a5 s0 s2 + a6 s1 s2 + a7 s0 s1 s2.
template <typename T>
std::array<T, 8> monomials(const std::array<T, 8>& X) {
    return {X[0],
            X[1] - X[0],
            X[2] - X[0],
            X[4] - X[0],
            X[3] - X[1] - X[2] + X[0],
            X[5] - X[1] - X[4] + X[0],
            X[6] - X[2] - X[4] + X[0],
            X[7] - X[6] - X[5] - X[3] + X[4] + X[2] + X[1] - X[0]};
}

/// evalMonomials for vectors, in scalars.
inline Vec3 evalVec(const std::array<Vec3, 8>& a, const Vec3& s) {
    const Real s0 = s[0], s1 = s[1], s2 = s[2], s01 = s0 * s1, s02 = s0 * s2, s12 = s1 * s2, s012 = s01 * s2;
    Vec3 r;
    for (int q = 0; q < 3; ++q)
        r[q] = a[0][q] + a[1][q] * s0 + a[2][q] * s1 + a[3][q] * s2 + a[4][q] * s01 + a[5][q] * s02 + a[6][q] * s12 +
               a[7][q] * s012;
    return r;
}

template <typename T>
T evalMonomials(const std::array<T, 8>& a, const Vec3& s) {
    return a[0] + a[1] * s[0] + a[2] * s[1] + a[3] * s[2] + a[4] * (s[0] * s[1]) + a[5] * (s[0] * s[2]) +
           a[6] * (s[1] * s[2]) + a[7] * (s[0] * s[1] * s[2]);
}

Mat3 jacobian(const std::array<Vec3, 8>& a, const Vec3& s) {
    Mat3 J;
    J.col(0) = a[1] + a[4] * s[1] + a[5] * s[2] + a[7] * (s[1] * s[2]);
    J.col(1) = a[2] + a[4] * s[0] + a[6] * s[2] + a[7] * (s[0] * s[2]);
    J.col(2) = a[3] + a[5] * s[0] + a[6] * s[1] + a[7] * (s[0] * s[1]);
    return J;
}

/// Inverse of J when det J > tiny * scale^3 (a right-handed, non-degenerate cell); false else.
bool invertPositive(const Mat3& J, Real scale, Mat3& inv) {
    const Vec3 c0 = J.col(1).cross(J.col(2)), c1 = J.col(2).cross(J.col(0)), c2 = J.col(0).cross(J.col(1));
    const Real det = J.col(0).dot(c0);
    if (!(det > 1e-12 * scale * scale * scale)) return false;
    inv.row(0) = c0.transpose() / det;
    inv.row(1) = c1.transpose() / det;
    inv.row(2) = c2.transpose() / det;
    return true;
}

struct CellMap {
    std::array<Vec3, 8> x;   // position monomials
    std::array<Vec3, 8> v;   // velocity monomials
    std::array<Real, 8> k;   // contact monomials
    Mat3 centreInverse;      // J(1/2)^-1
    Vec3 centre;             // x(1/2)
    Vec3 restLowest;         // rest position of the lowest corner
    Real h = 1;              // lattice spacing
    Vec3 margin;             // prefilter margin per axis, in s units
    Eigen::Vector3i lo, hi;  // world voxel index range to visit (inclusive)
    bool valid = false;      // centre Jacobian invertible and positive
    Real acceptStep = 0;     // Newton stops after a step this small (s units), see solveCell
};

/// A solved voxel: s = x^-1(p), and |grad s_a|^2 = |row a of J^-1|^2 with J at the last Newton
/// iterate before s.
struct InverseSolve {
    Vec3 s;
    Vec3 g2;
};

/// Newton's method for x(s) = p from sol.s (the prediction), written out in scalars: each step
/// evaluates x and J together and inverts J by cofactors. Quadratic convergence: after a step
/// of size d the error is about K d^2, K = |J^-1| |second derivatives of x| (the cell's
/// `acceptStep` is 1e-6 / sqrt(K) capped at 1e-4), so stopping after a step below acceptStep
/// leaves an error below ~1e-12 in s. Returns false for a Jacobian with det <= detMin (inverted or
/// degenerate cell) or no convergence in 12 steps. s is kept within [-1, 2]^3.
inline bool solveCell(const CellMap& m, const Vec3& p, Real detMin, InverseSolve& sol) {
    const std::array<Vec3, 8>& a = m.x;
    Real s0 = sol.s[0], s1 = sol.s[1], s2 = sol.s[2];
    for (int it = 0; it < 12; ++it) {
        const Real s01 = s0 * s1, s02 = s0 * s2, s12 = s1 * s2, s012 = s01 * s2;
        Real r[3], c0[3], c1[3], c2[3];  // residual x(s) - p; Jacobian columns
        for (int q = 0; q < 3; ++q) {
            r[q] = a[0][q] + a[1][q] * s0 + a[2][q] * s1 + a[3][q] * s2 + a[4][q] * s01 + a[5][q] * s02 +
                   a[6][q] * s12 + a[7][q] * s012 - p[q];
            c0[q] = a[1][q] + a[4][q] * s1 + a[5][q] * s2 + a[7][q] * s12;
            c1[q] = a[2][q] + a[4][q] * s0 + a[6][q] * s2 + a[7][q] * s02;
            c2[q] = a[3][q] + a[5][q] * s0 + a[6][q] * s1 + a[7][q] * s01;
        }
        // rows of J^-1: (c1 x c2, c2 x c0, c0 x c1) / det
        const Real r0x = c1[1] * c2[2] - c1[2] * c2[1], r0y = c1[2] * c2[0] - c1[0] * c2[2],
                   r0z = c1[0] * c2[1] - c1[1] * c2[0];
        const Real det = c0[0] * r0x + c0[1] * r0y + c0[2] * r0z;
        if (!(det > detMin)) return false;
        const Real r1x = c2[1] * c0[2] - c2[2] * c0[1], r1y = c2[2] * c0[0] - c2[0] * c0[2],
                   r1z = c2[0] * c0[1] - c2[1] * c0[0];
        const Real r2x = c0[1] * c1[2] - c0[2] * c1[1], r2y = c0[2] * c1[0] - c0[0] * c1[2],
                   r2z = c0[0] * c1[1] - c0[1] * c1[0];
        const Real id = 1 / det;
        const Real d0 = (r0x * r[0] + r0y * r[1] + r0z * r[2]) * id;
        const Real d1 = (r1x * r[0] + r1y * r[1] + r1z * r[2]) * id;
        const Real d2 = (r2x * r[0] + r2y * r[1] + r2z * r[2]) * id;
        s0 = std::min(Real(2), std::max(Real(-1), s0 - d0));
        s1 = std::min(Real(2), std::max(Real(-1), s1 - d1));
        s2 = std::min(Real(2), std::max(Real(-1), s2 - d2));
        if (std::max(std::abs(d0), std::max(std::abs(d1), std::abs(d2))) < m.acceptStep) {
            sol.s = Vec3(s0, s1, s2);
            sol.g2 = Vec3(r0x * r0x + r0y * r0y + r0z * r0z, r1x * r1x + r1y * r1y + r1z * r1z,
                          r2x * r2x + r2y * r2y + r2z * r2z) *
                     (id * id);
            return true;
        }
    }
    return false;
}

/// The voxel's coverage by the cell: the separable box filter with first-order face distances
/// (|grad s_a|^2 = g2_a, the squared rows of J^-1). In s units, with t = |grad s_a| hv (half a
/// voxel), the overlap along axis a is min(t, s_a) + min(t, 1 - s_a) out of 2t; a voxel at least
/// t inside both faces is whole. (The batched kernel computes the same, lane-wise.)
inline Real coverage(const Vec3& s, const Vec3& g2, Real hv) {
    Real c = 1;
    for (int a = 0; a < 3; ++a) {
        const Real t2 = g2[a] * (hv * hv), oneMinus = 1 - s[a], u = std::min(s[a], oneMinus);
        if (u >= 0 && u * u >= t2) continue;
        const Real tg = std::sqrt(t2);
        const Real ov = std::min(tg, s[a]) + std::min(tg, oneMinus);
        c = ov <= 0 ? 0 : c * std::min(Real(1), ov / (tg + tg));
    }
    return c;
}

// ---- batched Newton (SoA, 2, 4 or 8 lanes) ----------------------------------------------------
// The candidates of one (cell, leaf block) pair are solved together: each starts from the cell's
// affine guess s = 1/2 + J(1/2)^-1 (p - x(1/2)) and takes kBatchSteps Newton steps with no
// branches, 2 voxels at a time in SSE2 registers (any x86-64), 4 in AVX2 registers or 8 in
// AVX-512 registers where the CPU has them (GCC vector extensions; the same IEEE operations
// either way, no FMA, so the same bits; tested). The kernel is bound by the latency of its long
// dependency chain (two Newton steps, a division each, then three square roots and divisions
// for the coverage), so wider registers pay even where, as on AMD Zen 4, a 512-bit operation
// takes two 256-bit passes: 8 lanes took about 0.37 s where 4 took 0.50 s in the benchmark. (An
// 8-lane type compiled for AVX2 alone, two registers per value, was 3x slower: GCC splits it
// badly.) A lane whose last step was not below the cell's acceptStep goes on in solveCell; one
// that met a Jacobian with det <= detMin is unresolved, as in solveCell.
constexpr int kLanes = 8;
constexpr int kBatchSteps = 2;
constexpr int kBatchMax = kLeafVoxels + kLanes;

struct CandidateBatch {
    alignas(64) double p[3][kBatchMax];
    alignas(64) double s[3][kBatchMax];
    alignas(64) std::int64_t state[kBatchMax];  // 1 converged, 0 not yet, -1 degenerate Jacobian
    // coverage c (0 below 1e-9 and for lanes with state <= 0) and the c-weighted values
    alignas(64) double cov[kBatchMax];
    alignas(64) double vel[3][kBatchMax];
    alignas(64) double rest[3][kBatchMax];
    alignas(64) double con[kBatchMax];
    int at[kBatchMax];  // offset in the leaf block
    int n = 0;
};

/// One leaf block's coverage-weighted sums, per voxel (the offset in the block).
struct BlockSums {
    double cov[kLeafVoxels];
    double vel[kLeafVoxels][3];
    double rest[kLeafVoxels][3];
    double con[kLeafVoxels];
};

using V2 = double __attribute__((vector_size(16)));  // SSE2: any x86-64
using M2 = std::int64_t __attribute__((vector_size(16)));
using V4 = double __attribute__((vector_size(32)));  // AVX2
using M4 = std::int64_t __attribute__((vector_size(32)));
using V8 = double __attribute__((vector_size(64)));  // AVX-512
using M8 = std::int64_t __attribute__((vector_size(64)));

#define DGV_UNROLL2 _Pragma("GCC unroll 2")
#define DGV_UNROLL3 _Pragma("GCC unroll 3")
#define DGV_NEWTON_BATCH_BODY(V, M)                                                                                   \
    const std::array<Vec3, 8>& a = m.x;                                                                               \
    const V zero = V{}, one = zero + 1., lowS = one * -1., highS = one * 2.;                                          \
    M pending = M{};                                                                                                  \
    for (int i0 = 0; i0 < b.n; i0 += int(sizeof(V) / sizeof(double))) {                                               \
        V p[3], s[3];                                                                                                 \
        DGV_UNROLL3 for (int q = 0; q < 3; ++q) std::memcpy(&p[q], &b.p[q][i0], sizeof(V));                           \
        DGV_UNROLL3 for (int r = 0; r < 3; ++r) {                                                                     \
            s[r] = one * 0.5;                                                                                         \
            DGV_UNROLL3 for (int q = 0; q < 3; ++q) s[r] += m.centreInverse(r, q) * (p[q] - m.centre[q]);             \
        }                                                                                                             \
        M bad = M{};                                                                                                  \
        V dmax = one, id = one, r0[3], r1[3], r2[3];                                                                  \
        DGV_UNROLL2 for (int it = 0; it < kBatchSteps; ++it) {                                                        \
            const V s01 = s[0] * s[1], s02 = s[0] * s[2], s12 = s[1] * s[2], s012 = s01 * s[2];                       \
            V res[3], c0[3], c1[3], c2[3];                                                                            \
            DGV_UNROLL3 for (int q = 0; q < 3; ++q) {                                                                 \
                res[q] = a[0][q] + a[1][q] * s[0] + a[2][q] * s[1] + a[3][q] * s[2] + a[4][q] * s01 + a[5][q] * s02 + \
                         a[6][q] * s12 + a[7][q] * s012 - p[q];                                                       \
                c0[q] = a[1][q] + a[4][q] * s[1] + a[5][q] * s[2] + a[7][q] * s12;                                    \
                c1[q] = a[2][q] + a[4][q] * s[0] + a[6][q] * s[2] + a[7][q] * s02;                                    \
                c2[q] = a[3][q] + a[5][q] * s[0] + a[6][q] * s[1] + a[7][q] * s01;                                    \
            }                                                                                                         \
            r0[0] = c1[1] * c2[2] - c1[2] * c2[1], r0[1] = c1[2] * c2[0] - c1[0] * c2[2];                             \
            r0[2] = c1[0] * c2[1] - c1[1] * c2[0];                                                                    \
            const V det = c0[0] * r0[0] + c0[1] * r0[1] + c0[2] * r0[2];                                              \
            bad |= ~(det > detMin);                                                                                   \
            r1[0] = c2[1] * c0[2] - c2[2] * c0[1], r1[1] = c2[2] * c0[0] - c2[0] * c0[2];                             \
            r1[2] = c2[0] * c0[1] - c2[1] * c0[0];                                                                    \
            r2[0] = c0[1] * c1[2] - c0[2] * c1[1], r2[1] = c0[2] * c1[0] - c0[0] * c1[2];                             \
            r2[2] = c0[0] * c1[1] - c0[1] * c1[0];                                                                    \
            id = one / (bad ? one : det);                                                                             \
            const V d0 = (r0[0] * res[0] + r0[1] * res[1] + r0[2] * res[2]) * id;                                     \
            const V d1 = (r1[0] * res[0] + r1[1] * res[1] + r1[2] * res[2]) * id;                                     \
            const V d2 = (r2[0] * res[0] + r2[1] * res[1] + r2[2] * res[2]) * id;                                     \
            const V n0 = s[0] - d0, n1 = s[1] - d1, n2 = s[2] - d2;                                                   \
            s[0] = n0 < lowS ? lowS : (n0 > highS ? highS : n0);                                                      \
            s[1] = n1 < lowS ? lowS : (n1 > highS ? highS : n1);                                                      \
            s[2] = n2 < lowS ? lowS : (n2 > highS ? highS : n2);                                                      \
            const V a0 = d0 < 0 ? -d0 : d0, a1 = d1 < 0 ? -d1 : d1, a2 = d2 < 0 ? -d2 : d2;                           \
            const V m01 = a0 > a1 ? a0 : a1;                                                                          \
            dmax = m01 > a2 ? m01 : a2;                                                                               \
        }                                                                                                             \
        const V id2 = id * id;                                                                                        \
        const V g0 = (r0[0] * r0[0] + r0[1] * r0[1] + r0[2] * r0[2]) * id2;                                           \
        const V g1 = (r1[0] * r1[0] + r1[1] * r1[1] + r1[2] * r1[2]) * id2;                                           \
        const V g2 = (r2[0] * r2[0] + r2[1] * r2[1] + r2[2] * r2[2]) * id2;                                           \
        const M done = dmax < m.acceptStep;                                                                           \
        const M state = bad ? M{} - 1 : (done ? M{} + 1 : M{});                                                       \
        pending |= ~done | bad;                                                                                       \
        DGV_UNROLL3 for (int q = 0; q < 3; ++q) std::memcpy(&b.s[q][i0], &s[q], sizeof(V));                           \
        std::memcpy(&b.state[i0], &state, sizeof(M));                                                                 \
        /* the coverage (as coverage(), lane-wise) and the weighted values */                                         \
        const V gg[3] = {g0, g1, g2};                                                                                 \
        V c = one;                                                                                                    \
        DGV_UNROLL3 for (int q = 0; q < 3; ++q) {                                                                     \
            const V t2 = gg[q] * (hv * hv), oneMinus = one - s[q];                                                    \
            const V u = s[q] < oneMinus ? s[q] : oneMinus;                                                            \
            const M whole = (u >= 0) & (u * u >= t2);                                                                 \
            V tg = t2;                                                                                                \
            VSQRT(tg);                                                                                                \
            const V ov = (tg < s[q] ? tg : s[q]) + (tg < oneMinus ? tg : oneMinus);                                   \
            const V f = ov / (tg + tg);                                                                               \
            c = whole ? c : (ov <= 0 ? zero : c * (f < one ? f : one));                                               \
        }                                                                                                             \
        /* weight 0 (so sums may add every lane) below 1e-9 and where the lane is not solved here */                  \
        c = (done & ~bad & (c > 1e-9)) ? c : zero;                                                                    \
        std::memcpy(&b.cov[i0], &c, sizeof(V));                                                                       \
        const V s01 = s[0] * s[1], s02 = s[0] * s[2], s12 = s[1] * s[2], s012 = s01 * s[2];                           \
        DGV_UNROLL3 for (int q = 0; q < 3; ++q) {                                                                     \
            const V v = m.v[0][q] + m.v[1][q] * s[0] + m.v[2][q] * s[1] + m.v[3][q] * s[2] + m.v[4][q] * s01 +        \
                        m.v[5][q] * s02 + m.v[6][q] * s12 + m.v[7][q] * s012;                                         \
            const V cv = c * v, cr = c * (m.restLowest[q] + m.h * s[q]);                                              \
            std::memcpy(&b.vel[q][i0], &cv, sizeof(V));                                                               \
            std::memcpy(&b.rest[q][i0], &cr, sizeof(V));                                                              \
        }                                                                                                             \
        V sc[3];                                                                                                      \
        DGV_UNROLL3 for (int q = 0; q < 3; ++q) sc[q] = s[q] < 0 ? zero : (s[q] > one ? one : s[q]);                  \
        const V k = m.k[0] + m.k[1] * sc[0] + m.k[2] * sc[1] + m.k[3] * sc[2] + m.k[4] * (sc[0] * sc[1]) +            \
                    m.k[5] * (sc[0] * sc[2]) + m.k[6] * (sc[1] * sc[2]) + m.k[7] * (sc[0] * sc[1] * sc[2]);           \
        const V ck = c * k;                                                                                           \
        std::memcpy(&b.con[i0], &ck, sizeof(V));                                                                      \
    }                                                                                                                 \
    bool any = false;                                                                                                 \
    for (std::size_t q = 0; q < sizeof(M) / sizeof(std::int64_t); ++q) any |= pending[q] != 0;                        \
    return any;

inline void sqrtGeneric(V2& x) {
#if defined(__SSE2__)
    __m128d v;
    std::memcpy(&v, &x, sizeof v);
    v = _mm_sqrt_pd(v);
    std::memcpy(&x, &v, sizeof v);
#else
    for (int i = 0; i < 2; ++i) x[i] = std::sqrt(x[i]);
#endif
}

__attribute__((noinline)) bool newtonBatchGeneric(const CellMap& m, double detMin, double hv, CandidateBatch& b) {
#define VSQRT sqrtGeneric
    DGV_NEWTON_BATCH_BODY(V2, M2)
#undef VSQRT
}
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DGV_RESAMPLE_WIDE_KERNELS 1
__attribute__((target("avx2"))) inline void sqrtAvx2(V4& x) {
    __m256d v;
    std::memcpy(&v, &x, sizeof v);
    v = _mm256_sqrt_pd(v);
    std::memcpy(&x, &v, sizeof v);
}
__attribute__((noinline, target("avx2"))) bool newtonBatchAvx2(const CellMap& m, double detMin, double hv,
                                                               CandidateBatch& b) {
#define VSQRT sqrtAvx2
    DGV_NEWTON_BATCH_BODY(V4, M4)
#undef VSQRT
}
__attribute__((target("avx512f"))) inline void sqrtAvx512(V8& x) {
    __m512d v;
    std::memcpy(&v, &x, sizeof v);
    v = _mm512_mask_sqrt_pd(v, __mmask8(0xff), v);  // all lanes; _mm512_sqrt_pd trips GCC 12's -Wmaybe-uninitialized
    std::memcpy(&x, &v, sizeof v);
}
__attribute__((noinline, target("avx512f"))) bool newtonBatchAvx512(const CellMap& m, double detMin, double hv,
                                                                    CandidateBatch& b) {
#define VSQRT sqrtAvx512
    DGV_NEWTON_BATCH_BODY(V8, M8)
#undef VSQRT
}
#endif
#undef DGV_NEWTON_BATCH_BODY
#undef DGV_UNROLL2
#undef DGV_UNROLL3

// ---- candidates of one (cell, leaf block) pair ------------------------------------------------
/// The voxels of the box lo..hi (inside one leaf block) whose affine guess s = sLo + (i - lo) step
/// + (j - lo) stepJ + (k - lo) stepK lies within the cell's margin, -margin <= s_a <= 1 + margin
/// on every axis: outside it the coverage is provably 0 (see the margins in resample).
struct CandidateRows {
    Vec3 step, stepJ, stepK;  // ds per +1 in i, j, k
    Vec3 sLo;                 // the affine guess at voxel lo
    Vec3 margin;
    Eigen::Vector3i lo, hi, base;
    Vec3 origin;
    Real vs;
};

/// Fills b (p, at, n) with the candidates, row by row: on an axis with step_a != 0 a row's
/// candidates are i - lo in [(A_a - s_a) / step_a, (B_a - s_a) / step_a].
void gatherCandidatesScalar(const CandidateRows& r, CandidateBatch& b) {
    Vec3 A, B, inv;
    bool flat[3];
    for (int a = 0; a < 3; ++a) {
        flat[a] = !(std::abs(r.step[a]) > 1e-300);
        inv[a] = flat[a] ? 0 : 1 / r.step[a];
        A[a] = r.step[a] > 0 ? -r.margin[a] : 1 + r.margin[a];
        B[a] = r.step[a] > 0 ? 1 + r.margin[a] : -r.margin[a];
    }
    int n = 0;  // a local, not b.n: stores to b.at may alias b.n
    for (int kz = r.lo[2]; kz <= r.hi[2]; ++kz)
        for (int jy = r.lo[1]; jy <= r.hi[1]; ++jy) {
            const Vec3 s0 = r.sLo + Real(jy - r.lo[1]) * r.stepJ + Real(kz - r.lo[2]) * r.stepK;
            Real tmin = 0, tmax = r.hi[0] - r.lo[0];
            for (int a = 0; a < 3; ++a) {
                if (flat[a]) {
                    if (s0[a] < -r.margin[a] || s0[a] > 1 + r.margin[a]) tmax = -1;
                } else {
                    tmin = std::max(tmin, (A[a] - s0[a]) * inv[a]);
                    tmax = std::min(tmax, (B[a] - s0[a]) * inv[a]);
                }
            }
            if (!(tmin <= tmax)) continue;
            // 0 <= tmin <= tmax <= 7: ceil and floor by truncation (std::ceil is a call without
            // SSE4.1)
            int t0 = static_cast<int>(tmin);
            t0 += Real(t0) < tmin ? 1 : 0;
            const int i0 = r.lo[0] + t0, i1 = r.lo[0] + static_cast<int>(tmax);
            const double p1 = r.origin[1] + r.vs * jy, p2 = r.origin[2] + r.vs * kz;
            const int atRow = (jy - r.base[1]) * kLeafDim + (kz - r.base[2]);
            for (int ix = i0; ix <= i1; ++ix, ++n) {
                b.p[0][n] = r.origin[0] + r.vs * ix;
                b.p[1][n] = p1;
                b.p[2][n] = p2;
                b.at[n] = (ix - r.base[0]) * kLeafDim * kLeafDim + atRow;
            }
        }
    b.n = n;
}

#ifdef DGV_RESAMPLE_WIDE_KERNELS
/// gatherCandidatesScalar with a row in one zmm register: the guess tested lane by lane, the
/// passing lanes packed by vcompress and stored unconditionally (no branch per row). The test
/// differs from the scalar one only by rounding, at the margin, where the coverage is 0: the
/// same voxels receive the same values (the kernels' bit-equality test covers it).
__attribute__((noinline, noclone, target("avx512f,popcnt"))) void gatherCandidatesAvx512(const CandidateRows& r,
                                                                                         CandidateBatch& b) {
    const __m512d lane = _mm512_set_pd(7, 6, 5, 4, 3, 2, 1, 0);
    const int len = r.hi[0] - r.lo[0];  // lanes 0..len are in the box
    const __mmask8 inBox = static_cast<__mmask8>((2u << len) - 1);
    // (scalars and named registers: arrays of __m512d end up on the stack)
    const __m512d step0 = _mm512_mul_pd(lane, _mm512_set1_pd(r.step[0]));
    const __m512d step1 = _mm512_mul_pd(lane, _mm512_set1_pd(r.step[1]));
    const __m512d step2 = _mm512_mul_pd(lane, _mm512_set1_pd(r.step[2]));
    const __m512d low0 = _mm512_set1_pd(-r.margin[0]), high0 = _mm512_set1_pd(1 + r.margin[0]);
    const __m512d low1 = _mm512_set1_pd(-r.margin[1]), high1 = _mm512_set1_pd(1 + r.margin[1]);
    const __m512d low2 = _mm512_set1_pd(-r.margin[2]), high2 = _mm512_set1_pd(1 + r.margin[2]);
    // p_x = origin_x + vs i, as the scalar code rounds it
    const __m512d px =
        _mm512_add_pd(_mm512_set1_pd(r.origin[0]),
                      _mm512_mul_pd(_mm512_set1_pd(r.vs), _mm512_add_pd(_mm512_set1_pd(double(r.lo[0])), lane)));
    static_assert(kLeafDim * kLeafDim == 64, "at = 64 i + 8 j + k");
    const __m512i laneAt =
        _mm512_set_epi32(0, 0, 0, 0, 0, 0, 0, 0, 7 * 64, 6 * 64, 5 * 64, 4 * 64, 3 * 64, 2 * 64, 64, 0);
    const double sLo0 = r.sLo[0], sLo1 = r.sLo[1], sLo2 = r.sLo[2];
    const double sJ0 = r.stepJ[0], sJ1 = r.stepJ[1], sJ2 = r.stepJ[2];
    const double sK0 = r.stepK[0], sK1 = r.stepK[1], sK2 = r.stepK[2];
    const double ox1 = r.origin[1], ox2 = r.origin[2], vs = r.vs;
    const int lo1 = r.lo[1], hi1 = r.hi[1], lo2 = r.lo[2], hi2 = r.hi[2];
    const int at0 = (r.lo[0] - r.base[0]) * kLeafDim * kLeafDim - r.base[1] * kLeafDim - r.base[2];
    double* const p0 = b.p[0];
    double* const p1 = b.p[1];
    double* const p2 = b.p[2];
    int* const atOut = b.at;
    int n = 0;
    for (int kz = lo2; kz <= hi2; ++kz) {
        const double dk = double(kz - lo2);
        const __m512d pz = _mm512_set1_pd(ox2 + vs * kz);
        for (int jy = lo1; jy <= hi1; ++jy) {
            const double dj = double(jy - lo1);
            // as the scalar code: sLo + dj stepJ + dk stepK
            const __m512d s0 = _mm512_add_pd(_mm512_set1_pd(sLo0 + dj * sJ0 + dk * sK0), step0);
            const __m512d s1 = _mm512_add_pd(_mm512_set1_pd(sLo1 + dj * sJ1 + dk * sK1), step1);
            const __m512d s2 = _mm512_add_pd(_mm512_set1_pd(sLo2 + dj * sJ2 + dk * sK2), step2);
            __mmask8 keep = _mm512_mask_cmp_pd_mask(inBox, s0, low0, _CMP_GE_OQ);
            keep = _mm512_mask_cmp_pd_mask(keep, s0, high0, _CMP_LE_OQ);
            keep = _mm512_mask_cmp_pd_mask(keep, s1, low1, _CMP_GE_OQ);
            keep = _mm512_mask_cmp_pd_mask(keep, s1, high1, _CMP_LE_OQ);
            keep = _mm512_mask_cmp_pd_mask(keep, s2, low2, _CMP_GE_OQ);
            keep = _mm512_mask_cmp_pd_mask(keep, s2, high2, _CMP_LE_OQ);
            // stored whatever keep is (no branch per row); n + 8 <= kBatchMax because n counts
            // distinct voxels of the block, at most kLeafVoxels
            _mm512_storeu_pd(p0 + n, _mm512_maskz_compress_pd(keep, px));
            _mm512_storeu_pd(p1 + n, _mm512_set1_pd(ox1 + vs * jy));
            _mm512_storeu_pd(p2 + n, pz);
            const __m512i at = _mm512_add_epi32(_mm512_set1_epi32(at0 + jy * kLeafDim + kz), laneAt);
            _mm512_mask_storeu_epi32(
                atOut + n, __mmask16(0xff),
                _mm512_maskz_compress_epi32(keep, at));  // (a cast to __m256i trips GCC 12's -Wmaybe-uninitialized)
            n += __builtin_popcount(keep);
        }
    }
    b.n = n;
}
#endif

void gatherCandidates(const CandidateRows& r, ResampleKernel kernel, CandidateBatch& b) {
#ifdef DGV_RESAMPLE_WIDE_KERNELS
    if (kernel == ResampleKernel::Avx512) return gatherCandidatesAvx512(r, b);
#else
    (void)kernel;
#endif
    gatherCandidatesScalar(r, b);
}

}  // namespace

ResampleKernel resolveResampleKernel(ResampleKernel asked) {
#ifdef DGV_RESAMPLE_WIDE_KERNELS
    if ((asked == ResampleKernel::Auto || asked == ResampleKernel::Avx512) && cpuHasAvx512f())
        return ResampleKernel::Avx512;
    if (asked != ResampleKernel::Sse2 && cpuHasAvx2()) return ResampleKernel::Avx2;
#endif
    return ResampleKernel::Sse2;
}

namespace {

/// Solves the batch (see DGV_NEWTON_BATCH_BODY); true if some lane is left to solveCell or
/// unresolved (state <= 0: weight 0 in cov, vel, rest, con).
bool newtonBatch(const CellMap& m, double detMin, double hv, ResampleKernel kernel, CandidateBatch& b) {
#ifdef DGV_RESAMPLE_WIDE_KERNELS
    if (kernel == ResampleKernel::Avx512) return newtonBatchAvx512(m, detMin, hv, b);
    if (kernel == ResampleKernel::Avx2) return newtonBatchAvx2(m, detMin, hv, b);
#else
    (void)kernel;
#endif
    return newtonBatchGeneric(m, detMin, hv, b);
}
struct ObjectRefs {
    const ResampleInput* frame;
    Index firstCell;  // global cell id of its cell 0
};

}  // namespace

ResampleReport resampleLattices(const std::vector<ResampleInput>& objects, Real vs, const Vec3& origin,
                                ResampleKernel kernel, ResampleBinning binning,
                                const std::function<void(Index blocks)>& start,
                                const std::function<void(Index block, const ResampledBlock& values)>& sink) {
    ResampleReport report;
    kernel = resolveResampleKernel(kernel);
    auto t = Clock::now();
    // ---- per-cell maps --------------------------------------------------------------------
    std::vector<ObjectRefs> refs;
    Index totalCells = 0;
    for (const ResampleInput& f : objects) {
        refs.push_back({&f, totalCells});
        totalCells += f.cells->size();
    }
    // kept from frame to frame (84 MB in the benchmark): fresh memory would cost ~20k page faults
    // and a serial initialisation a frame; every field a cell's tasks read is set below
    // (the tasks see it through `maps`: a thread_local named in a lambda is the running thread's)
    thread_local std::vector<CellMap> mapsKept;
    std::vector<CellMap>& maps = mapsKept;
    if (maps.size() < static_cast<std::size_t>(totalCells)) maps.resize(static_cast<std::size_t>(totalCells));
    for (std::size_t o = 0; o < refs.size(); ++o) {
        const ResampleInput& f = *refs[o].frame;
        const Index first = refs[o].firstCell;
        parallelFor(
            f.cells->size(),
            [&](Index c) {
                CellMap& m = maps[static_cast<std::size_t>(first + c)];
                const auto& corners = f.cells->corners[static_cast<std::size_t>(c)];
                std::array<Vec3, 8> X, V;
                std::array<Real, 8> K;
                Vec3 bmin = Vec3::Constant(std::numeric_limits<Real>::max()), bmax = -bmin;
                for (int q = 0; q < 8; ++q) {
                    const std::size_t p = static_cast<std::size_t>(corners[static_cast<std::size_t>(q)]);
                    X[static_cast<std::size_t>(q)] = (*f.positions)[p];
                    V[static_cast<std::size_t>(q)] = f.velocities ? (*f.velocities)[p] : Vec3::Zero();
                    K[static_cast<std::size_t>(q)] = (f.contact && (*f.contact)[p]) ? 1.0 : 0.0;
                    bmin = bmin.cwiseMin((*f.positions)[p]);
                    bmax = bmax.cwiseMax((*f.positions)[p]);
                }
                m.x = monomials(X);
                m.v = monomials(V);
                m.k = monomials(K);
                m.h = f.lattice->spacing;
                m.restLowest = f.lattice->originWorld + m.h * f.cells->lowest[static_cast<std::size_t>(c)].cast<Real>();
                const Vec3 half = Vec3::Constant(0.5);
                m.centre = evalMonomials(m.x, half);
                const Real scale = (bmax - bmin).maxCoeff();
                m.valid = scale > 0 && invertPositive(jacobian(m.x, half), scale, m.centreInverse);
                if (!m.valid) {
                    m.lo = Eigen::Vector3i::Zero();
                    m.hi = Eigen::Vector3i::Constant(-1);
                    return;
                }
                // Which voxels can this cell cover? Coverage > 0 needs -t_a < s_a < 1 + t_a on every
                // axis, t_a = |grad s_a| hv (|grad s_a| = |row a of J(s)^-1|). Candidates are chosen
                // by the affine guess s' = 1/2 + J(1/2)^-1 (p - x(1/2)), so the margin around [0,1]
                // must cover t_a and the guess's error. With D = max_a |s_a - 1/2| and the nonlinear
                // monomials a4..a7 (x(s) = x(1/2) + J(1/2)(s - 1/2) + N(s)):
                //   |N(s)| <= (|a4|+|a5|+|a6|) D^2 + |a7| (D^3 + 1.5 D^2),   s - s' = -J(1/2)^-1 N(s),
                //   so |s_a - s'_a| <= |row a of J(1/2)^-1| |N|;
                //   |J(s) - J(1/2)|_F <= sqrt(3) D nonlinear, so E = J(1/2)^-1 (J(s) - J(1/2)) has
                //   |E| <= rho = kNewton sqrt(3) D / 4 <= kNewton / 2 (D <= 1), and
                //   |row a of J(s)^-1| <= |row a of J(1/2)^-1| + rho / (1 - rho) |J(1/2)^-1|_F.
                // These hold for D <= 1, i.e. while t_a <= 1/2: used for kNewton <= 1/2 and a reach
                // below 0.3; more distorted cells keep the old, generous margin (Newton decides).
                const Real nonlinear = m.x[4].norm() + m.x[5].norm() + m.x[6].norm() + 2 * m.x[7].norm();
                const Real kNewton = 4 * m.centreInverse.norm() * nonlinear;  // see solveCell
                const Real hv = 0.5 * vs;
                const Real rho = kNewton / 2;
                // reach_a bounds t_a = |grad s_a| hv: coverage > 0 needs -reach < s_a < 1 + reach
                Vec3 reach;
                Real maxReach = 0;
                for (int a = 0; a < 3; ++a) {
                    reach[a] = hv * (m.centreInverse.row(a).norm() +
                                     (rho < 1 ? rho / (1 - rho) : Real(1e30)) * m.centreInverse.norm());
                    maxReach = std::max(maxReach, reach[a]);
                }
                // world box: the hull of the corners contains the image of the unit cube (trilinear
                // weights are convex); a point with coverage > 0 lies within s_b in [-mu_b, 1 + mu_b]
                // (mu the margin), so x_a is at most sum_b |J_ab(xi)| mu_b beyond the hull, with
                // |J_ab(xi) - J_ab(1/2)| <= sqrt(3) D nonlinear.
                Vec3 pad = Vec3::Constant(vs + 2.25 * nonlinear);
                bool tight = kNewton <= 0.5 && maxReach <= 0.3;
                if (tight) {
                    const Real D = 0.5 + maxReach;
                    const Real nBound = (m.x[4].norm() + m.x[5].norm() + m.x[6].norm()) * D * D +
                                        m.x[7].norm() * (D * D * D + 1.5 * D * D);
                    for (int a = 0; a < 3; ++a)
                        m.margin[a] = reach[a] + 1.01 * m.centreInverse.row(a).norm() * nBound + 1e-9;
                    tight = m.margin.maxCoeff() <= 0.5;  // the bounds above assume |s - 1/2| <= 1
                }
                if (tight) {
                    const Mat3 Jc = jacobian(m.x, half);
                    const Real dJ = std::sqrt(Real(3)) * (0.5 + m.margin.maxCoeff()) * nonlinear;
                    for (int a = 0; a < 3; ++a) {
                        pad[a] = 1e-9 * scale;
                        for (int b2 = 0; b2 < 3; ++b2) pad[a] += (std::abs(Jc(a, b2)) + dJ) * m.margin[b2];
                    }
                } else {
                    for (int a = 0; a < 3; ++a) {
                        const Real g = m.centreInverse.row(a).norm();
                        m.margin[a] = g * hv * 1.5 + g * nonlinear * 2.25 + 1e-9;
                    }
                }
                m.acceptStep = kNewton > 1e-4 ? 1e-6 / std::sqrt(kNewton) : Real(1e-4);
                for (int a = 0; a < 3; ++a) {
                    m.lo[a] = static_cast<int>(std::ceil((bmin[a] - pad[a] - origin[a]) / vs));
                    m.hi[a] = static_cast<int>(std::floor((bmax[a] + pad[a] - origin[a]) / vs));
                }
            },
            256);
    }

    report.cellsSeconds = since(t);
    t = Clock::now();

    // ---- bin cells by leaf block ------------------------------------------------------------
    auto floorDiv = [](int a) { return a >= 0 ? a / kLeafDim : -((-a + kLeafDim - 1) / kLeafDim); };
    constexpr std::int64_t kOff = std::int64_t(1) << 20;
    auto key = [&](int bx, int by, int bz) {
        return (std::uint64_t(bz + kOff) << 42) | (std::uint64_t(by + kOff) << 21) | std::uint64_t(bx + kOff);
    };
    // The (block, cell) pairs grouped by block, blocks in key order and each block's cells in
    // increasing order. By counting where the blocks' bounding box is small enough to index
    // densely (the usual case: 40^3 blocks in the benchmark), by sorting the pairs elsewhere.
    std::vector<std::uint64_t> blockKey;  // per block
    std::vector<std::size_t> blockStart;  // per block, into blockCells; one more at the end
    std::vector<Index> blockCells;
    Eigen::Vector3i bmin = Eigen::Vector3i::Constant(std::numeric_limits<int>::max()), bmax = -bmin;
    for (Index c = 0; c < totalCells; ++c) {
        const CellMap& m = maps[static_cast<std::size_t>(c)];
        if (!m.valid) continue;
        for (int a = 0; a < 3; ++a) {
            bmin[a] = std::min(bmin[a], floorDiv(m.lo[a]));
            bmax[a] = std::max(bmax[a], floorDiv(m.hi[a]));
        }
    }
    const bool anyCell = bmin[0] <= bmax[0];
    const Eigen::Vector3i dims =
        anyCell ? Eigen::Vector3i(bmax - bmin + Eigen::Vector3i::Ones()) : Eigen::Vector3i::Zero();
    const std::int64_t dense = std::int64_t(dims[0]) * dims[1] * dims[2];
    constexpr std::int64_t kDenseMax = std::int64_t(1) << 23;  // 64 MB of counts at most
    auto forBlocks = [&](const CellMap& m, auto&& f) {         // the blocks a cell's voxel box meets
        for (int bz = floorDiv(m.lo[2]); bz <= floorDiv(m.hi[2]); ++bz)
            for (int by = floorDiv(m.lo[1]); by <= floorDiv(m.hi[1]); ++by)
                for (int bx = floorDiv(m.lo[0]); bx <= floorDiv(m.hi[0]); ++bx) f(bx, by, bz);
    };
    if (anyCell && dense <= kDenseMax && binning == ResampleBinning::Auto) {
        // x fastest, then y, then z: the order of key()
        auto denseIndex = [&](int bx, int by, int bz) {
            return (std::size_t(bz - bmin[2]) * std::size_t(dims[1]) + std::size_t(by - bmin[1])) *
                       std::size_t(dims[0]) +
                   std::size_t(bx - bmin[0]);
        };
        std::vector<std::size_t> at(static_cast<std::size_t>(dense) + 1, 0);
        for (Index c = 0; c < totalCells; ++c) {
            const CellMap& m = maps[static_cast<std::size_t>(c)];
            if (m.valid) forBlocks(m, [&](int bx, int by, int bz) { ++at[denseIndex(bx, by, bz) + 1]; });
        }
        for (std::size_t i = 0; i < static_cast<std::size_t>(dense); ++i) {
            if (at[i + 1] > 0) {
                const int bx = int(i % std::size_t(dims[0])) + bmin[0];
                const int by = int(i / std::size_t(dims[0]) % std::size_t(dims[1])) + bmin[1];
                const int bz = int(i / (std::size_t(dims[0]) * std::size_t(dims[1]))) + bmin[2];
                blockKey.push_back(key(bx, by, bz));
                blockStart.push_back(at[i]);
            }
            at[i + 1] += at[i];
        }
        blockStart.push_back(at[static_cast<std::size_t>(dense)]);
        blockCells.resize(at[static_cast<std::size_t>(dense)]);
        for (Index c = 0; c < totalCells; ++c) {  // in cell order: each block's cells ascending
            const CellMap& m = maps[static_cast<std::size_t>(c)];
            if (m.valid) forBlocks(m, [&](int bx, int by, int bz) { blockCells[at[denseIndex(bx, by, bz)]++] = c; });
        }
    } else if (anyCell) {
        std::vector<Index> counts(static_cast<std::size_t>(totalCells) + 1, 0);
        parallelFor(
            totalCells,
            [&](Index c) {
                const CellMap& m = maps[static_cast<std::size_t>(c)];
                if (!m.valid) return;
                Index n = 1;
                for (int a = 0; a < 3; ++a) n *= floorDiv(m.hi[a]) - floorDiv(m.lo[a]) + 1;
                counts[static_cast<std::size_t>(c) + 1] = n;
            },
            1024);
        for (std::size_t i = 1; i < counts.size(); ++i) counts[i] += counts[i - 1];
        std::vector<std::pair<std::uint64_t, Index>> pairs(static_cast<std::size_t>(counts.back()));
        parallelFor(
            totalCells,
            [&](Index c) {
                const CellMap& m = maps[static_cast<std::size_t>(c)];
                if (!m.valid) return;
                std::size_t i = static_cast<std::size_t>(counts[static_cast<std::size_t>(c)]);
                forBlocks(m, [&](int bx, int by, int bz) { pairs[i++] = {key(bx, by, bz), c}; });
            },
            1024);
        tbb::parallel_sort(pairs.begin(), pairs.end());  // (key, cell) pairs are unique: deterministic
        blockCells.resize(pairs.size());
        for (std::size_t i = 0; i < pairs.size(); ++i) {
            if (i == 0 || pairs[i].first != pairs[i - 1].first) {
                blockKey.push_back(pairs[i].first);
                blockStart.push_back(i);
            }
            blockCells[i] = pairs[i].second;
        }
        blockStart.push_back(pairs.size());
    } else {
        blockStart.push_back(0);
    }
    const Index blocks = static_cast<Index>(blockKey.size());

    report.binsSeconds = since(t);
    t = Clock::now();

    // ---- per-block resampling ------------------------------------------------------------------
    struct BlockCounts {
        Index unresolved = 0, slowSolves = 0, candidates = 0;
    };
    std::vector<BlockCounts> counted(static_cast<std::size_t>(blocks));
    start(blocks);
    const Real hv = 0.5 * vs;
    parallelFor(
        blocks,
        [&](Index b) {
            const std::size_t begin = blockStart[static_cast<std::size_t>(b)],
                              end = blockStart[static_cast<std::size_t>(b) + 1];
            const std::uint64_t k = blockKey[static_cast<std::size_t>(b)];
            const int bx = int(std::int64_t(k & ((1u << 21) - 1)) - kOff);
            const int by = int(std::int64_t((k >> 21) & ((1u << 21) - 1)) - kOff);
            const int bz = int(std::int64_t(k >> 42) - kOff);
            const Eigen::Vector3i base(bx * kLeafDim, by * kLeafDim, bz * kLeafDim);
            // The block's sums, zero: the block before cleared each voxel's sums as it read them, in the loop that
            // writes the leaves; a block that did not get there (no active voxel, an exception)
            // leaves them `dirty`.
            thread_local BlockSums sums;  // zero-initialised
            thread_local bool dirty = false;
            if (dirty) std::memset(&sums, 0, sizeof sums);
            dirty = true;
            double* const cov = sums.cov;
            double(*const vel)[3] = sums.vel;
            double(*const rest)[3] = sums.rest;
            double* const con = sums.con;
            Index unresolved = 0, slowSolves = 0, candidates = 0;
            // one batch per thread, not per block: a 64-byte-aligned allocation per block fragments
            // glibc's heap (peak RSS 1.4 GB instead of 0.46 GB in the benchmark)
            thread_local CandidateBatch batch;  // not zeroed
            for (std::size_t e = begin; e < end; ++e) {
                const CellMap& m = maps[static_cast<std::size_t>(blockCells[e])];
                if (e + 1 < end) {  // the next cell's map: 640 bytes, mostly not in cache
                    const char* next =
                        reinterpret_cast<const char*>(&maps[static_cast<std::size_t>(blockCells[e + 1])]);
                    for (std::size_t line = 0; line < sizeof(CellMap); line += 64) __builtin_prefetch(next + line);
                }
                Eigen::Vector3i lo = m.lo.cwiseMax(base),
                                hi = m.hi.cwiseMin(base + Eigen::Vector3i::Constant(kLeafDim - 1));
                if ((lo.array() > hi.array()).any()) continue;
                const Real detMin = 1e-12 * m.h * m.h * m.h;
                const CandidateRows rows{
                    m.centreInverse.col(0) * vs,
                    m.centreInverse.col(1) * vs,
                    m.centreInverse.col(2) * vs,
                    Vec3::Constant(0.5) + m.centreInverse * (origin + vs * lo.cast<Real>() - m.centre),
                    m.margin,
                    lo,
                    hi,
                    base,
                    origin,
                    vs};
                gatherCandidates(rows, kernel, batch);
                if (batch.n == 0) continue;
                const int real = batch.n;
                while (batch.n % kLanes) {  // pad with copies of the last candidate
                    for (int q = 0; q < 3; ++q) batch.p[q][batch.n] = batch.p[q][real - 1];
                    ++batch.n;
                }
                candidates += real;
                const bool pending = newtonBatch(m, detMin, hv, kernel, batch);
                // every lane: those with weight 0 add +-0 to sums that are never -0, i.e. nothing
                for (int e2 = 0; e2 < real; ++e2) {
                    const std::size_t at = static_cast<std::size_t>(batch.at[e2]);
                    cov[at] += batch.cov[e2];
                    for (int q = 0; q < 3; ++q) vel[at][q] += batch.vel[q][e2];
                    for (int q = 0; q < 3; ++q) rest[at][q] += batch.rest[q][e2];
                    con[at] += batch.con[e2];
                }
                if (!pending) continue;
                for (int e2 = 0; e2 < real; ++e2) {
                    if (batch.state[e2] > 0) continue;  // added above
                    const std::size_t at = static_cast<std::size_t>(batch.at[e2]);
                    if (batch.state[e2] < 0) {
                        ++unresolved;
                        continue;
                    }
                    // not converged in kBatchSteps: go on one voxel at a time
                    InverseSolve sol;
                    sol.s = Vec3(batch.s[0][e2], batch.s[1][e2], batch.s[2][e2]);
                    if (!solveCell(m, Vec3(batch.p[0][e2], batch.p[1][e2], batch.p[2][e2]), detMin, sol)) {
                        ++unresolved;
                        continue;
                    }
                    ++slowSolves;
                    const Vec3& s = sol.s;
                    const Real c = coverage(s, sol.g2, hv);
                    if (!(c > 1e-9)) continue;
                    const Vec3 sc = s.cwiseMax(Vec3::Zero()).cwiseMin(Vec3::Ones());  // keeps contact in 0..1
                    const Vec3 cv = c * evalVec(m.v, s);  // extrapolated by < 1/2 voxel outside
                    const Vec3 cr = c * (m.restLowest + m.h * s);
                    cov[at] += c;
                    for (int q = 0; q < 3; ++q) vel[at][q] += cv[q];
                    for (int q = 0; q < 3; ++q) rest[at][q] += cr[q];
                    con[at] += c * evalMonomials(m.k, sc);
                }
            }
            BlockCounts& o = counted[static_cast<std::size_t>(b)];
            o.unresolved = unresolved;
            o.slowSolves = slowSolves;
            o.candidates = candidates;
            // the block's values: covered voxels their means, the others 0
            int active = 0;
            for (int at = 0; at < kLeafVoxels; ++at) active += cov[at] > 0 ? 1 : 0;
            if (active == 0) return;
            thread_local ResampledBlock blk;
            blk.origin = base;
            blk.active = active;
            blk.densitySum = 0;
            for (int at = 0; at < kLeafVoxels; ++at) {
                const std::size_t i = static_cast<std::size_t>(at);
                auto clear = [&] {  // for the next block
                    cov[at] = con[at] = 0;
                    vel[at][0] = vel[at][1] = vel[at][2] = rest[at][0] = rest[at][1] = rest[at][2] = 0;
                };
                if (!(cov[at] > 0)) {
                    blk.covered[i] = 0;
                    blk.velocity[i] = {0.f, 0.f, 0.f};
                    blk.rest[i] = {0.f, 0.f, 0.f};
                    blk.density[i] = blk.contact[i] = 0.f;
                    clear();
                    continue;
                }
                const Real w = 1 / cov[at];
                const Real d = std::min(Real(1), cov[at]);
                blk.covered[i] = 1;
                blk.density[i] = static_cast<float>(d);
                blk.contact[i] = static_cast<float>(std::min(Real(1), con[at] * w));
                blk.velocity[i] = {float(vel[at][0] * w), float(vel[at][1] * w), float(vel[at][2] * w)};
                blk.rest[i] = {float(rest[at][0] * w), float(rest[at][1] * w), float(rest[at][2] * w)};
                blk.densitySum += d;
                clear();
            }
            dirty = false;
            sink(b, blk);
        },
        1);

    report.voxelsSeconds = since(t);
    report.blocks = blocks;
    for (const BlockCounts& o : counted) {
        report.unresolved += o.unresolved;
        report.slowSolves += o.slowSolves;
        report.candidates += o.candidates;
    }
    return report;
}

}  // namespace dgv
