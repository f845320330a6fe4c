#pragma once

#include <limits>
/// @file volume.hpp
/// @brief Exact volumes of the lattice cells and the volume projection (seed eqs 40-44: local
/// volume conservation, applied to the cells of the lattice; docs/math.md, "Cell volumes and
/// the volume projection").
///
/// A cell is a unit cube of the lattice whose 8 corners are all material points. Its shape is
/// the trilinear image of [0,1]^3: x(s) = sum_k w_k(s) x_k, corner k at offset
/// (k & 1, (k >> 1) & 1, (k >> 2) & 1) from the cell's lowest corner u, w_k the trilinear
/// weights. Its volume is the EXACT integral of det(dx/ds) over [0,1]^3 (bilinear faces; a cubic
/// in the corner positions), in closed form: with the cell's coefficient vectors in centred
/// coordinates, V = [b,c,d] + ([b,e,f] - [c,e,g] + [d,f,g]) / 12 (volume.cpp derives it; tested
/// against 5^3-point Gauss-Legendre). Rest cell: h^3; any affine map x -> A x + b scales it by
/// det A (both to round-off); positive for right-handed (non-inverted) cells.

#include "base/types.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <memory>
#include <vector>

namespace dgv {

/// The cells of a lattice, numbered in increasing linear grid index of their lowest corner.
struct LatticeCells {
    std::vector<std::array<Index, 8>> corners;  ///< #C point ids, corner order as above
    std::vector<Vec3i> lowest;                  ///< #C lowest corner u of each cell
    std::vector<Index> cellOfGrid;              ///< lat.dims.prod() entries: cell id or -1
    Vec3i dims = Vec3i::Zero();                 ///< the lattice's grid dims
    Index size() const { return static_cast<Index>(corners.size()); }
};

/// All cells of `lat` (deterministic order; parallel).
LatticeCells buildCells(const Lattice& lat);

/// Exact volume of the trilinear hexahedron with corners x[0..7] (order above), world units^3.
Real hexVolume(const std::array<Vec3, 8>& x);

/// Exact volume and its gradient d V / d x_k (8 vectors, world units^2), from the same closed
/// form (12 cross products and two butterflies: about a tenth of the 2x2x2 Gauss rule's work).
Real hexVolumeGradient(const std::array<Vec3, 8>& x, std::array<Vec3, 8>& gradient);

/// #C exact cell volumes of `positions` (#P, world units).
std::vector<Real> cellVolumes(const LatticeCells& cells, const std::vector<Vec3>& positions);

/// Sum of the cell volumes (deterministic: fixed blocks, combined in order).
Real totalVolume(const LatticeCells& cells, const std::vector<Vec3>& positions);

/// What projectVolumes keeps between calls on the same cells and pins (the dynamics calls it
/// every step): the multigrid hierarchy, built from the first call's normal matrix and reused
/// while the active cells are the same (rebuilt otherwise); and the cells' topology (stencil
/// neighbours, the cells of each point, colours and the normal matrix's pattern), remade when
/// the LatticeCells object, its size or the active cells change. Pass the same object to each call
/// through VolumeProjectionSettings::cache; not shared between concurrent calls.
struct VolumeProjectionCache {
    struct Impl;                 ///< internal (volume.cpp)
    std::shared_ptr<Impl> impl;  ///< empty until a call fills it
    /// The input of the call that built the multigrid held now (its positions on entry and its
    /// pinned flags; empty while none is held). The hierarchy is a function of these alone, so a
    /// state checkpoint saves them and rebuildVolumeProjectionCache makes the same one again.
    std::vector<Vec3> builtFromPositions;
    std::vector<unsigned char> builtFromPinned;
};

struct VolumeProjectionSettings {
    int maxIterations = 8;   ///< Gauss-Newton iterations
    Real tolerance = 1e-12;  ///< stop when max_c |V_c / V0_c - 1| <= tolerance
    /// ... and the body's total volume error |Σ_c (V_c − V0_c)| / Σ_c V0_c (over the
    /// constrainable cells) <= driftTolerance. Cell errors within `tolerance` can share a sign:
    /// a spinning jelly's total drifted to 1.25e-6 with every cell within 1e-5 (docs/math.md,
    /// "Cell volumes and the volume projection"). Infinite: the cells alone decide.
    Real driftTolerance = std::numeric_limits<Real>::infinity();
    Real linearTolerance = 1e-8;     ///< relative residual of each linear solve (CG); the
                                     ///< floor of the adaptive one (adaptiveLinearTolerance)
    int maxLinearIterations = 2000;  ///< CG iterations per Gauss-Newton iteration
    /// Precondition the CG with the multigrid of solve/multigrid.hpp (built on the first
    /// Gauss-Newton iteration's normal matrix, see reuseMultigrid and cache); false: Jacobi, far
    /// more iterations on large lattices.
    bool multigrid = true;
    /// Multigrid aggregates per parity class of the cells (MultigridSettings::parityAggregates):
    /// the checkerboard modes are near-null modes of J J^T (docs/math.md).
    bool parityAggregates = true;
    /// Build the multigrid once per call, from the first iteration's normal matrix, and use it
    /// for the later ones (their matrices differ by the small change of the gradients).
    bool reuseMultigrid = true;
    /// Inexact Gauss-Newton: each linear solve only as accurate as the step can use, relative
    /// residual max(linearTolerance, min(0.5, max(err, tolerance / err))) with err the
    /// current max cell error; false: linearTolerance on every step.
    bool adaptiveLinearTolerance = true;
    /// Nonlinear Gauss-Seidel sweeps over the cells after each Gauss-Newton step (8 colours).
    int localSweeps = 2;
    /// Optional: keeps the multigrid from call to call (setup is most of a call's cost).
    VolumeProjectionCache* cache = nullptr;
    /// #P unit normals, required when some pinned flag is kSlides: such a point moves only in
    /// the plane normal to its normal (a contact point on a collider's surface). The
    /// projection's push then has no net component along that plane, as a frictionless
    /// surface's reaction; a point held in all directions takes one (measured: a jelly resting
    /// on the ground accelerated sideways at 0.04 m/s^2, or with friction sheared its contact
    /// layer until it folded; docs/math.md).
    const std::vector<Vec3>* slideNormals = nullptr;
    /// Optional #P weights w_p > 0 (the points' inverse masses, relative): the step minimises
    /// Σ_p |δx_p|² / w_p instead of Σ_p |δx_p|², so it moves no centre of mass and changes no
    /// momentum (each cell's push sums to zero over its corners, and mass-weighted displacements
    /// are what momentum counts). Empty: all 1.
    const std::vector<Real>* weights = nullptr;
    /// Optional #C multipliers, in and out. In: a prediction of this call's (a dynamic step's
    /// volume correction changes little from step to step: the caller extrapolates the last
    /// ones), applied first as a Gauss-Newton step without a linear solve, dx = −W Jᵀ λ, and
    /// kept only if it lowers the largest cell error; any other size: none. Out: the multipliers
    /// applied in total (the kept prediction plus each Gauss-Newton step's; 0 for inactive cells).
    std::vector<Real>* multipliers = nullptr;
};

/// The pinned flag of a point that slides (VolumeProjectionSettings::slideNormals); 1: fixed.
constexpr unsigned char kSlides = 2;

/// Outcome of projectVolumes. Numerical trouble (no convergence) is reported, not thrown.
struct [[nodiscard]] VolumeProjectionReport {
    bool converged = false;
    int iterations = 0;         ///< Gauss-Newton iterations taken
    int linearIterations = 0;   ///< CG iterations, summed over the Gauss-Newton iterations
    int predicted = 0;          ///< 1 when the caller's predicted multipliers were applied (kept)
    Real maxErrorBefore = 0;    ///< max_c |V_c / V0_c - 1| on entry, over the constrainable cells
    Real maxErrorAfter = 0;     ///< ... on return (cells with all 8 corners pinned are left out:
                                ///< nothing may move them)
    Real driftAfter = 0;        ///< Σ_c (V_c − V0_c) / Σ_c V0_c on return, same cells
    Real maxMove = 0;           ///< largest |x_new - x_old| of a point, world units
    Index unconstrainable = 0;  ///< cells whose 8 corners are all pinned (left out)
};

/// Volume projection: moves the points minimally (least squares, Euclidean) so that every
/// cell's exact volume returns to restVolumes[c]. Gauss-Newton on the #C constraints
/// V_c(x) - V0_c = 0: each step is the minimum-norm solution dx = -J^T (J J^T)^-1 r, with the
/// sparse normal matrix J J^T on the cell-adjacency graph (27-cell stencil) solved by conjugate
/// gradients from zero multipliers, preconditioned by smoothed-aggregation multigrid with parity
/// aggregates (or Jacobi), each only as accurate as the step can use (inexact Gauss-Newton);
/// after each step `localSweeps` nonlinear Gauss-Seidel sweeps over the cells remove localised
/// peaks; it stops when every cell is within `tolerance` and the total within `driftTolerance`.
/// From 3e-2 errors: 2 iterations to 1e-5, 3 to 1e-12 (docs/math.md). Pinned points
/// (pinned[p] == 1; may be empty = none) never move, sliding ones (pinned[p] == kSlides) move only
/// along their plane; cells with all corners fixed are left out (counted in `unconstrainable`).
/// @param[in]     cells        cells of the lattice the positions belong to
/// @param[in]     restVolumes  #C target volumes (> 0), world units^3
/// @param[in]     pinned       #P flags (0 free, 1 fixed, kSlides), or empty
/// @param[in,out] positions    #P world positions, updated in place
/// Deterministic for any thread count.
VolumeProjectionReport projectVolumes(const LatticeCells& cells, const std::vector<Real>& restVolumes,
                                      const std::vector<unsigned char>& pinned, std::vector<Vec3>& positions,
                                      const VolumeProjectionSettings& settings = {});

/// Rebuilds `*settings.cache`'s multigrid from its builtFrom* inputs (a restored checkpoint):
/// one projectVolumes call on a copy of them with these settings (the caller's usual ones), so
/// the hierarchy is the same, bit for bit, as the one built first. Empties the cache when they
/// are empty.
void rebuildVolumeProjectionCache(const LatticeCells& cells, const std::vector<Real>& restVolumes,
                                  const VolumeProjectionSettings& settings);

}  // namespace dgv
