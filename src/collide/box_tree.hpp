#pragma once
/// @file box_tree.hpp
/// @brief A bounding-volume hierarchy over axis-aligned boxes: which boxes overlap a query box
/// (the GLN network's ring/loop pairs, collide/gln_network), and the node layout a nearest-first
/// descent walks (the signed distance to a mesh, collide/mesh_distance).
///
/// Built in O(n log n) by median splits of the boxes' centres (given, or the boxes' own) along
/// the longest axis of the centres' bounds, ties broken by the box's index, so the tree is the
/// same on every run. Leaves hold at most `leafSize` boxes; a leaf's boxes are the contiguous
/// run order()[first, first + count). Queries are const and may run on any number of threads.

#include "base/types.hpp"

#include <vector>

namespace dgv {

class BoxTree {
public:
    struct Node {
        Box3 box;                   ///< bounds of the node's boxes
        int first = 0, count = 0;   ///< a leaf's boxes: order()[first, first + count)
        int left = -1, right = -1;  ///< children; -1 for a leaf
        bool leaf() const { return left < 0; }
    };

    BoxTree() = default;
    /// A tree over `boxes`, split on their centres.
    explicit BoxTree(const std::vector<Box3>& boxes, int leafSize = 4);
    /// A tree over `boxes`, split on `centres` (one a box, e.g. a triangle's centroid).
    BoxTree(const std::vector<Box3>& boxes, const std::vector<Vec3>& centres, int leafSize);

    bool empty() const { return mNodes.empty(); }
    /// mNodes[0] is the root; empty for no boxes.
    const std::vector<Node>& nodes() const { return mNodes; }
    /// The boxes' indices in leaf order.
    const std::vector<int>& order() const { return mOrder; }

    /// The indices of the boxes that overlap `query` (closed boxes: touching counts), ascending.
    void overlapping(const Box3& query, std::vector<Index>& out) const;

private:
    int build(int first, int count, const std::vector<Box3>& boxes, const std::vector<Vec3>& centres, int leafSize);

    std::vector<Node> mNodes;
    std::vector<int> mOrder;
    std::vector<Box3> mLeafBoxes;  ///< boxes in leaf order: mLeafBoxes[k] is box mOrder[k]
};

/// Whether two closed boxes share a point.
inline bool boxesOverlap(const Box3& a, const Box3& b) {
    return !((a.max.array() < b.min.array()).any() || (b.max.array() < a.min.array()).any());
}

}  // namespace dgv
