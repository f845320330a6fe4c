// A VDB cache written by `dgv simulate --vdb` agrees with the stats.csv of the same run: every
// cell's volume recomputed from the `position` grid (the exact trilinear
// hexahedron volume of its 8 corners) matches `volume_ratio` × V0, and the largest cell error
// and the total drift over the cache match stats.csv's `max_cell_volume_error` and
// `total_volume_drift` frame by frame. One substep per frame, so that stats.csv's maximum over
// the frame's substeps is the end-of-frame state the cache holds.
#include "deform/volume.hpp"
#include "e2e/e2e_run.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace dgv;
using namespace dgv::e2e;
namespace fs = std::filesystem;

namespace {

constexpr int kFrames = 6;

}  // namespace

TEST_CASE("e2e: cell volumes from a written cache's position grid agree with volume_ratio and stats.csv",
          "[e2e][vdb]") {
    test::TempDir dir("e2e_vdb_stats");
    // A box swirled by a vortex while it falls onto the ground: cells change volume within the
    // projection's tolerance (1e-4 here, so that the errors compared below are well above the
    // float and print resolutions), and the contact cells the most. One substep a frame, fixed:
    // stats.csv's max_cell_volume_error is the largest over the frame's substeps, the cache's
    // volume_ratio the frame's end.
    std::ofstream(dir.path() / "swirl.json") << R"({"name": "swirl", "frames": {"start": 1, "end": )" << kFrames
                                             << R"(, "fps": 24}, "substeps": 1, "max_substeps": 1,
  "objects": [{"name": "cube", "primitive": {"type": "box", "size": [0.4, 0.4, 0.4]},
               "transform": {"translate": [0, 0.24, 0], "rotate": [0, 0, 12]}, "resolution": 8,
               "material": {"damping": 1, "volume_tolerance": 1e-4}, "spin": [0, 90, 0]}],
  "forces": [{"type": "gravity", "strength": 9.81},
             {"type": "vortex", "position": [0.3, 0, 0], "axis": [0, 1, 0], "radius": 0.5, "strength": 3}],
  "colliders": [{"type": "ground", "height": 0, "friction": 0.5}],
  "camera": {"type": "look_at", "eye": [1.2, 0.8, 1.6], "target": [0, 0.2, 0], "fov": 40},
  "render": {"width": 64, "height": 48, "supersample": 1}})";
    const Run r = runDgvIn(dir.path(), "-q simulate swirl.json --out o --vdb");
    INFO("stderr: " << r.err);
    REQUIRE(r.exitCode == 0);
    const auto stats = readStatsCsv(dir.path() / "o" / "stats.csv");
    REQUIRE(stats.size() == std::size_t(kFrames));

    openvdb::initialize();
    double largestError = 0;
    for (int frame = 1; frame <= kFrames; ++frame) {
        char name[64];
        std::snprintf(name, sizeof name, "o/vdb/swirl.%04d.vdb", frame);
        openvdb::io::File file((dir.path() / name).string());
        file.open();
        auto pos = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("position"));
        auto ratio = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("volume_ratio"));
        file.close();
        REQUIRE(pos);
        REQUIRE(ratio);
        const double h = pos->voxelSize()[0];
        const double v0 = h * h * h;  // the rest lattice's cells are cubes of the voxel size
        auto pa = pos->getConstAccessor();
        double maxFromRatio = 0, sumRatio = 0, worstCell = 0, maxCoordinate = 0;
        std::size_t cells = 0;
        for (auto it = ratio->cbeginValueOn(); it; ++it, ++cells) {
            const openvdb::Coord u = it.getCoord();
            std::array<Vec3, 8> X;
            for (int k = 0; k < 8; ++k) {
                const openvdb::Coord q = u.offsetBy(k & 1, (k >> 1) & 1, (k >> 2) & 1);
                REQUIRE(pa.isValueOn(q));
                const openvdb::Vec3s x = pa.getValue(q);
                X[static_cast<std::size_t>(k)] = Vec3(x.x(), x.y(), x.z());
                maxCoordinate = std::max(maxCoordinate, X[static_cast<std::size_t>(k)].cwiseAbs().maxCoeff());
            }
            const double fromPositions = hexVolume(X) / v0;
            worstCell = std::max(worstCell, std::abs(fromPositions - double(*it)));
            maxFromRatio = std::max(maxFromRatio, std::abs(double(*it) - 1));
            sumRatio += *it;
        }
        REQUIRE(cells > 100);
        const auto& row = stats[static_cast<std::size_t>(frame - 1)];
        INFO("frame " << frame << ": " << cells << " cells, max |V/V0-1| " << maxFromRatio << " (stats "
                      << row.at("max_cell_volume_error") << "), drift " << sumRatio / cells - 1 << " (stats "
                      << row.at("total_volume_drift") << "), worst cell " << worstCell);
        // Float corners: each coordinate is off by up to 2^-24 |x|; a cell's volume moves by about
        // |∂V/∂x| ≈ h² per unit of coordinate, for 24 coordinates: 24 · 2^-24 |x|max / h of V0.
        const double floatBound = 24 * std::ldexp(maxCoordinate, -24) / h;
        CHECK(worstCell < floatBound);
        // volume_ratio is a float: near 1 its step is 2^-24 below and 2^-23 above (1.2e-7), so
        // |r - 1| is known to one step; stats.csv prints 3 decimals of the mantissa (5e-4).
        const double csvError = row.at("max_cell_volume_error");
        CHECK(std::abs(maxFromRatio - csvError) <= 5e-4 * csvError + 1.2e-7);
        const double csvDrift = row.at("total_volume_drift");
        CHECK(std::abs((sumRatio / cells - 1) - csvDrift) <= 5e-4 * std::abs(csvDrift) + 1.2e-7);
        largestError = std::max(largestError, csvError);
    }
    // The check above is only worth something if the volumes do change measurably.
    CHECK(largestError > 1e-6);
}
