// The bounding-volume hierarchy over boxes (src/collide/box_tree.hpp): its overlap query against
// a scan of every box, the leaf layout a nearest-first descent relies on, and the same tree for
// the same boxes.
#include <catch2/catch.hpp>

#include "collide/box_tree.hpp"

#include <random>

using namespace dgv;

namespace {
std::vector<Box3> randomBoxes(int n, std::mt19937& rng) {
    std::uniform_real_distribution<double> pos(-10, 10), size(0, 1.5);
    std::vector<Box3> boxes(static_cast<std::size_t>(n));
    for (Box3& b : boxes) {
        const Vec3 c(pos(rng), pos(rng), pos(rng));
        const Vec3 h(size(rng), size(rng), size(rng));
        b.extend(c - h);
        b.extend(c + h);
    }
    return boxes;
}
}  // namespace

TEST_CASE("box tree: the overlap query finds exactly the boxes a scan finds, in ascending order", "[collide]") {
    std::mt19937 rng(7);
    for (int n : {1, 3, 4, 5, 17, 1000}) {
        const std::vector<Box3> boxes = randomBoxes(n, rng);
        for (int leafSize : {1, 4, 16}) {
            const BoxTree tree(boxes, leafSize);
            std::vector<Box3> queries = randomBoxes(200, rng);
            queries.push_back(boxes[0]);  // a box touches itself
            Box3 touching;                // shares only the corner boxes[0].max
            touching.extend(boxes[0].max);
            touching.extend(boxes[0].max + Vec3::Constant(0.5));
            queries.push_back(touching);
            std::vector<Index> found;
            long hits = 0;
            for (const Box3& q : queries) {
                tree.overlapping(q, found);
                std::vector<Index> expected;
                for (std::size_t i = 0; i < boxes.size(); ++i)
                    if (boxesOverlap(boxes[i], q)) expected.push_back(static_cast<Index>(i));
                INFO("n " << n << ", leaves of " << leafSize);
                REQUIRE(found == expected);
                hits += static_cast<long>(found.size());
            }
            tree.overlapping(touching, found);
            CHECK(std::find(found.begin(), found.end(), Index(0)) != found.end());
            if (n == 1000) CHECK(hits > 200);  // the queries do meet boxes
        }
    }
    const BoxTree none(std::vector<Box3>{});
    std::vector<Index> found{1, 2};
    none.overlapping(randomBoxes(1, rng)[0], found);
    CHECK(found.empty());
    CHECK(none.empty());
}

TEST_CASE("box tree: leaves partition the boxes, nodes bound their boxes, and the tree is the same every build",
          "[collide]") {
    std::mt19937 rng(11);
    const std::vector<Box3> boxes = randomBoxes(777, rng);
    std::vector<Vec3> centres;
    for (const Box3& b : boxes) centres.push_back(b.min);  // split on given centres
    const BoxTree tree(boxes, centres, 4);
    const auto& nodes = tree.nodes();
    std::vector<int> seen(boxes.size(), 0);
    int leafBoxes = 0;
    for (const BoxTree::Node& node : nodes) {
        if (node.leaf()) {
            CHECK(node.count >= 1);
            CHECK(node.count <= 4);
            for (int k = node.first; k < node.first + node.count; ++k) {
                const int i = tree.order()[static_cast<std::size_t>(k)];
                ++seen[static_cast<std::size_t>(i)];
                ++leafBoxes;
                const Box3& b = boxes[static_cast<std::size_t>(i)];
                CHECK((node.box.min.array() <= b.min.array()).all());
                CHECK((node.box.max.array() >= b.max.array()).all());
            }
        } else {
            for (int c : {node.left, node.right}) {
                const Box3& child = nodes[static_cast<std::size_t>(c)].box;
                CHECK((node.box.min.array() <= child.min.array()).all());
                CHECK((node.box.max.array() >= child.max.array()).all());
            }
        }
    }
    CHECK(leafBoxes == 777);
    CHECK(std::count(seen.begin(), seen.end(), 1) == 777);
    const BoxTree again(boxes, centres, 4);
    CHECK(again.order() == tree.order());
    REQUIRE(again.nodes().size() == nodes.size());
    for (std::size_t k = 0; k < nodes.size(); ++k) {
        CHECK(again.nodes()[k].first == nodes[k].first);
        CHECK(again.nodes()[k].left == nodes[k].left);
    }
}
