// Resampling deformed lattices onto a world grid (src/deform/resample.hpp), without OpenVDB:
// the blocks the sink receives, checked against the body's volume, its velocity and rest
// positions, and against themselves across kernels, binnings and thread counts.
#include <catch2/catch.hpp>

#include "deform/resample.hpp"
#include "deform/twisted_ball.hpp"

#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <map>
#include <mutex>

using namespace dgv;

namespace {

using Ball = test::TwistedBall;

ResampleInput inputOf(const Ball& f) { return {&f.lat, &f.cells, &f.x, &f.v, &f.contact}; }

Ball makeBall(Real r, Real h, const Vec3& origin, Real twist) { return test::makeTwistedBall(r, h, origin, twist); }

/// Every block the sink received, by index.
struct Collected {
    Index blocks = -1;
    std::map<Index, ResampledBlock> byIndex;
    int calls = 0;
    ResampleReport report;
};

Collected collect(const Ball& f, Real vs, const Vec3& origin, ResampleKernel kernel = ResampleKernel::Auto,
                  ResampleBinning binning = ResampleBinning::Auto) {
    Collected c;
    std::mutex m;
    c.report = resampleLattices(
        {inputOf(f)}, vs, origin, kernel, binning, [&](Index blocks) { c.blocks = blocks; },
        [&](Index b, const ResampledBlock& blk) {
            std::lock_guard<std::mutex> lock(m);
            ++c.calls;
            c.byIndex[b] = blk;
        });
    return c;
}

bool sameBits(const ResampledBlock& a, const ResampledBlock& b) {
    return a.origin == b.origin && a.active == b.active && a.covered == b.covered &&
           std::memcmp(a.density.data(), b.density.data(), sizeof a.density) == 0 &&
           std::memcmp(a.contact.data(), b.contact.data(), sizeof a.contact) == 0 &&
           std::memcmp(a.velocity.data(), b.velocity.data(), sizeof a.velocity) == 0 &&
           std::memcmp(a.rest.data(), b.rest.data(), sizeof a.rest) == 0 &&
           std::memcmp(&a.densitySum, &b.densitySum, sizeof a.densitySum) == 0;
}

/// The grid index of entry `at` of a block.
Vec3i voxelOf(const ResampledBlock& blk, std::size_t at) {
    const int i = static_cast<int>(at) / 64, j = static_cast<int>(at) / 8 % 8, k = static_cast<int>(at) % 8;
    return blk.origin + Vec3i(i, j, k);
}

}  // namespace

TEST_CASE("resample: the blocks' density integrates to the body's volume", "[deform][resample]") {
    for (Real twist : {0.0, 0.5}) {
        for (Real vsRatio : {0.25, 1.0, 0.3}) {
            INFO("twist " << twist << " voxel/h " << vsRatio);
            const Ball f = makeBall(6, 0.1, Vec3(-0.3, 0.2, 0.7), twist);
            const Real vs = 0.1 * vsRatio;
            const Collected c = collect(f, vs, f.lat.originWorld);
            REQUIRE(c.blocks == c.report.blocks);
            REQUIRE(c.calls == static_cast<int>(c.byIndex.size()));  // each block once
            Real sum = 0;
            float lo = 1, hi = 0;
            Index active = 0;
            for (const auto& [b, blk] : c.byIndex) {
                REQUIRE(b >= 0);
                REQUIRE(b < c.blocks);
                for (int a = 0; a < 3; ++a) REQUIRE(blk.origin[a] % kResampleBlockDim == 0);
                Real blockSum = 0;
                int covered = 0;
                for (std::size_t at = 0; at < std::size_t(kResampleBlockVoxels); ++at) {
                    if (!blk.covered[at]) {
                        REQUIRE(blk.density[at] == 0.f);
                        continue;
                    }
                    ++covered;
                    blockSum += blk.density[at];
                    lo = std::min(lo, blk.density[at]);
                    hi = std::max(hi, blk.density[at]);
                    REQUIRE(blk.contact[at] >= 0.f);
                    REQUIRE(blk.contact[at] <= 1.f);
                }
                CHECK(covered == blk.active);
                CHECK(blockSum == Approx(blk.densitySum).epsilon(1e-6));  // the float values summed again
                sum += blk.densitySum;
                active += blk.active;
            }
            CHECK(active > 0);
            CHECK(lo > 0);
            CHECK(hi == 1.0f);
            const Real volume = totalVolume(f.cells, f.x), integral = sum * vs * vs * vs;
            // undeformed cells: the box filter is exact (to rounding); twisted ones to second order
            CHECK(std::abs(integral / volume - 1) < (twist == 0 ? 1e-12 : 1e-2));
        }
    }
}

