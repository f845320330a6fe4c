// Tests of src/geom/voxelise.hpp: the material points are the grid points with winding number
// >= 1/2; convergence, robustness (holes, overlaps, duplicates, soups), determinism, budgets.
#include <tbb/global_control.h>

#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "geom/primitives.hpp"
#include "geom/voxelise.hpp"

#include <sys/resource.h>

#include <cmath>
#include <random>

using namespace dgv;

namespace {
constexpr Real kPi = 3.14159265358979323846;

VoxeliseSettings atResolution(int n) {
    VoxeliseSettings s;
    s.resolution = n;
    return s;
}

VoxeliseSettings atVoxelSize(Real h) {
    VoxeliseSettings s;
    s.voxelSize = h;
    return s;
}

TriangleMesh merged(const TriangleMesh& a, const TriangleMesh& b) {
    TriangleMesh m = a;
    const int base = static_cast<int>(m.vertices.size());
    m.vertices.insert(m.vertices.end(), b.vertices.begin(), b.vertices.end());
    for (auto t : b.triangles) m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    return m;
}

TriangleMesh translated(TriangleMesh m, const Vec3& t) {
    transformMesh(m, Mat3::Identity(), t);
    return m;
}

/// Every grid point of `lat`, in linear order.
std::vector<Vec3> gridPoints(const Lattice& lat) {
    std::vector<Vec3> q;
    for (int k = 0; k < lat.dims.z(); ++k)
        for (int j = 0; j < lat.dims.y(); ++j)
            for (int i = 0; i < lat.dims.x(); ++i) q.push_back(lat.originWorld + lat.spacing * Vec3(i, j, k));
    return q;
}

/// The lattice must be {grid points with exact winding number >= 1/2}, except where w is within
/// the accelerated evaluation's error (1e-3) of 1/2 (only near holes, where it is used).
void requireMatchesWindingNumber(const TriangleMesh& mesh, const Lattice& lat) {
    const std::vector<Real> w = windingNumbers(mesh, gridPoints(lat), WindingEvaluation::Exact);
    std::size_t mismatches = 0;
    for (std::size_t c = 0; c < w.size(); ++c)
        if (std::abs(w[c] - 0.5) > 1e-3) mismatches += (lat.pointOfCell[c] != kNoPoint) != (w[c] >= 0.5);
    CHECK(mismatches == 0);
}

bool sameLattice(const Lattice& a, const Lattice& b) {
    return a.dims == b.dims && a.originWorld == b.originWorld && a.spacing == b.spacing &&
           a.pointOfCell == b.pointOfCell && a.coords == b.coords && a.component == b.component;
}

}  // namespace

TEST_CASE("voxelise: winding number is 1 inside and 0 outside a closed mesh", "[geom]") {
    const TriangleMesh torus = makeTorus(1.0, 0.4, 48, 24);
    std::mt19937 rng(7);
    std::uniform_real_distribution<Real> u(-1.6, 1.6);
    std::vector<Vec3> q;
    std::vector<Real> expected;
    while (q.size() < 500) {
        const Vec3 p(u(rng), u(rng) * 0.5, u(rng));
        const Real ring = std::hypot(std::hypot(p.x(), p.z()) - 1.0, p.y());
        if (std::abs(ring - 0.4) < 0.03) continue;  // keep clear of the faceted surface
        q.push_back(p);
        expected.push_back(ring < 0.4 ? 1 : 0);
    }
    const std::vector<Real> exact = windingNumbers(torus, q, WindingEvaluation::Exact);
    const std::vector<Real> fast = windingNumbers(torus, q);
    Real worstExact = 0, worstFast = 0;
    for (std::size_t i = 0; i < q.size(); ++i) {
        worstExact = std::max(worstExact, std::abs(exact[i] - expected[i]));
        worstFast = std::max(worstFast, std::abs(fast[i] - expected[i]));
    }
    CHECK(worstExact < 1e-6);
    CHECK(worstFast < 1e-3);
}

