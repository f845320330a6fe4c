#pragma once
/// @file contact_highlight.hpp
/// @brief The contact set R as a per-vertex scalar on a drawn surface (the renderer's
/// ScalarRamp): per lattice point a value (penetration depth, or how recently the point was in
/// R), carried to the mesh vertices by the embedding's trilinear weights, the same way the
/// positions are carried (vertices without a full material cell take their anchor point's
/// value). Relies only on DeformableBody::contact() and contactDepth() (0/1 and world units
/// per lattice point), so it does not depend on how R is computed.

#include "base/types.hpp"
#include "geom/embedding.hpp"
#include "geom/lattice.hpp"
#include "sim/scene.hpp"

#include <array>
#include <utility>
#include <vector>

namespace dgv {

/// Per lattice point: frames since the point was last in R (0: in R this frame; kNever: not
/// yet). Updated once per simulated frame, whether or not that frame is rendered, so a render
/// of frames A-B sees the same history as a render of the whole range.
class ContactHistory {
public:
    static constexpr int kNever = 1 << 30;
    /// Records one frame's contact flags (0/1 per point). A change in the point count restarts
    /// the history.
    void observe(const std::vector<unsigned char>& contact);
    const std::vector<int>& age() const { return mAge; }
    /// Sets the history to `age` (a state checkpoint's copy, docs/robustness.md).
    void restore(std::vector<int> age) { mAge = std::move(age); }

private:
    std::vector<int> mAge;
};

/// A highlight ramp's two colours (linear RGB): `low` shallow or fading, `high` deep or now.
struct HighlightColours {
    Vec3 low, high;
};

/// The ramp that stands out on a surface of albedo `surface` (linear RGB): of four pairs,
/// warm (yellow → red, the default), cool (cyan → blue), green and magenta, the first whose
/// `high` lies farthest from the surface in sRGB-encoded colour. A blue jelly gets red, an
/// orange putty blue.
HighlightColours contrastingHighlight(const Vec3& surface);

/// Per-point scalar for `mode` (Off: all 0). Points outside the highlight get a negative value,
/// so that the interpolated scalar crosses 0 (the renderer's "highlighted" test) between a
/// highlighted point and its neighbours rather than at the neighbours: the highlight's edge
/// runs through the triangles instead of fanning out over every triangle that touches R.
/// Depth: contact ? depth + edge : −edge (points in R at depth 0 still show; ramp from `edge`
/// to depth_max + edge). Recent: (fade − age)/fade where age < fade, else −1 (needs `age`;
/// `fadeFrames` ≥ 1).
std::vector<Real> contactPointScalar(ContactHighlightMode mode, const std::vector<unsigned char>& contact,
                                     const std::vector<Real>& depth, const std::vector<int>& age, int fadeFrames,
                                     Real edge = 0);

/// Widens a highlight over the body (render.contact.spread): a point within `rings` lattice
/// steps (6-neighbour hops through material points) of highlighted points (s > 0) and not
/// highlighted itself takes max_q s_q (1 − d_q/(rings + 1)), d_q its hops to q. The contact
/// set R lies where the body touches, usually on the side facing away from the camera (under a
/// landing ball, on the face towards the other ball); the band around it is what the camera
/// sees. Points out of reach keep their value, except those next to the outermost ring, which
/// take −1/4 of their largest spread neighbour's (when that is above their own), so the edge
/// fades across the cell. rings ≤ 0: unchanged.
void spreadPointScalar(const Lattice& lat, std::vector<Real>& scalar, int rings);

/// Smooths a per-vertex highlight over the mesh: `passes` Jacobi sweeps of the mean over each
/// vertex's edge neighbours, on the positive values only (a vertex out of the highlight stays
/// out, one inside never drops below zero). The value comes from lattice points a voxel or more
/// apart, so on a mesh finer than the lattice its edge follows the cells in steps; a few
/// passes round them off.
void smoothVertexScalar(const std::vector<std::array<int, 3>>& triangles, std::vector<Real>& value, int passes);

/// Per vertex of a collider's drawn surface, its footprint (render.contact.footprint): the
/// highlighted points (value > 0) within `radius` of the vertex give value · (1 − d/radius),
/// the largest of them; vertices out of reach get −edge (the same sign rule as
/// contactPointScalar, so the footprint's edge runs through triangles). `vertexValue` is
/// resized to vertices.size(). Deterministic, in parallel.
void footprintScalar(const std::vector<Vec3>& vertices, const std::vector<Vec3>& points,
                     const std::vector<Real>& pointValue, Real radius, Real edge, std::vector<Real>& vertexValue);

/// Per mesh vertex: sum_k w_k value(corner_k) for trilinear vertices, value(anchor) for the
/// others. `vertexValue` is resized to emb.size(). Deterministic, in parallel.
void pointScalarToVertices(const MeshEmbedding& emb, const std::vector<Real>& pointValue,
                           std::vector<Real>& vertexValue);

}  // namespace dgv
