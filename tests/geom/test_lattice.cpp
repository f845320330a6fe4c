// Tests of the material lattice (src/geom/lattice.hpp): numbering, neighbours, components.
#include <catch2/catch.hpp>

#include "geom/lattice.hpp"

#include <tbb/global_control.h>

#include <vector>

using namespace dgv;

namespace {

std::vector<unsigned char> boxMask(const Vec3i& dims, const Vec3i& lo, const Vec3i& hi) {
    std::vector<unsigned char> m(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = lo.z(); k <= hi.z(); ++k)
        for (int j = lo.y(); j <= hi.y(); ++j)
            for (int i = lo.x(); i <= hi.x(); ++i) m[static_cast<std::size_t>(i + dims.x() * (j + dims.y() * k))] = 1;
    return m;
}

std::vector<unsigned char> sphereMask(const Vec3i& dims, const Vec3& centre, Real radius) {
    std::vector<unsigned char> m(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < dims.z(); ++k)
        for (int j = 0; j < dims.y(); ++j)
            for (int i = 0; i < dims.x(); ++i)
                if ((Vec3(i, j, k) - centre).norm() <= radius)
                    m[static_cast<std::size_t>(i + dims.x() * (j + dims.y() * k))] = 1;
    return m;
}

int opposite(int slot) { return slot ^ 1; }

}  // namespace

TEST_CASE("lattice: box mask numbers points in linear order, i fastest", "[geom]") {
    const Vec3i dims(7, 6, 5);
    const Lattice lat = buildLattice(Vec3(1, 2, 3), 0.5, dims, boxMask(dims, {1, 1, 1}, {4, 3, 2}));
    REQUIRE(lat.size() == 4 * 3 * 2);
    REQUIRE(lat.coords[0] == Vec3i(1, 1, 1));
    REQUIRE(lat.coords[1] == Vec3i(2, 1, 1));
    REQUIRE(lat.coords[4] == Vec3i(1, 2, 1));
    REQUIRE(lat.coords[12] == Vec3i(1, 1, 2));
    for (Index p = 1; p < lat.size(); ++p) REQUIRE(lat.linearIndex(lat.coords[p]) > lat.linearIndex(lat.coords[p - 1]));
    for (Index p = 0; p < lat.size(); ++p) REQUIRE(lat.pointAt(lat.coords[p]) == p);
    REQUIRE(lat.pointAt(Vec3i(0, 0, 0)) == kNoPoint);
    REQUIRE(lat.pointAt(Vec3i(-1, 1, 1)) == kNoPoint);
    REQUIRE(lat.pointAt(Vec3i(7, 1, 1)) == kNoPoint);
    REQUIRE(lat.restPosition(0).isApprox(Vec3(1.5, 2.5, 3.5)));
    const std::vector<Vec3> rest = restPositions(lat);
    REQUIRE(rest.size() == 24);
    REQUIRE(rest[23] == Vec3(1 + 0.5 * 4, 2 + 0.5 * 3, 3 + 0.5 * 2));
    REQUIRE(lat.components == 1);
}

TEST_CASE("lattice: neighbour counts of a box", "[geom]") {
    const Vec3i dims(5, 4, 3);
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, boxMask(dims, {0, 0, 0}, {4, 3, 2}));
    REQUIRE(lat.size() == 60);
    // Points with c links: corners 3 (8), edges 4, faces 5, interior 6.
    std::array<int, 7> histogram{};
    for (Index p = 0; p < lat.size(); ++p) {
        int c = 0;
        for (Index q : lat.neighbours[p]) c += q != kNoPoint;
        ++histogram[c];
    }
    const int interior = 3 * 2 * 1;
    const int faces = 2 * (3 * 2 + 3 * 1 + 2 * 1);
    const int edges = 4 * (3 + 2 + 1);
    REQUIRE(histogram[3] == 8);
    REQUIRE(histogram[4] == edges);
    REQUIRE(histogram[5] == faces);
    REQUIRE(histogram[6] == interior);
    // Links: (nx-1) ny nz + ... each counted twice.
    int links = 0;
    for (int c = 0; c <= 6; ++c) links += c * histogram[c];
    REQUIRE(links == 2 * (4 * 4 * 3 + 5 * 3 * 3 + 5 * 4 * 2));
}