TEST_CASE("voxelise: the lattice is the set of grid points with winding number >= 1/2", "[geom][slow]") {
    SECTION("sphere") {
        const TriangleMesh m = makeSphere(1.0, 40, 20);
        requireMatchesWindingNumber(m, voxelise(m, atResolution(20)));
    }
    SECTION("torus") {
        const TriangleMesh m = makeTorus(1.0, 0.35, 40, 20);
        requireMatchesWindingNumber(m, voxelise(m, atResolution(30)));
    }
    SECTION("box with vertices and edges exactly on grid points and rows") {
        const TriangleMesh m = makeBox(Vec3(2, 2, 2), 2);
        const Lattice lat = voxelise(m, atVoxelSize(0.5));
        CHECK(lat.size() == 64);
        requireMatchesWindingNumber(m, lat);
    }
    SECTION("sphere with a hole") {
        TriangleMesh m = makeSphere(1.0, 40, 20);
        m.triangles.erase(m.triangles.begin() + 300, m.triangles.begin() + 306);
        VoxeliseReport report;
        const Lattice lat = voxelise(m, atResolution(20), &report);
        CHECK(report.exactEvaluations > 0);
        requireMatchesWindingNumber(m, lat);
    }
}

TEST_CASE("voxelise: placement is centred on the bounds with one empty cell of padding", "[geom]") {
    const TriangleMesh m = translated(makeBox(Vec3(2.0, 1.0, 0.5), 1), Vec3(3, -1, 2));
    VoxeliseReport report;
    const Lattice lat = voxelise(m, atResolution(10), &report);
    CHECK(report.spacing == Approx(0.2).epsilon(1e-14));
    CHECK(lat.dims == Vec3i(12, 7, 5));
    const Vec3 centre = lat.originWorld + 0.5 * lat.spacing * (lat.dims.cast<Real>() - Vec3::Ones());
    CHECK((centre - Vec3(3, -1, 2)).norm() < 1e-12);
    CHECK(lat.size() == 10 * 5 * 3);  // voxel centres inside the box; padding empty
    for (const Vec3i& u : lat.coords) {
        CHECK((u.array() >= 1).all());
        CHECK((u.array() <= lat.dims.array() - 2).all());
    }
    CHECK(report.points == lat.size());
    CHECK(report.voxelVolume == Approx(150 * 0.2 * 0.2 * 0.2).epsilon(1e-12));
    CHECK(report.components == 1);
}

TEST_CASE("voxelise: voxel volume converges to the analytic volume at first order", "[geom][slow]") {
    SECTION("sphere") {
        const TriangleMesh m = makeSphere(1.0, 256, 128);
        const Real exact = 4.0 / 3 * kPi;
        std::vector<Real> err;
        for (int n : {16, 32, 64, 128}) {
            VoxeliseReport r;
            voxelise(m, atResolution(n), &r);
            err.push_back(std::abs(r.voxelVolume / exact - 1));
            CHECK(err.back() < 0.5 / n);
        }
        CHECK(err[1] < err[0]);
        CHECK(err[2] < err[1]);
        CHECK(err[3] < err[0] / 4);
    }
    SECTION("torus") {
        const TriangleMesh m = makeTorus(1.0, 0.4, 316, 158);
        const Real exact = 2 * kPi * kPi * 0.4 * 0.4;
        std::vector<Real> err;
        for (int n : {32, 64, 256}) {
            VoxeliseReport r;
            voxelise(m, atResolution(n), &r);
            err.push_back(std::abs(r.voxelVolume / exact - 1));
            CHECK(err.back() < 1.0 / n);
        }
        CHECK(err[1] < err[0]);
        CHECK(err[2] < err[0] / 8);
    }
}

TEST_CASE("voxelise: a sphere with a small hole voxelises like the closed one", "[geom]") {
    const TriangleMesh closed = makeSphere(1.0, 64, 32);
    TriangleMesh holed = closed;
    holed.triangles.erase(holed.triangles.begin() + 1000, holed.triangles.begin() + 1004);
    holed.triangles.erase(holed.triangles.begin() + 3000, holed.triangles.begin() + 3002);
    REQUIRE(analyseMesh(holed).boundaryEdges > 0);
    VoxeliseReport a, b;
    voxelise(closed, atResolution(48), &a);
    voxelise(holed, atResolution(48), &b);
    CHECK(a.exactEvaluations == 0);
    CHECK(b.exactEvaluations > 0);
    CHECK(std::abs(Real(b.points) / Real(a.points) - 1) < 0.01);
}

