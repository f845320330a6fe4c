#pragma once
/// @file embedding.hpp
/// @brief A lattice deformer: the imported surface mesh is embedded in the material lattice at
/// rest and carried by the lattice as it deforms, so renders keep the mesh's detail whatever
/// the voxel size. Exact for any affine motion of the lattice.

#include "base/types.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <vector>

namespace dgv {

struct MeshEmbedding {
    /// Per vertex: the 8 corner points of its lattice cell and trilinear weights when all 8
    /// corners are material points; otherwise the nearest material point and the offset from
    /// it in lattice units (the vertex then follows that point's tangent frame).
    std::vector<std::array<Index, 8>> corners;
    std::vector<std::array<Real, 8>> weights;   ///< sums to 1 when corners[v][0] != kNoPoint
    std::vector<Index> anchor;                  ///< nearest material point (always valid)
    std::vector<Vec3> offset;                   ///< vertex - x(anchor), lattice units, at rest
};

/// Embeds rest vertices (world units) in the lattice. Requires lat.size() > 0.
MeshEmbedding embedVertices(const Lattice& lat, const std::vector<Vec3>& restVertices);

/// Deformed vertex positions from the current state (positions and tangent frames).
void deformVertices(const MeshEmbedding& emb, const GeometricState& state,
                    std::vector<Vec3>& vertices);

}  // namespace dgv