TEST_CASE("lattice: boundary points are those missing a neighbour (box, and a box with a hole)", "[geom]") {
    const Vec3i dims(6, 5, 4);
    const std::vector<unsigned char> mask = boxMask(dims, {0, 0, 0}, {5, 4, 3});
    const Lattice box = buildLattice(Vec3::Zero(), 1, dims, mask);
    const std::vector<Index> surface = boundaryPoints(box);
    // 6 x 5 x 4 points, 4 x 3 x 2 of them interior.
    REQUIRE(surface.size() == std::size_t(6 * 5 * 4 - 4 * 3 * 2));
    for (std::size_t k = 1; k < surface.size(); ++k) REQUIRE(surface[k] > surface[k - 1]);
    for (Index p : surface) {
        const Vec3i u = box.coords[p];
        REQUIRE(((u.array() == 0) || (u.array() == dims.array() - 1)).any());
    }
    // Removing one interior point (2, 2, 1) makes its six neighbours boundary points too.
    std::vector<unsigned char> holed = mask;
    holed[static_cast<std::size_t>(2 + dims.x() * (2 + dims.y() * 1))] = 0;
    const Lattice withHole = buildLattice(Vec3::Zero(), 1, dims, holed);
    REQUIRE(boundaryPoints(withHole).size() == surface.size() + 5);  // (2,2,0) was one already
    REQUIRE(isBoundaryPoint(withHole, withHole.pointAt(Vec3i(3, 2, 1))));
    REQUIRE_FALSE(isBoundaryPoint(withHole, withHole.pointAt(Vec3i(3, 2, 2))));
}

TEST_CASE("lattice: neighbours are symmetric and one step apart (sphere)", "[geom]") {
    const Vec3i dims(21, 19, 17);
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, sphereMask(dims, {10, 9, 8}, 7.3));
    // Count of lattice points in the ball, computed independently.
    Index expected = 0;
    for (int k = 0; k < 17; ++k)
        for (int j = 0; j < 19; ++j)
            for (int i = 0; i < 21; ++i) expected += (Vec3(i, j, k) - Vec3(10, 9, 8)).norm() <= 7.3;
    REQUIRE(lat.size() == expected);
    REQUIRE(expected > 1500);  // ~ 4/3 pi 7.3^3 = 1630
    REQUIRE(lat.components == 1);
    Index links = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        for (int s = 0; s < 6; ++s) {
            const Index q = lat.neighbours[p][s];
            Vec3i u = lat.coords[p];
            u[s / 2] += (s % 2) ? 1 : -1;
            REQUIRE(q == lat.pointAt(u));
            if (q == kNoPoint) continue;
            ++links;
            REQUIRE(lat.neighbours[q][opposite(s)] == p);
            REQUIRE(lat.coords[q] == u);
        }
    }
    // Independent link count from the mask.
    Index maskLinks = 0;
    for (Index p = 0; p < lat.size(); ++p)
        for (int a = 0; a < 3; ++a) {
            Vec3i u = lat.coords[p];
            u[a] += 1;
            maskLinks += lat.pointAt(u) != kNoPoint;
        }
    REQUIRE(links == 2 * maskLinks);
}

TEST_CASE("lattice: separate blobs get components ordered by first point", "[geom]") {
    const Vec3i dims(20, 10, 10);
    std::vector<unsigned char> mask = sphereMask(dims, {14, 5, 5}, 3.2);       // starts later
    const std::vector<unsigned char> b = boxMask(dims, {1, 1, 1}, {5, 3, 4});  // first point
    for (std::size_t c = 0; c < mask.size(); ++c) mask[c] |= b[c];
    // A diagonal-only touching voxel: 6-connectivity keeps it separate.
    mask[static_cast<std::size_t>(6 + 20 * (4 + 10 * 5))] = 1;  // (6,4,5) touches (5,3,4) by a corner
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, mask);
    REQUIRE(lat.components == 3);
    REQUIRE(lat.component[0] == 0);
    std::array<Index, 3> counts{};
    for (Index p = 0; p < lat.size(); ++p) {
        const Vec3i& u = lat.coords[p];
        // First points: box (1,1,1), sphere (14,5,2), lone voxel (6,4,5) last.
        const int expected = (u.x() <= 5 && u.y() <= 3 && u.z() <= 4) ? 0 : (u == Vec3i(6, 4, 5)) ? 2 : 1;
        REQUIRE(lat.component[p] == expected);
        ++counts[expected];
    }
    REQUIRE(counts[0] == 5 * 3 * 4);
    REQUIRE(counts[2] == 1);
    REQUIRE(counts[1] > 100);  // ~ 4/3 pi 3.2^3 = 137
    // Component ids are ordered by their first point.
    std::array<Index, 3> first{-1, -1, -1};
    for (Index p = 0; p < lat.size(); ++p)
        if (first[lat.component[p]] < 0) first[lat.component[p]] = p;
    REQUIRE(first[0] < first[1]);
    REQUIRE(first[1] < first[2]);
    // Neighbours never cross components.
    for (Index p = 0; p < lat.size(); ++p)
        for (Index q : lat.neighbours[p])
            if (q != kNoPoint) REQUIRE(lat.component[q] == lat.component[p]);
}