TEST_CASE("voxelise: overlapping boxes voxelise to their union", "[geom]") {
    // Two self-intersecting boxes (winding number 2 in the overlap) on a grid aligned to them.
    const TriangleMesh m = merged(makeBox(Vec3(2, 2, 2), 3), translated(makeBox(Vec3(2, 2, 2), 2), Vec3(1, 1, 0)));
    const Lattice lat = voxelise(m, atVoxelSize(0.25));
    CHECK(lat.size() == 2 * 512 - 4 * 4 * 8);  // union = 2 boxes - overlap (1 x 1 x 2)
    CHECK(lat.components == 1);
}

TEST_CASE("voxelise: duplicated, inverted and unwelded pieces do not change the result", "[geom]") {
    const TriangleMesh box = makeBox(Vec3(1.0, 1.4, 0.6), 4);
    const Lattice reference = voxelise(box, atResolution(24));

    // Every triangle twice: winding number 2 inside.
    CHECK(sameLattice(voxelise(merged(box, box), atResolution(24)), reference));

    // An extra copy of some faces together with their inverted copies: they cancel.
    TriangleMesh extra = box;
    for (int t = 0; t < 10; ++t) {
        auto tri = box.triangles[static_cast<std::size_t>(t)];
        extra.triangles.push_back(tri);
        extra.triangles.push_back({tri[0], tri[2], tri[1]});
    }
    CHECK(sameLattice(voxelise(extra, atResolution(24)), reference));

    // A triangle soup: every triangle with its own three vertices.
    TriangleMesh soup;
    for (const auto& t : box.triangles) {
        const int base = static_cast<int>(soup.vertices.size());
        for (int v : t) soup.vertices.push_back(box.vertices[static_cast<std::size_t>(v)]);
        soup.triangles.push_back({base, base + 1, base + 2});
    }
    VoxeliseReport report;
    CHECK(sameLattice(voxelise(soup, atResolution(24), &report), reference));
    CHECK(report.exactEvaluations == 0);  // welded by position: still a closed cycle
}

TEST_CASE("voxelise: two separate spheres are two components", "[geom]") {
    const TriangleMesh m = merged(makeSphere(1.0, 32, 16), translated(makeSphere(0.5, 32, 16), Vec3(2.5, 0, 0)));
    VoxeliseReport report;
    const Lattice lat = voxelise(m, atResolution(40), &report);
    CHECK(report.components == 2);
    CHECK(lat.components == 2);
}

TEST_CASE("voxelise: 1 and 2 threads give identical lattices", "[geom][determinism]") {
    TriangleMesh m = makeTorus(1.0, 0.4, 96, 48);
    m.triangles.erase(m.triangles.begin() + 500, m.triangles.begin() + 503);  // exercise the winding path
    Lattice one, two;
    VoxeliseReport r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = voxelise(m, atResolution(64), &r1);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = voxelise(m, atResolution(64), &r2);
    }
    CHECK(r1.exactEvaluations > 0);
    CHECK(r1.exactEvaluations == r2.exactEvaluations);
    CHECK(sameLattice(one, two));
}

TEST_CASE("voxelise: a lattice over the memory budget is refused before allocating", "[geom]") {
    const TriangleMesh m = makeSphere(1.0, 16, 8);
    VoxeliseSettings s = atResolution(2048);
    s.memoryBudgetBytes = std::size_t(64) << 20;
    try {
        voxelise(m, s);
        FAIL("expected an InputError");
    } catch (const InputError& e) {
        CHECK(e.where() == "resolution");
        CHECK(e.problem().find("2050x2050x2050") != std::string::npos);
        CHECK(e.problem().find("budget") != std::string::npos);
    }
    CHECK(estimateLatticeBytes(1000, 100) == 1000 * 8 + 100 * 1024);
    s = atResolution(32);
    s.memoryBudgetBytes = std::size_t(64) << 20;
    CHECK_NOTHROW(voxelise(m, s));
}

