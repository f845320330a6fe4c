#pragma once
/// @file gln_network.hpp
/// @brief GLN collision networks (seed section 5, eqs 90-91): closed loops over a deformable
/// body's surface, loops for a collider, and the contact set R from their linking numbers.
/// docs/gln.md, "GLN networks and the contact set R", gives the layout and its reasons.
///
/// Object loops (built once from the rest lattice, evaluated on the deformed positions):
///  - fine: per boundary lattice point p, the ring through x_p + r·(x_q − x_p) for its boundary
///    26-neighbours q, ordered by angle in p's rest tangent plane (r = fineRadius, a tenth of
///    the way: the ring encloses p and no other lattice point). Interior = {p}.
///  - coarse: per centre of a greedy cover of the boundary (centres coarseSpacing voxels apart),
///    the polygon of midpoints of the boundary points nearest the circle of radius coarseRadius
///    voxels in the centre's rest tangent plane. Interior = the boundary points within the
///    radius (rest).
/// Collider loops ("needles"): for each boundary point p within needleMargin voxels of the
/// collider (or inside it), with s = x_p − φ n its foot on the collider surface (n the unit
/// gradient), the rectangles s − ε n → s − D n → s − D n + W t → s − ε n + W t for t = ±t0,
/// ±n × t0 (t0 a tangent): loops that lie inside the collider. The one on the +t side threads the
/// fine ring of p exactly when the ring's point on the +t side lies deeper than ε inside the
/// collider (likewise −t), so a linked pair means "this part of the surface, within a tenth of a
/// step of p, is inside the collider". Every loop lies inside the collider, so it can
/// only link object loops that themselves enter the collider (docs/gln.md, what this implies for
/// the coarse level).
///
/// R per collider and per step (eqs 90-91, in this order): R = ∅; coarse rings (when enabled):
/// for each, lk = 0 with every collider loop → R −= Interior (eq 91), then |lk| ≥ 1 with some
/// loop → R ∪= Interior (eq 90); fine rings, only those of points in R after the coarse pass
/// (or all, coarse disabled): the same two rules with Interior = {p}. The sign of lk follows
/// the loops' orientations, so |lk| ≥ 1 counts. Pairs whose bounding boxes do not overlap have
/// lk = 0 exactly and are never evaluated (a hierarchy over the collider loops' boxes); the
/// others are evaluated by the certified exact kernel (gln_farfield.hpp); touching or uncertain
/// pairs count as linked.
///
/// Deterministic for any thread count (each ring's result is written to its own slot).

#include "base/types.hpp"
#include "collide/gln_exact.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <functional>
#include <vector>

namespace dgv {

/// A collider's signed distance (negative inside) and its gradient, world units.
using SignedDistance = std::function<Real(const Vec3& x, Vec3* gradient)>;

struct GlnNetworkSettings {
    Real fineRadius = 0.1;      ///< fine ring: fraction of the way from p to each neighbour
    bool coarseToFine = false;  ///< evaluate coarse rings first, fine rings only inside linked ones
    Real coarseRadius = 2;      ///< voxels
    Real coarseSpacing = 1.5;   ///< voxels between coarse centres (greedy cover)
    Real needleDepth = 4;       ///< D, voxels: penetration deeper than this is not seen
    Real needleWidth = 0.5;     ///< W, voxels (between the fine ring radius and the next point)
    Real needleTop = 1e-6;      ///< ε, voxels: depth the surface must exceed to count
    Real needleMargin = 0.5;    ///< voxels: points farther outside the collider get no loop
};

/// One step's figures of a contact-set evaluation.
struct ContactSetReport {
    Index colliderLoops = 0;   ///< needle loops laid
    Index coarseRings = 0;     ///< coarse rings evaluated
    Index coarseLinked = 0;    ///< of which linked
    Index fineRings = 0;       ///< fine rings evaluated
    Index candidatePairs = 0;  ///< ring–loop pairs whose boxes overlap (evaluated exactly)
    Index linkedPairs = 0;     ///< |lk| >= 1
    Index undecidedPairs = 0;  ///< touching or uncertain (counted as linked)
    Index contacts = 0;        ///< |R|
    ContactSetReport& operator+=(const ContactSetReport& o);
};

/// A ring: the lattice points (and, for fine rings, the centre) its vertices are made of.
struct NetworkRing {
    Index centre = 0;             ///< lattice point
    std::vector<Index> points;    ///< ring vertices' lattice points, in tangent-plane order
    std::vector<Index> interior;  ///< Interior(γ): lattice points
};

class GlnNetwork {
public:
    GlnNetwork(const Lattice& lattice, const GlnNetworkSettings& settings = {});

    /// Sets R (#P flags; resized and cleared) to the points in contact with the collider `phi`
    /// at positions x (#P).
    ContactSetReport contactSet(const std::vector<Vec3>& x, const SignedDistance& phi,
                                std::vector<unsigned char>& R) const;

    /// The fine ring of boundary point number k (0..fine().size()-1) at positions x.
    ClosedCurve fineCurve(std::size_t k, const std::vector<Vec3>& x) const;
    /// The coarse ring number k at positions x.
    ClosedCurve coarseCurve(std::size_t k, const std::vector<Vec3>& x) const;
    const std::vector<NetworkRing>& fine() const { return mFine; }
    const std::vector<NetworkRing>& coarse() const { return mCoarse; }
    /// Boundary points (a 6-neighbour missing) without a usable fine ring (never in R).
    Index pointsWithoutRing() const { return mWithoutRing; }
    const GlnNetworkSettings& settings() const { return mSet; }

private:
    const Lattice& mLat;
    GlnNetworkSettings mSet;
    std::vector<NetworkRing> mFine;  ///< one per boundary point with a ring
    std::vector<Index> mFineOf;      ///< #P: index into mFine, or −1
    std::vector<NetworkRing> mCoarse;
    Index mWithoutRing = 0;
};

/// The collider's loops near the body (file comment): four rectangles (±t0, ±n × t0) per listed point
/// within the margin. `owner` (if given) receives the point each loop belongs to.
std::vector<ClosedCurve> needleLoops(const std::vector<Vec3>& x, const std::vector<Index>& points,
                                     const SignedDistance& phi, Real spacing, const GlnNetworkSettings& settings,
                                     std::vector<Index>* owner = nullptr);

/// |lk(a, b)| >= 1 (certified), or the curves touch / the value cannot be certified (counted as
/// linked; *undecided set). Disjoint bounding boxes: false with no sum.
bool loopsLinked(const ClosedCurve& a, const ClosedCurve& b, bool* undecided = nullptr);

}  // namespace dgv
