#pragma once
/// @file surface_check.hpp
/// @brief Is the embedded surface of a deformed body fit to write? The lattice's own checks
/// (cell volumes, inverted cells) do not see the surface the user renders: a vertex carried by
/// its anchor's frame (geom/embedding) can be thrown far out by a bad second derivative while
/// every cell keeps its volume (docs/math.md, "Never a torn frame").
///
/// With F the frame [x_1 x_2 x_3] of a vertex's anchor point divided by the lattice spacing h
/// (the local deformation gradient; F = 1 at rest), a smooth deformation maps a rest edge e0 to
/// about F e0 and a rest normal n0 to a normal along cof(F) n0 = det(F) F⁻ᵀ n0. Two tests, each
/// invariant under rigid motion and silent under any affine motion (which the embedding
/// reproduces exactly):
///  - *flipped triangles*: two triangles sharing an edge whose normals now point more than 120°
///    apart (n̂·n̂' < kFoldCosine) where the frame at the edge predicts them within 90°
///    (cof(F) n0 · cof(F) n0' > 0), both at least kFoldHeight voxels high: the surface has
///    folded over there (both count). A sliver below that height is under what the lattice
///    resolves (measured: in the pole fan of a goo ball spread on the ground, slivers 2e-4 m
///    high, 0.006 voxels, turned over as their two close vertices crossed; invisible in the
///    frames). Folds of a mesh much finer than the lattice are only seen where its triangles
///    are that high. The frame
///    predicts only the pair's relative turn, not the absolute normal: a boundary frame
///    squashed against a collider predicts absolute normals poorly (measured: against its
///    anchor's cof(F) n0 a goo ball spread on the ground had one triangle "flipped" at the
///    bottom of a smooth surface; the pair test finds none there).
///  - *torn edges*: an edge longer than kTearRatio · max_v |F_v e0| + kTearSlack h (one end
///    thrown away from the other); for a vertex following its neighbourhood's fit, F_v is the
///    larger of its anchor's frame and the frame of the rule that carries it.

#include "base/types.hpp"
#include "geom/embedding.hpp"
#include "geom/geometric_state.hpp"
#include "geom/triangle_mesh.hpp"

#include <array>
#include <vector>

namespace dgv {

/// What the check needs of the rest mesh, made once (prepareSurfaceCheck).
struct SurfaceCheckSetup {
    std::vector<std::array<int, 2>> edges;         ///< each edge once (vertex indices)
    std::vector<std::array<Index, 3>> neighbours;  ///< triangle pairs sharing an edge, and a vertex of that edge
};
SurfaceCheckSetup prepareSurfaceCheck(const TriangleMesh& restMesh);

struct SurfaceCheck {
    Index triangles = 0;         ///< triangles checked
    Index flippedTriangles = 0;  ///< triangles folded over against a neighbour
    Index tornEdges = 0;         ///< edges stretched far beyond the local frame's stretch
    Real worstStretch = 0;       ///< max over edges of |e| / (max_v |F_v e0| + kTearSlack h / kTearRatio)
    /// Fit to write: no edge torn, and folds on at most kMaxFlippedFraction of the triangles.
    bool ok() const;
};

constexpr Real kFoldCosine = -0.5;  ///< neighbours more than 120° apart have folded over
constexpr Real kFoldHeight = 0.25;  ///< ... both at least this many voxels high (2 area / longest edge)
/// A frame whose surface folds over on more than this fraction of its triangles is torn. Below
/// it the folds are specks or creases in a crushed contact layer (measured on the stress suite:
/// up to 12 of the 3,968 triangles of goo balls spread on the ground, 30 on the bottom ball of a
/// stack of three pressed flat, frames that look smooth), while a crumpling body passes it
/// (a jelly hanging from a small pin: 162 of 3,968, before its lattice folds). A tear is caught
/// by its edges first (the swirled duck: torn edges from frame 14, where its folds were 1.3 %).
constexpr Real kMaxFlippedFraction = 0.02;
constexpr Real kTearRatio = 4;    ///< an edge may stretch 4× beyond what its frames predict
constexpr Real kTearSlack = 0.5;  ///< plus half a voxel (edges crossing cells, the 2nd-order term)

/// Checks the deformed surface.
/// @param setup      prepareSurfaceCheck(restMesh)
/// @param restMesh   the surface at rest (world units); its triangles index `deformed`
/// @param emb        the embedding of restMesh's vertices (anchors give each vertex's frame)
/// @param state      the body's geometric state now (tangents x_a, world units per lattice step)
/// @param spacing    h, the lattice spacing (world units)
/// @param deformed   #V deformed vertex positions (deformVertices of the same state)
/// Deterministic for any thread count.
SurfaceCheck checkSurface(const SurfaceCheckSetup& setup, const TriangleMesh& restMesh, const MeshEmbedding& emb,
                          const GeometricState& state, Real spacing, const std::vector<Vec3>& deformed);

}  // namespace dgv