TEST_CASE("resample: a block's index orders its origin by z, then y, then x", "[deform][resample]") {
    const Ball f = makeBall(9, 0.1, Vec3(0.05, -0.4, 0.3), 0.3);
    const Collected c = collect(f, 0.03, f.lat.originWorld);
    REQUIRE(c.byIndex.size() > 8);
    auto key = [](const Vec3i& o) { return std::make_tuple(o.z(), o.y(), o.x()); };
    const ResampledBlock* last = nullptr;
    for (const auto& [b, blk] : c.byIndex) {
        if (last) CHECK(key(last->origin) < key(blk.origin));
        last = &blk;
    }
}

TEST_CASE("resample: undeformed at h/2, lattice points on voxel centres hold the lattice's values",
          "[deform][resample]") {
    const Ball f = makeBall(4, 0.2, Vec3(0.3, -0.1, 0.05), 0.0);
    const Collected c = collect(f, 0.1, f.lat.originWorld);
    std::map<std::tuple<int, int, int>, std::pair<const ResampledBlock*, std::size_t>> voxel;
    for (const auto& [b, blk] : c.byIndex)
        for (std::size_t at = 0; at < std::size_t(kResampleBlockVoxels); ++at)
            if (blk.covered[at]) {
                const Vec3i g = voxelOf(blk, at);
                voxel[{g.x(), g.y(), g.z()}] = {&blk, at};
            }
    std::vector<unsigned char> inCell(static_cast<std::size_t>(f.lat.size()), 0);
    for (const auto& corners : f.cells.corners)
        for (Index q : corners) inCell[static_cast<std::size_t>(q)] = 1;
    Real worstV = 0, worstR = 0;
    int contactWrong = 0, checked = 0;
    for (Index q = 0; q < f.lat.size(); ++q) {
        if (!inCell[static_cast<std::size_t>(q)]) continue;  // a point of no cell has no volume
        const Vec3i& u = f.lat.coords[static_cast<std::size_t>(q)];
        const auto it = voxel.find({2 * u.x(), 2 * u.y(), 2 * u.z()});
        REQUIRE(it != voxel.end());
        const auto& [blk, at] = it->second;
        const Vec3 v(blk->velocity[at][0], blk->velocity[at][1], blk->velocity[at][2]);
        const Vec3 r(blk->rest[at][0], blk->rest[at][1], blk->rest[at][2]);
        worstV = std::max(worstV, (v - f.v[static_cast<std::size_t>(q)]).norm());
        worstR = std::max(worstR, (r - f.lat.restPosition(q)).norm());
        if (blk->contact[at] != float(f.contact[static_cast<std::size_t>(q)])) ++contactWrong;
        ++checked;
    }
    CHECK(checked > 100);
    CHECK(worstV < 2e-6);  // float rounding of values ~ 3
    CHECK(worstR < 1e-6);
    CHECK(contactWrong == 0);
}

TEST_CASE("resample: the same bits for any kernel, binning and thread count", "[deform][resample]") {
    // A spin about the twist axis as the velocity: near the axis its values cancel, so a kernel
    // whose arithmetic differs in the last bits (an FMA contraction) changes them.
    Ball f = makeBall(8, 0.125, Vec3(0.5, -0.25, 1.0), 0.7);
    for (std::size_t p = 0; p < f.x.size(); ++p) {
        const Vec3 d = f.x[p] - f.centre;
        f.v[p] = 0.5 * Vec3(d.z(), 0, -d.x()) + Vec3(0, -1, 0);
    }
    const Real vs = 0.03125;
    const Collected ref = collect(f, vs, f.lat.originWorld, ResampleKernel::Sse2);
    std::vector<Collected> others;
    for (ResampleKernel k : {ResampleKernel::Avx2, ResampleKernel::Avx512, ResampleKernel::Auto})
        others.push_back(collect(f, vs, f.lat.originWorld, k));
    others.push_back(collect(f, vs, f.lat.originWorld, ResampleKernel::Auto, ResampleBinning::Sort));
    for (int threads : {1, 2, 4}) {
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
        others.push_back(collect(f, vs, f.lat.originWorld));
    }
    for (std::size_t k = 0; k < others.size(); ++k) {
        INFO("run " << k);
        REQUIRE(others[k].blocks == ref.blocks);
        REQUIRE(others[k].byIndex.size() == ref.byIndex.size());
        CHECK(others[k].report.unresolved == ref.report.unresolved);
        CHECK(others[k].report.candidates == ref.report.candidates);
        int differ = 0;
        for (const auto& [b, blk] : ref.byIndex) {
            const auto it = others[k].byIndex.find(b);
            if (it == others[k].byIndex.end() || !sameBits(blk, it->second)) ++differ;
        }
        CHECK(differ == 0);
    }
}
