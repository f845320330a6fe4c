#pragma once
/// @file gln_exact.hpp
/// @brief The Gauss linking number (eq 83) of two closed polylines, exactly: the double integral
/// of eq 87 over one straight segment of each curve has a closed form, the signed solid angle
/// Ω_ij of the parallelogram of directions between the two segments (docs/gln.md, "Exact: the
/// closed form per pair of segments"; the formula at `segmentPairSolidAngle` below), and
/// lk = Σ_ij Ω_ij / 4π. Sign convention of eq 83:
/// lk = 1/4π ∮∮ (r1 − r2)·(dr1 × dr2) / |r1 − r2|³.
///
/// The direct sum is vectorised (AVX2 where the CPU has it, chosen at run time; a scalar build of
/// the same operations otherwise: both give bit-identical results), threaded deterministically
/// (base/parallel.hpp), and returns a rigorous bound on its floating-point error, so the rounded
/// integer can be certified (see GlnSum::bound).

#include "base/types.hpp"

#include <vector>

namespace dgv {

/// A closed polyline: vertices in order; the edge from the last vertex back to the first is
/// implied (do not repeat the first vertex). World units.
using ClosedCurve = std::vector<Vec3>;

/// Ω_ij for segment p0→p1 of curve 1 and q0→q1 of curve 2 (reference scalar form with two
/// atan2, long double): Ω = 2 atan2(T, N1) + 2 atan2(T, N2) with a = q0−p0, b = q0−p1,
/// c = q1−p1, d = q1−p0, T = a·((q1−q0)×(p1−p0)),
/// N1 = |a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|, N2 = |a||c||d| + (c·d)|a| + (d·a)|c| + (a·c)|d|.
/// |Ω| < 2π for segments that do not intersect; 0 for parallel, coplanar or zero-length
/// segments that do not touch. Segments that intersect (T = 0 with N1 ≤ 0 or N2 ≤ 0) return 0
/// and set *intersect (if given).
Real segmentPairSolidAngle(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, bool* intersect = nullptr);

/// Vertices of a closed curve as structure of arrays, with the first vertex repeated at the end
/// (index n), so that segment i runs from vertex i to vertex i + 1 for i in [0, n).
struct CurveSoA {
    std::vector<Real> x, y, z;  ///< n + 1 entries
    std::vector<Real> len;      ///< n segment lengths |v(i+1) − v(i)|
    Index segments() const { return static_cast<Index>(len.size()); }
};

/// `curve` multiplied by `scale` (use a power of two: exact), as arrays.
CurveSoA toSoA(const ClosedCurve& curve, Real scale = 1);

/// The power of two that brings the largest |coordinate| of both curves into [0.5, 1): scaling
/// by it is exact and changes no linking contribution, and keeps every product in the kernel
/// far from overflow and underflow whatever the input's units.
Real unitScale(const ClosedCurve& a, const ClosedCurve& b);

/// A partial sum of Ω/2 over segment pairs.
struct GlnSum {
    double halfAngle = 0;      ///< Σ Ω_ij / 2 (radians); lk = halfAngle / 2π
    double bound = 0;          ///< rigorous bound on |computed − exact| of halfAngle, radians
    double absHalfAngle = 0;   ///< Σ |partial sums| combined (for the summation error bound)
    Index pairs = 0;           ///< segment pairs evaluated
    Index intersections = 0;   ///< pairs with T = 0 and N ≤ 0: the curves touch there
    Index illConditioned = 0;  ///< pairs too close to touching for double precision (bound = π each)

    GlnSum& operator+=(const GlnSum& o);
};

/// Which implementation of the direct kernel runs.
enum class GlnKernel { Auto, Scalar, Avx2 };

/// Whether this CPU runs the AVX2 kernel.
bool glnAvx2Available();

/// Σ Ω_ij / 2 over segments i in [i0, i1) of `a` and j in [j0, j1) of `b` (one tile, one
/// thread). Each pair contributes its own error bound (from the conditioning of T and N; a
/// pair whose error could reach π is counted as ill-conditioned and bounded by π). Pure.
GlnSum glnTile(const CurveSoA& a, Index i0, Index i1, const CurveSoA& b, Index j0, Index j1,
               GlnKernel kernel = GlnKernel::Auto);

/// Same tile in long double with the two-atan2 form: slower, used to re-evaluate tiles in which
/// the fast kernel met ill-conditioned pairs. Its own bound is tighter by 2^11.
GlnSum glnTileCareful(const CurveSoA& a, Index i0, Index i1, const CurveSoA& b, Index j0, Index j1);

/// The whole double sum over all pairs, in parallel tiles (deterministic for any thread
/// count). Tiles with ill-conditioned pairs are re-evaluated by glnTileCareful.
GlnSum glnDirectSum(const CurveSoA& a, const CurveSoA& b, GlnKernel kernel = GlnKernel::Auto);

/// From a sum to a linking number: lk = halfAngle / 2π and its bound, including the bound of
/// the summation itself.
struct LinkValue {
    double raw = 0;    ///< the computed Σ Ω / 4π
    double bound = 0;  ///< |raw − exact| ≤ bound (exact: the true double integral of the polylines)
};
LinkValue toLinkValue(const GlnSum& sum);

}  // namespace dgv