TEST_CASE("lattice: a U shape joined late is one component", "[geom]") {
    // Two prongs joined only at the top: union-find must merge labels seen earlier.
    const Vec3i dims(9, 9, 3);
    std::vector<unsigned char> mask = boxMask(dims, {1, 0, 1}, {2, 7, 1});
    const std::vector<unsigned char> right = boxMask(dims, {6, 0, 1}, {7, 7, 1});
    const std::vector<unsigned char> top = boxMask(dims, {1, 8, 1}, {7, 8, 1});
    for (std::size_t c = 0; c < mask.size(); ++c) mask[c] |= right[c] | top[c];
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, mask);
    REQUIRE(lat.components == 1);
    for (int c : lat.component) REQUIRE(c == 0);
}

TEST_CASE("lattice: build is identical for 1 and 2 threads (determinism)", "[geom]") {
    const Vec3i dims(64, 48, 40);
    std::vector<unsigned char> mask = sphereMask(dims, {20, 24, 20}, 15.5);
    const std::vector<unsigned char> m2 = sphereMask(dims, {50, 20, 22}, 10.2);
    for (std::size_t c = 0; c < mask.size(); ++c) mask[c] |= m2[c];
    Lattice a, b;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        a = buildLattice(Vec3(0.1, 0.2, 0.3), 0.25, dims, mask);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        b = buildLattice(Vec3(0.1, 0.2, 0.3), 0.25, dims, mask);
    }
    REQUIRE(a.components == 2);
    REQUIRE(a.coords == b.coords);
    REQUIRE(a.pointOfCell == b.pointOfCell);
    REQUIRE(a.neighbours == b.neighbours);
    REQUIRE(a.component == b.component);
    REQUIRE(a.components == b.components);
}

TEST_CASE("lattice: empty mask and empty grid", "[geom]") {
    const Vec3i dims(4, 4, 4);
    const Lattice lat = buildLattice(Vec3::Zero(), 1, dims, std::vector<unsigned char>(64, 0));
    REQUIRE(lat.size() == 0);
    REQUIRE(lat.components == 0);
    const Lattice none = buildLattice(Vec3::Zero(), 1, Vec3i(0, 3, 3), {});
    REQUIRE(none.size() == 0);
}

TEST_CASE("lattice: loose points (in no complete cell) leave, a lattice with no cell stays whole", "[geom]") {
    // A 3x3x3 block with a one-voxel fin sticking out of its top face (two points up from its
    // centre), a pole tip on its side, and, apart, a 4x4 one-voxel-thin sheet (a fragment of a
    // thin part: no cell, nothing to hold it).
    const Vec3i dims(12, 8, 5);
    std::vector<unsigned char> m = boxMask(dims, {0, 0, 0}, {2, 2, 2});
    auto set = [&](int i, int j, int k) { m[static_cast<std::size_t>(i + dims.x() * (j + dims.y() * k))] = 1; };
    set(1, 3, 1);
    set(1, 4, 1);  // the fin
    set(3, 1, 1);  // the pole tip
    std::vector<unsigned char> sheetOnly(m.size(), 0);
    for (int j = 0; j < 4; ++j) {
        for (int i = 7; i < 11; ++i) {
            set(i, j, 2);  // the sheet
            sheetOnly[static_cast<std::size_t>(i + dims.x() * (j + dims.y() * 2))] = 1;
        }
    }
    const Lattice lat = buildLattice(Vec3(0.5, -1, 2), 0.25, dims, m);
    REQUIRE(lat.size() == 27 + 3 + 16);
    REQUIRE(lat.components == 2);
    for (Index p = 0; p < lat.size(); ++p) {
        const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
        const bool inBlock = (u.array() <= 2).all();
        CHECK((completeCellsAt(lat, p) > 0) == inBlock);
    }
    Index removed = -1;
    const Lattice kept = withoutLoosePoints(lat, &removed);
    CHECK(removed == 3 + 16);
    REQUIRE(kept.size() == 27);
    CHECK(kept.components == 1);
    CHECK(kept.spacing == lat.spacing);
    CHECK(kept.originWorld == lat.originWorld);
    CHECK(kept.dims == lat.dims);
    // The kept points keep their order, coordinates and rest positions.
    Index q = 0;
    for (Index p = 0; p < lat.size(); ++p) {
        const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
        if (!(u.array() <= 2).all()) {
            CHECK(kept.pointAt(u) == kNoPoint);
            continue;
        }
        CHECK(kept.coords[static_cast<std::size_t>(q)] == u);
        CHECK(kept.restPosition(q) == lat.restPosition(p));
        ++q;
    }
    // Nothing loose: the same lattice back.
    Index none = -1;
    const Lattice again = withoutLoosePoints(kept, &none);
    CHECK(none == 0);
    CHECK(again.coords == kept.coords);
    // The sheet alone has no cell anywhere: it stays whole.
    const Lattice sheet = buildLattice(Vec3(0.5, -1, 2), 0.25, dims, sheetOnly);
    const Lattice sheetKept = withoutLoosePoints(sheet, &none);
    CHECK(none == 0);
    CHECK(sheetKept.size() == 16);
}
