#include "geom/lattice.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <numeric>

namespace dgv {

namespace {

/// Union-find root with path halving. Roots are always the smallest id of their set, because
/// unite() links the larger root below the smaller one.
Index findRoot(std::vector<Index>& parent, Index p) {
    while (parent[static_cast<std::size_t>(p)] != p) {
        const std::size_t s = static_cast<std::size_t>(p);
        parent[s] = parent[static_cast<std::size_t>(parent[s])];
        p = parent[s];
    }
    return p;
}

void unite(std::vector<Index>& parent, Index a, Index b) {
    Index ra = findRoot(parent, a);
    Index rb = findRoot(parent, b);
    if (ra == rb) return;
    if (ra > rb) std::swap(ra, rb);
    parent[static_cast<std::size_t>(rb)] = ra;
}

}  // namespace

Lattice buildLattice(const Vec3& originWorld, Real spacing, const Vec3i& dims, const std::vector<unsigned char>& mask) {
    DGV_CHECK((dims.array() >= 0).all());
    DGV_CHECK_GT(spacing, Real(0));
    Lattice lat;
    lat.originWorld = originWorld;
    lat.spacing = spacing;
    lat.dims = dims;
    const Index cells = Index(dims.x()) * Index(dims.y()) * Index(dims.z());
    DGV_CHECK_EQ(static_cast<Index>(mask.size()), cells);
    lat.pointOfCell.assign(static_cast<std::size_t>(cells), kNoPoint);
    if (cells == 0) return lat;

    // Number the points in increasing linear index: count per row (fixed j,k), exclusive scan in
    // row order, then fill. Row boundaries do not depend on the thread count.
    const Index rowLength = dims.x();
    const Index rows = cells / rowLength;
    std::vector<Index> rowStart(static_cast<std::size_t>(rows) + 1, 0);
    parallelFor(
        rows,
        [&](Index r) {
            Index count = 0;
            const unsigned char* m = mask.data() + r * rowLength;
            for (Index i = 0; i < rowLength; ++i) count += m[i] != 0;
            rowStart[static_cast<std::size_t>(r) + 1] = count;
        },
        64);
    std::partial_sum(rowStart.begin(), rowStart.end(), rowStart.begin());
    const Index points = rowStart.back();
    lat.coords.resize(static_cast<std::size_t>(points));
    parallelFor(
        rows,
        [&](Index r) {
            Index id = rowStart[static_cast<std::size_t>(r)];
            const int j = static_cast<int>(r % dims.y());
            const int k = static_cast<int>(r / dims.y());
            for (Index i = 0; i < rowLength; ++i) {
                const Index cell = r * rowLength + i;
                if (!mask[static_cast<std::size_t>(cell)]) continue;
                lat.pointOfCell[static_cast<std::size_t>(cell)] = id;
                lat.coords[static_cast<std::size_t>(id)] = Vec3i(static_cast<int>(i), j, k);
                ++id;
            }
        },
        64);

    // 6-neighbours by NeighbourSlot.
    lat.neighbours.resize(static_cast<std::size_t>(points));
    parallelFor(points, [&](Index p) {
        const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
        std::array<Index, 6>& nb = lat.neighbours[static_cast<std::size_t>(p)];
        for (int a = 0; a < 3; ++a) {
            Vec3i lo = u, hi = u;
            lo[a] -= 1;
            hi[a] += 1;
            nb[static_cast<std::size_t>(2 * a)] = lat.pointAt(lo);
            nb[static_cast<std::size_t>(2 * a + 1)] = lat.pointAt(hi);
        }
    });

    // 6-connected components: union-find over the backward links (sequential, O(P), in point
    // order), then ids handed out in order of each component's first (smallest) point.
    std::vector<Index> parent(static_cast<std::size_t>(points));
    std::iota(parent.begin(), parent.end(), Index(0));
    for (Index p = 0; p < points; ++p) {
        const std::array<Index, 6>& nb = lat.neighbours[static_cast<std::size_t>(p)];
        for (int slot : {kMinusI, kMinusJ, kMinusK}) {
            const Index q = nb[static_cast<std::size_t>(slot)];
            if (q != kNoPoint) unite(parent, p, q);
        }
    }
    lat.component.assign(static_cast<std::size_t>(points), -1);
    int next = 0;
    for (Index p = 0; p < points; ++p) {
        const Index root = findRoot(parent, p);
        int& label = lat.component[static_cast<std::size_t>(root)];
        if (root == p) label = next++;  // the root is the smallest id, so it is seen first
        lat.component[static_cast<std::size_t>(p)] = label;
    }
    lat.components = next;
    return lat;
}

std::vector<Vec3> restPositions(const Lattice& lat) {
    std::vector<Vec3> x(static_cast<std::size_t>(lat.size()));
    parallelFor(lat.size(), [&](Index p) { x[static_cast<std::size_t>(p)] = lat.restPosition(p); });
    return x;
}

bool isBoundaryPoint(const Lattice& lat, Index p) {
    for (Index q : lat.neighbours[static_cast<std::size_t>(p)])
        if (q == kNoPoint) return true;
    return false;
}

bool isCompleteCell(const Lattice& lat, const Vec3i& u) {
    for (int c = 0; c < 8; ++c)
        if (lat.pointAt(u + Vec3i(c & 1, (c >> 1) & 1, (c >> 2) & 1)) == kNoPoint) return false;
    return true;
}

int completeCellsAt(const Lattice& lat, Index p) {
    const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
    int cells = 0;
    for (int c = 0; c < 8; ++c) cells += isCompleteCell(lat, u - Vec3i(c & 1, (c >> 1) & 1, (c >> 2) & 1)) ? 1 : 0;
    return cells;
}

Lattice withoutLoosePoints(const Lattice& lat, Index* removed) {
    const Index n = lat.size();
    std::vector<unsigned char> inCell(static_cast<std::size_t>(n), 0);
    parallelFor(n, [&](Index p) { inCell[static_cast<std::size_t>(p)] = completeCellsAt(lat, p) > 0 ? 1 : 0; });
    // A lattice with no complete cell anywhere (a one-voxel sheet or rod) is kept whole: there is
    // nothing else to carry its mesh.
    const bool anyCell = std::find(inCell.begin(), inCell.end(), 1) != inCell.end();
    std::vector<unsigned char> mask(lat.pointOfCell.size(), 0);
    Index dropped = 0;
    for (Index p = 0; p < n; ++p) {
        const std::size_t i = static_cast<std::size_t>(p);
        const bool keep = inCell[i] || !anyCell;
        if (keep)
            mask[static_cast<std::size_t>(lat.linearIndex(lat.coords[i]))] = 1;
        else
            ++dropped;
    }
    if (removed) *removed = dropped;
    if (dropped == 0) return lat;
    return buildLattice(lat.originWorld, lat.spacing, lat.dims, mask);
}

std::vector<Index> boundaryPoints(const Lattice& lat) {
    std::vector<Index> out;
    for (Index p = 0; p < lat.size(); ++p)
        if (isBoundaryPoint(lat, p)) out.push_back(p);
    return out;
}

}  // namespace dgv
