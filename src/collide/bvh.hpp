#pragma once
/// @file bvh.hpp
/// @brief A bounding-volume hierarchy over the segments of one closed curve, for the far-field
/// evaluation of the Gauss linking integral (eq 83; Barnes–Hut after Qu & James 2021, "Fast
/// Linking Numbers for Topology Verification of Loopy Structures").
///
/// Nodes are contiguous runs of segments (a sub-chain of the curve, split at the middle index),
/// so that the exact kernel (gln_exact.hpp) runs on a node pair as one tile with its vertex-row
/// reuse. Each node carries its bounding box, a centre c (the box centre), a radius ρ bounding
/// |x − c| over every point x of its segments, its arc length, and the moments of the line
/// element dx about c up to second order (exact for straight segments, m = midpoint − c):
///   M    = ∫ dx               = Σ e
///   F[k] = ∫ (x − c)_k dx     = Σ m_k e
///   S[kl]= ∫ (x−c)_k (x−c)_l dx = Σ (m_k m_l + e_k e_l / 12) e

#include "base/types.hpp"
#include "collide/gln_exact.hpp"

#include <array>
#include <vector>

namespace dgv {

struct BvhNode {
    Index begin = 0, end = 0;   ///< segments [begin, end)
    int left = -1, right = -1;  ///< children (node indices); -1 for a leaf
    Box3 box;
    Vec3 centre = Vec3::Zero();
    Real radius = 0;           ///< max |x − centre| over the node's segments
    Real length = 0;           ///< Σ segment lengths
    Vec3 m0 = Vec3::Zero();    ///< M
    Mat3 m1 = Mat3::Zero();    ///< column k is F[k]
    std::array<Vec3, 6> m2{};  ///< S[kl] for kl = 00, 11, 22, 01, 02, 12

    bool leaf() const { return left < 0; }
};

struct CurveBvh {
    std::vector<BvhNode> nodes;  ///< nodes[0] is the root (covers every segment)
};

/// Builds the hierarchy over the segments of `curve` (leaves of at most `leafSize` segments).
/// O(n) moments: children's moments are translated to the parent's centre.
CurveBvh buildCurveBvh(const CurveSoA& curve, int leafSize = 32);

/// Index of the second-order moment S[kl] in BvhNode::m2.
inline int momentIndex(int k, int l) {
    static constexpr int idx[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};
    return idx[k][l];
}

/// The far-field (multipole, second order) value of the Gauss integral between node `a` of
/// curve 1 and node `b` of curve 2, in linking-number units (already divided by 4π), and a
/// rigorous bound on its truncation error:
///   |exact − value| ≤ L_a L_b / (4π D²) · [ (1 − q)^-3 − (1 + 3q + 6q²) ],  q = (ρ_a + ρ_b)/D,
/// from |∇ of the degree-n term of 1/|R + z|| ≤ (n+1)(n+2)/2 · |z|^n / D^(n+2) (Legendre
/// series). Requires q < 1.
struct FarValue {
    double value = 0;
    double bound = 0;
};
FarValue farFieldPair(const BvhNode& a, const BvhNode& b);

}  // namespace dgv
