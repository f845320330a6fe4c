#pragma once
/// @file embedding.hpp
/// @brief A lattice deformer: the imported surface mesh is embedded in the material lattice at
/// rest and carried by the lattice as it deforms, so renders keep the mesh's detail whatever
/// the voxel size. Exact for any affine motion of the lattice.
///
/// Rule (docs/math.md, "Embedding"): a vertex whose lattice cell (the 8 grid points around
/// u = (v - originWorld) / h) are all material points is carried trilinearly,
/// v' = sum_k w_k x(corner_k). Any other vertex (near the surface, or up to a few voxels outside
/// the lattice) is anchored to its nearest material point q (Euclidean in u; ties: smallest
/// point id) with offset d = u - u(q) in lattice units, and follows q's frame to second order:
/// v' = x(q) + sum_a x_a(q) d_a + 1/2 sum_ab x_ab(q) d_a d_b (the quadratic term only when
/// `secondOrder`). A vertex more than a voxel from its anchor (a fin or a leg thinner than the
/// lattice resolves, whose voxels were dropped) blends towards the anchor neighbourhood's
/// moving-least-squares affine fit, fully from 2.5 voxels out: one point's frame extrapolated
/// over several voxels amplifies its roughness. All rules reproduce any affine motion exactly.

#include "base/types.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace dgv {

/// Far vertices: the neighbourhood fit starts at kFitFrom voxels from the anchor and takes over
/// fully at kFitFull (a smoothstep in between, so the surface stays continuous).
constexpr Real kFitFrom = 1.5;
constexpr Real kFitFull = 2.5;
constexpr Real kFitRadius = 2.5;  ///< lattice units beyond the anchor's distance, around the vertex

struct MeshEmbedding {
    /// Per vertex: the 8 corner points of its lattice cell and trilinear weights when all 8
    /// corners are material points; otherwise the nearest material point and the offset from
    /// it in lattice units (the vertex then follows that point's tangent frame).
    std::vector<std::array<Index, 8>> corners;
    std::vector<std::array<Real, 8>> weights;  ///< sums to 1 when corners[v][0] != kNoPoint
    std::vector<Index> anchor;                 ///< nearest material point (always valid)
    std::vector<Vec3> offset;                  ///< vertex - x(anchor), lattice units, at rest
    bool secondOrder = true;                   ///< anchored vertices add 1/2 x_ab d_a d_b (Taylor, 2nd order)
    /// Far anchored vertices: v' = (1 - s) anchorRule + s sum_j alpha_j x(p_j), with s = fitBlend[v]
    /// and the pairs (p_j, alpha_j) at fitPoint/fitWeight[fitStart[v] .. fitStart[v+1]). Empty
    /// ranges and s = 0 for every other vertex. sum_j alpha_j = 1 and sum_j alpha_j u(p_j) = u(v).
    std::vector<Real> fitBlend;
    std::vector<Index> fitStart;  ///< #V + 1
    std::vector<Index> fitPoint;
    std::vector<Real> fitWeight;
    /// The fit's derivative in lattice coordinates: ∂v'/∂u = sum_j x(p_j) fitGradient[j]ᵀ over the
    /// same range (sum_j fitGradient[j] = 0, sum_j fitGradient[j] u(p_j)ᵀ = 1): the frame of a
    /// fitted vertex, which the surface check compares its edges with.
    std::vector<Vec3> fitGradient;

    std::size_t size() const { return anchor.size(); }
    /// Whether vertex v is carried trilinearly (else by its anchor's frame).
    bool trilinear(std::size_t v) const { return corners[v][0] != kNoPoint; }
    /// How many vertices follow a neighbourhood fit at all (fitBlend > 0).
    Index fittedVertices() const;
    /// How many vertices lie kFitFull voxels or more from their anchor (parts thinner than the
    /// lattice resolves), whatever rule carries them.
    Index farVertices() const;
};

/// Embeds rest vertices (world units) in the lattice, in parallel. Requires lat.size() > 0.
/// Corners are ordered (di, dj, dk) in {0,1}^3 with index di + 2 dj + 4 dk. The nearest-point
/// search walks cubic shells outward from the nearest grid point and stops once no closer
/// point can exist: O(r^3) for a vertex r voxels from the lattice. The fit of a far vertex is
/// the affine least-squares fit centred on the vertex: the material points within
/// R = d + kFitRadius of it (d its distance to its anchor; reached from the anchor through the
/// 6-neighbour network), weighted (1 - r²/R²)² by their distance r from the vertex, so the fit
/// changes continuously along the surface where anchors change; it is skipped (s = 0) where
/// those points do not spread in 3-D (a one-voxel sheet).
/// fitOutside: every vertex outside the cells follows its neighbourhood's fit wholly (the
/// one-solve step's bodies: a boundary layer pressed onto a collider has rough frames at the
/// lattice scale, which the anchor's frame extrapolates into folds).
MeshEmbedding embedVertices(const Lattice& lat, const std::vector<Vec3>& restVertices, bool fitOutside = false);

/// Deformed vertex positions (world units) from the current state (positions, tangent frames
/// and second derivatives); `vertices` is resized to emb.size(). In parallel.
void deformVertices(const MeshEmbedding& emb, const GeometricState& state, std::vector<Vec3>& vertices);

}  // namespace dgv
