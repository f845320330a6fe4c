#include "collide/box_tree.hpp"

#include <algorithm>
#include <numeric>

namespace dgv {

namespace {
std::vector<Vec3> centresOf(const std::vector<Box3>& boxes) {
    std::vector<Vec3> c(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) c[i] = boxes[i].centre();
    return c;
}
}  // namespace

BoxTree::BoxTree(const std::vector<Box3>& boxes, int leafSize) : BoxTree(boxes, centresOf(boxes), leafSize) {}

BoxTree::BoxTree(const std::vector<Box3>& boxes, const std::vector<Vec3>& centres, int leafSize) {
    const int n = static_cast<int>(boxes.size());
    if (n == 0) return;
    leafSize = std::max(leafSize, 1);
    mOrder.resize(boxes.size());
    std::iota(mOrder.begin(), mOrder.end(), 0);
    mNodes.reserve(2 * boxes.size() / static_cast<std::size_t>(leafSize) + 1);
    build(0, n, boxes, centres, leafSize);
    mLeafBoxes.resize(boxes.size());
    for (std::size_t k = 0; k < boxes.size(); ++k) mLeafBoxes[k] = boxes[static_cast<std::size_t>(mOrder[k])];
}

int BoxTree::build(int first, int count, const std::vector<Box3>& boxes, const std::vector<Vec3>& centres,
                   int leafSize) {
    const int id = static_cast<int>(mNodes.size());
    mNodes.emplace_back();
    Box3 box, centreBounds;
    for (int k = first; k < first + count; ++k) {
        const auto i = static_cast<std::size_t>(mOrder[static_cast<std::size_t>(k)]);
        box.extend(boxes[i]);
        centreBounds.extend(centres[i]);
    }
    mNodes[static_cast<std::size_t>(id)].box = box;
    if (count <= leafSize) {
        mNodes[static_cast<std::size_t>(id)].first = first;
        mNodes[static_cast<std::size_t>(id)].count = count;
        return id;
    }
    int axis = 0;
    centreBounds.size().maxCoeff(&axis);
    const int half = count / 2;
    const auto begin = mOrder.begin() + first;
    std::nth_element(begin, begin + half, begin + count, [&](int a, int b) {
        const Real ca = centres[static_cast<std::size_t>(a)][axis], cb = centres[static_cast<std::size_t>(b)][axis];
        return ca != cb ? ca < cb : a < b;
    });
    const int left = build(first, half, boxes, centres, leafSize);
    const int right = build(first + half, count - half, boxes, centres, leafSize);
    mNodes[static_cast<std::size_t>(id)].left = left;
    mNodes[static_cast<std::size_t>(id)].right = right;
    return id;
}

void BoxTree::overlapping(const Box3& query, std::vector<Index>& out) const {
    out.clear();
    if (mNodes.empty()) return;
    // Median splits: the depth is about log2(n / leafSize), and each level leaves at most one
    // node on the stack, so 64 entries cover any tree.
    int stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& node = mNodes[static_cast<std::size_t>(stack[--top])];
        if (!boxesOverlap(node.box, query)) continue;
        if (node.leaf()) {
            for (int k = node.first; k < node.first + node.count; ++k)
                if (boxesOverlap(mLeafBoxes[static_cast<std::size_t>(k)], query))
                    out.push_back(mOrder[static_cast<std::size_t>(k)]);
        } else {
            stack[top++] = node.left;
            stack[top++] = node.right;
        }
    }
    std::sort(out.begin(), out.end());
}

}  // namespace dgv
