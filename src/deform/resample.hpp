#pragma once
/// @file resample.hpp
/// @brief Deformed lattices resampled onto a world grid of voxels (docs/vdb.md, "How the world grids are resampled"):
/// per voxel the share of it the bodies cover (density) and the coverage-weighted means of the
/// velocity, the rest position and the contact flag. Each cell's trilinear map is inverted at
/// the voxel centres by Newton's method, in vector registers where the CPU has them; a voxel's
/// coverage by a cell is the cell's separable box filter (resample.cpp). The numerics behind
/// io/vdb_cache's world grids, with no OpenVDB in them: the grid comes out in blocks of 8³
/// voxels (the size of an OpenVDB leaf), handed to a sink as each is done.

#include "base/types.hpp"
#include "deform/volume.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <functional>
#include <vector>

namespace dgv {

constexpr int kResampleBlockDim = 8;  ///< a block is 8³ voxels
constexpr int kResampleBlockVoxels = kResampleBlockDim * kResampleBlockDim * kResampleBlockDim;

/// Which vector kernel inverts the cell maps: the widest the CPU runs (Auto: AVX-512, else AVX2,
/// else SSE2), or a narrower one (a kernel the CPU lacks falls back to the next narrower). All
/// give the same bits (tested); the choice only exists to test that.
enum class ResampleKernel { Auto, Avx512, Avx2, Sse2 };
/// How the (block, cell) pairs are grouped by block: by counting where the blocks' bounding box
/// is at most 2^23 blocks (Auto), else by sorting (Sort, always). Both give the same bits
/// (tested); the choice only exists to test that.
enum class ResampleBinning { Auto, Sort };

/// One body. Pointers are borrowed for the call only.
struct ResampleInput {
    const Lattice* lattice = nullptr;                     ///< material lattice (rest positions)
    const LatticeCells* cells = nullptr;                  ///< buildCells(*lattice)
    const std::vector<Vec3>* positions = nullptr;         ///< #P deformed world positions
    const std::vector<Vec3>* velocities = nullptr;        ///< #P; nullptr = at rest
    const std::vector<unsigned char>* contact = nullptr;  ///< #P 0/1; nullptr = no contact
};

/// One block with at least one covered voxel. Its voxel (i, j, k), the grid's voxel origin +
/// (i, j, k), is entry (i · 8 + j) · 8 + k (x slowest: OpenVDB's leaf order).
struct ResampledBlock {
    Vec3i origin = Vec3i::Zero();  ///< the grid index of the block's voxel (0, 0, 0): multiples of 8
    int active = 0;                ///< covered voxels (coverage > 0)
    std::array<unsigned char, kResampleBlockVoxels> covered{};
    std::array<float, kResampleBlockVoxels> density{};  ///< min(1, coverage); 0 where not covered
    std::array<float, kResampleBlockVoxels> contact{};  ///< min(1, the mean contact flag); 0 where not covered
    std::array<std::array<float, 3>, kResampleBlockVoxels> velocity{};  ///< mean velocity; 0 where not covered
    std::array<std::array<float, 3>, kResampleBlockVoxels> rest{};      ///< mean rest position; 0 where not covered
    Real densitySum = 0;  ///< Σ min(1, coverage) over the block, in double
};

struct ResampleReport {
    Index blocks = 0;      ///< blocks some cell's voxel box meets (the `start` count)
    Index unresolved = 0;  ///< voxel-cell pairs where inverting the trilinear map failed
                           ///< (inverted or degenerate cells, candidates far outside a strongly
                           ///< distorted cell)
    Index slowSolves = 0;  ///< pairs the batched Newton steps left unconverged (finished one at a time)
    Index candidates = 0;  ///< voxel-cell pairs solved (the prefilter's survivors)
    double cellsSeconds = 0, binsSeconds = 0, voxelsSeconds = 0;  ///< per-cell maps, grouping by block, the voxels
};

/// The widest kernel that `asked` allows and the CPU runs.
ResampleKernel resolveResampleKernel(ResampleKernel asked);

/// Resamples the bodies onto the grid of voxel size `vs` whose voxel (0, 0, 0) has its centre
/// at `origin`. `start(blocks)` is called once with the number of blocks, numbered 0 .. blocks − 1
/// in order of (z, y, x) of their origins; then `sink(b, block)` once for each block with a
/// covered voxel, from several threads at once; `block` lives for the call only. The bits are
/// the same for any thread count, kernel and binning.
ResampleReport resampleLattices(const std::vector<ResampleInput>& bodies, Real vs, const Vec3& origin,
                                ResampleKernel kernel, ResampleBinning binning,
                                const std::function<void(Index blocks)>& start,
                                const std::function<void(Index block, const ResampledBlock& values)>& sink);

}  // namespace dgv
