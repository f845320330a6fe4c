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

#include <utility>
#include <vector>

namespace dgv {

enum class ContactHighlightMode {
    Off,
    Depth,   ///< scalar = penetration depth before the response (world units) where in R, else 0
    Recent,  ///< scalar = 1 − age/fade for points in R within the last `fade` frames, else 0
};

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

/// Per mesh vertex: sum_k w_k value(corner_k) for trilinear vertices, value(anchor) for the
/// others. `vertexValue` is resized to emb.size(). Deterministic, in parallel.
void pointScalarToVertices(const MeshEmbedding& emb, const std::vector<Real>& pointValue,
                           std::vector<Real>& vertexValue);

}  // namespace dgv