TEST_CASE("voxelise: a simulated body's bytes per point are budgeted, and the refusal names a resolution that fits",
          "[geom]") {
    const TriangleMesh m = makeSphere(1.0, 32, 16);
    VoxeliseSettings s = atResolution(64);
    s.memoryBudgetBytes = std::size_t(256) << 20;
    CHECK_NOTHROW(voxelise(m, s));  // ~140k points at 1 KiB
    s.bytesPerPoint = 7 * 1024;     // what `dgv simulate` keeps a point (io/scene_build.hpp)
    int fits = 0;
    try {
        voxelise(m, s);
        FAIL("expected an InputError");
    } catch (const InputError& e) {
        CHECK(e.where() == "resolution");
        const std::string p = e.problem();
        const auto at = p.find("; resolution ");
        REQUIRE(at != std::string::npos);
        REQUIRE(p.find(" would fit") != std::string::npos);
        fits = std::stoi(p.substr(at + 13));
    }
    CHECK(fits > 32);  // the cube root of the shortfall, not a guess far below it
    CHECK(fits < 64);
    s.resolution = fits;
    CHECK_NOTHROW(voxelise(m, s));
    // by voxel size: a size that fits
    VoxeliseSettings v = atVoxelSize(2.0 / 64);
    v.memoryBudgetBytes = s.memoryBudgetBytes;
    v.bytesPerPoint = s.bytesPerPoint;
    try {
        voxelise(m, v);
        FAIL("expected an InputError");
    } catch (const InputError& e) {
        CHECK(e.where() == "voxel_size");
        const auto at = e.problem().find("; voxel_size ");
        REQUIRE(at != std::string::npos);
        v.voxelSize = std::stod(e.problem().substr(at + 13));
    }
    CHECK(v.voxelSize > 2.0 / 64);
    CHECK_NOTHROW(voxelise(m, v));
}

#if !defined(__SANITIZE_ADDRESS__) && !(defined(__has_feature) && __has_feature(address_sanitizer))
TEST_CASE("voxelise: the memory budget is within the address-space limit", "[geom]") {
    // (not under AddressSanitizer, which reserves terabytes of address space)
    rlimit old{};
    REQUIRE(getrlimit(RLIMIT_AS, &old) == 0);
    const std::size_t free = memoryBudgetBytes();
    rlimit low = old;
    low.rlim_cur = std::min<rlim_t>(rlim_t(2) << 30, old.rlim_max);  // 2 GiB, where the hard limit allows
    REQUIRE(setrlimit(RLIMIT_AS, &low) == 0);
    const std::size_t limited = memoryBudgetBytes();
    REQUIRE(setrlimit(RLIMIT_AS, &old) == 0);
    // the limit less the address space the program takes besides its lattices (320 MiB)
    CHECK(limited == std::min(free, std::size_t(low.rlim_cur) - (std::size_t(320) << 20)));
    CHECK(memoryBudgetBytes() == free);
}
#endif

TEST_CASE("voxelise: invalid settings and meshes are input errors", "[geom]") {
    const TriangleMesh m = makeSphere(1.0, 16, 8);
    VoxeliseSettings both = atResolution(10);
    both.voxelSize = 0.1;
    VoxeliseSettings threshold = atResolution(10);
    threshold.windingThreshold = 0;
    for (const VoxeliseSettings& s : {VoxeliseSettings{}, both, atVoxelSize(-1), atVoxelSize(std::nan("")),
                                      atVoxelSize(INFINITY), atResolution(-3), atResolution(5000), threshold}) {
        CHECK_FALSE(s.validate().empty());
        CHECK_THROWS_AS(voxelise(m, s), InputError);
    }
    CHECK(atVoxelSize(-1).validate().front().rfind("voxel_size: ", 0) == 0);
    CHECK(atResolution(5000).validate().front().rfind("resolution: ", 0) == 0);
    CHECK(atResolution(10).validate().empty());

    CHECK_THROWS_AS(voxelise(TriangleMesh{}, atResolution(10)), InputError);
    TriangleMesh bad = m;
    bad.vertices[3].x() = INFINITY;
    CHECK_THROWS_AS(voxelise(bad, atResolution(10)), InputError);
    TriangleMesh tiny = m;
    CHECK_THROWS_AS(voxelise(tiny, atVoxelSize(1e-6)), InputError);  // > 16384 points per axis
}
