#pragma once
/// @file gln_farfield.hpp
/// @brief The certified linking number of two closed polylines (eq 83): exact closed-form
/// pairs near, second-order multipoles far (bvh.hpp), every part with a rigorous error bound,
/// and refinement until the rounded integer is proved.
///
/// The exact Gauss integral of two closed polylines that do not touch is an integer, so once
/// |raw − k| + bound < 1/2 the answer is k. linkingNumber() tries the far-field sum with
/// opening ratio θ, then θ/2, θ/4 ..., and finally the direct sum over all pairs; it reports
/// "uncertain" only when even the direct sum cannot decide (the curves come within rounding
/// distance of each other), and "intersect" when a segment pair touches (T = 0, N ≤ 0).

#include "base/types.hpp"
#include "collide/bvh.hpp"
#include "collide/gln_exact.hpp"

#include <cmath>
#include <functional>
#include <string>

namespace dgv {

/// The far-field sum for opening ratio theta: node pairs with (ρ_a + ρ_b) < θ·D use the
/// multipole, leaf pairs that are not separated run the exact kernel (glnTile). Parallel and
/// deterministic.
struct FarFieldSum {
    double farValue = 0;        ///< Σ multipole values (lk units)
    double farBound = 0;        ///< Σ their truncation bounds (lk units)
    GlnSum near;                ///< the exact pairs
    Index farPairs = 0;         ///< node pairs evaluated by multipole
    Index nearTiles = 0;        ///< leaf pairs evaluated exactly
    bool nearEvaluated = true;  ///< false: farBound exceeded maxFarBound, the near field was skipped
    int rounds = 0;             ///< glnAdaptiveSum: refinement rounds taken
    Real smallestTheta = 1;     ///< glnAdaptiveSum: the smallest opening ratio a far pair was accepted at
};
/// `maxFarBound`: when the far field's bound alone exceeds it (so the sum could not certify),
/// the near field is not evaluated (the driver then tries a smaller θ at little cost).
FarFieldSum glnFarFieldSum(const CurveSoA& a, const CurveBvh& ta, const CurveSoA& b, const CurveBvh& tb, Real theta,
                           GlnKernel kernel = GlnKernel::Auto, double maxFarBound = HUGE_VAL);

struct GlnSettings {
    GlnKernel kernel = GlnKernel::Auto;
    bool farField = true;                ///< false: always the direct sum
    Real theta = 0.5;                    ///< first opening ratio, in (0, 1)
    int refinements = 8;                 ///< far-field passes at θ, θ/2, ... before the direct sum; a
                                         ///< pass whose far bound alone is over 0.45 skips its near field
    Index directPairs = Index(1) << 23;  ///< at most this many pairs: direct sum at once
    int leafSize = 16;                   ///< segments per BVH leaf
    /// Refine the far field where its bound is (glnAdaptiveSum) before the passes at uniform θ,
    /// which remain the fallback when it cannot certify.
    bool adaptive = true;
    double budget = 0.45;     ///< adaptive: the far bound at which the sum is first tried
    int adaptiveRounds = 12;  ///< adaptive: refinement rounds at most
};

enum class GlnStatus { Certified, Intersect, Uncertain };

struct GlnResult {
    GlnStatus status = GlnStatus::Certified;
    long long linking = 0;  ///< the certified integer (Certified only)
    double raw = 0;         ///< Σ Ω / 4π as computed (near exact + far multipole)
    double bound = 0;       ///< |raw − exact integral| ≤ bound
    Index segmentsA = 0, segmentsB = 0;
    Index pairsExact = 0;     ///< segment pairs evaluated in closed form (last pass)
    Index farPairs = 0;       ///< node pairs evaluated by multipole (last pass)
    Index intersections = 0;  ///< touching segment pairs found
    int passes = 0;           ///< evaluations made (far-field passes + direct)
    double theta = 0;         ///< opening ratio of the deciding pass; 0: direct sum
    bool culled = false;      ///< the curves' bounding boxes are disjoint: lk = 0 with no sum
    bool avx2 = false;        ///< the AVX2 kernel ran
    std::string method;       ///< "bounding boxes disjoint", "direct", "far field (theta = ...)"
};

/// The far-field sum refined where its bound is (docs/gln.md, "Adaptive refinement"): node
/// pairs accepted at θ, then, round by round, every far pair whose bound is over its even share
/// of half the target opened again at half the ratio it was accepted at. When the far bound is
/// at most the target (first `budget`), the near leaf pairs found since the last try are summed
/// exactly (each once: refining the far field never touches them) and `done` is asked; if it
/// declines, the target halves and refinement goes on, for at most `maxRounds` rounds. Returns
/// the last sum tried (nearEvaluated false: none was). Parallel and deterministic.
FarFieldSum glnAdaptiveSum(const CurveSoA& a, const CurveBvh& ta, const CurveSoA& b, const CurveBvh& tb, Real theta,
                           double budget, const std::function<bool(const FarFieldSum&)>& done,
                           GlnKernel kernel = GlnKernel::Auto, int maxRounds = 12);

/// The certified linking number. Curves need at least 3 vertices (checked).
GlnResult linkingNumber(const ClosedCurve& a, const ClosedCurve& b, const GlnSettings& settings = {});

}  // namespace dgv
