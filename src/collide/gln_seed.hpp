#pragma once
/// @file gln_seed.hpp
/// @brief The seed's own numerical Gauss linking number (eqs 84-89 and the notes' listing
/// `gln_segmented_compute`), kept for the notes' figures 1-4 and for comparison with the exact
/// sum (gln_exact.hpp). Not certified: its error depends on `tolerance` (docs/gln.md).
///
/// As in the listing: each curve is re-sampled at parameter steps dp = tolerance·(domain)/50
/// (so 50/tolerance chords per curve, whatever its vertex count), and for every chord pair
/// G_kl (eq 88) is integrated in closed form along the chord of curve 2 (eq 89) and by a
/// Riemann sum of step ds = 0.02·tolerance along the chord of curve 1, with the listing's own
/// loop `for (s = 0; s <= 1; s += ds)` and weight ds; GLN = Σ (Δ1 × Δ2)·(γ1^k − γ2^l) G_kl /
/// (4·3.14159265) (eq 87, with the listing's constant for π).
///
/// A closed polyline of n vertices is the degree-1 curve with parameter domain [0, n], vertex k
/// at parameter k (Maya's uniform knots). Where dgv departs from the listing, on purpose:
///  - sample parameters are k·dp (not accumulated), and the chain is closed at the end of the
///    domain when the last sample falls short of it (the listing's accumulating loop drops the
///    closing chord, e.g. for 256 segments at tolerance 1, leaving an open curve);
///  - the inner loop restarts at γ2(start) (the listing carries v2minus over, which equals
///    γ2(start) only when the closing sample is reached);
///  - a sample of curve 1 lying on the line of a chord of curve 2 (4ac − b² ≤ 0 in eq 89, a
///    division by zero in the listing) is skipped: there (Δ1 × Δ2)·(γ1 − γ2) vanishes anyway.

#include "base/types.hpp"
#include "collide/gln_exact.hpp"

namespace dgv {

struct SeedGln {
    Real gln = 0;       ///< the listing's value (not rounded)
    Index chordsA = 0;  ///< chords of the re-sampled curve 1
    Index chordsB = 0;
    Index samples = 0;  ///< Riemann samples per chord pair (along curve 1)
};

/// The listing's GLN of two closed polylines (>= 3 vertices each). tolerance > 0; large values
/// (> 50/3) leave fewer than 3 chords and a meaningless value.
SeedGln glnSeed(const ClosedCurve& a, const ClosedCurve& b, Real tolerance);

/// The point of the closed polyline at parameter p in [0, n] (vertex k at p = k).
Vec3 polylinePointAt(const ClosedCurve& curve, Real p);

}  // namespace dgv
