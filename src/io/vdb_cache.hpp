#pragma once
/// @file vdb_cache.hpp
/// @brief Per-frame OpenVDB caches of deformable objects (docs/vdb.md): resampled
/// world-space grids `density`, `vel`, `rest`, `contact` (and optionally `surface`), plus the
/// material-lattice grids `position` and `volume_ratio` of each object. OpenVDB appears only in
/// vdb_cache.cpp; callers pass plain dgv data.
///
/// World grids (all objects merged, one shared transform): voxel size `worldVoxelSize`, voxel
/// centres at originWorld(object 0) + vs * (i, j, k) (OpenVDB index points are voxel centres),
/// so the lattice points of object 0 fall on voxel centres whenever h / vs is an integer.
/// Lattice grids: index (i, j, k) = material coordinate u, transform x = originWorld + h * u
/// (voxel centres on lattice points). `volume_ratio` of a cell sits at its LOWEST corner u.
/// One object: grid names `position`, `volume_ratio`; several: `position_<name>`,
/// `volume_ratio_<name>` (name reduced to [A-Za-z0-9_]), each with metadata `dgv_object`.
///
/// The frame is written to a hidden temporary, re-opened and checked (io::File::write does not
/// report a full disk), then renamed (io/atomic_file.hpp). Contents are identical for any
/// thread count.

#include "base/types.hpp"
#include "deform/resample.hpp"
#include "deform/volume.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

/// One deformable object at one frame. Pointers are borrowed for the call only.
struct VdbObjectFrame {
    std::string name;                                     ///< object name (metadata, grid suffix)
    const Lattice* lattice = nullptr;                     ///< material lattice (rest transform)
    const LatticeCells* cells = nullptr;                  ///< buildCells(*lattice)
    const std::vector<Vec3>* positions = nullptr;         ///< #P deformed world positions
    const std::vector<Vec3>* velocities = nullptr;        ///< #P world units / s; nullptr = at rest
    const std::vector<unsigned char>* contact = nullptr;  ///< #P 0/1; nullptr = no contact
    const std::vector<Real>* restVolumes = nullptr;       ///< #C rest cell volumes V0 (> 0)
    /// Deformed surface (e.g. the embedded mesh at this frame), used only for the `surface`
    /// grid; nullptr = this object has no surface in it.
    const TriangleMesh* surface = nullptr;
};

struct VdbFrameInfo {
    int frame = 1;             ///< scene frame number (1-based)
    Real time = 0;             ///< seconds
    Real fps = 24;             ///< frames per second
    std::string scene;         ///< scene name
    std::string upAxis = "y";  ///< metadata only: the grids are in dgv's world frame (Y up)
    std::string key;           ///< the scene's frame key (io/state_file.hpp, sceneFrameKey), as dgv_key
};

/// Who serialises the grids: dgv's streamed writer (the leaf buffers compressed once, on every
/// core, by OpenVDB's own leaf code, while a thread writes the grids already done) or
/// openvdb::io::Archive::write. Both write the same bytes
/// but for the file's random UUID (tested); the choice only exists to test that.
enum class VdbWriter { Parallel, OpenVdb };
/// The resampler's vector kernel and binning (deform/resample.hpp): the same bits whichever.
using VdbKernel = ResampleKernel;
using VdbBinning = ResampleBinning;

struct VdbWriteSettings {
    Real worldVoxelSize = 0;    ///< world-grid voxel size; 0 = the smallest lattice spacing
    bool halfFloat = false;     ///< store density, vel, contact as 16-bit floats
    bool surface = false;       ///< add the `surface` level set (objects with a surface mesh)
    Real surfaceHalfWidth = 3;  ///< narrow-band half width of `surface`, in voxels
    VdbKernel kernel = VdbKernel::Auto;
    VdbWriter writer = VdbWriter::Parallel;
    VdbBinning binning = VdbBinning::Auto;
};

/// Wall-clock seconds of the stages of writeVdbFrame (`dgv bench vdb` prints them).
struct VdbStageSeconds {
    double cells = 0;    ///< per-cell trilinear maps and voxel boxes
    double bins = 0;     ///< grouping the (leaf block, cell) pairs by block
    double voxels = 0;   ///< inverting the cell maps at the voxel centres, coverage, values
    double trees = 0;    ///< the leaves into the four world grids
    double surface = 0;  ///< the `surface` level set (when asked for)
    double lattice = 0;  ///< `position` and `volume_ratio` (built during `file`, while the world grids are written)
    double file = 0;     ///< serialisation with Blosc, writing, fsync, size check
    double verify = 0;   ///< re-reading the file's metadata, and the rename
};

struct VdbWriteReport {
    std::uintmax_t bytes = 0;    ///< size of the written file
    double seconds = 0;          ///< whole call, wall clock
    double resampleSeconds = 0;  ///< building the world grids (and `surface`)
    double writeSeconds = 0;     ///< writing, checking and renaming the file (the lattice grids are built meanwhile)
    Index activeVoxels = 0;      ///< active voxels of the world grids (density > 0)
    Real densityVolume = 0;      ///< sum of density * voxel volume, world units^3
    Real objectVolume = 0;       ///< sum of the deformed cell volumes of all objects
    Index unresolved = 0;        ///< voxel-cell pairs where inverting the trilinear map failed:
                                 ///< inverted or degenerate cells, and candidates far outside a
                                 ///< strongly distorted cell, where its extension folds (a ball of
                                 ///< radius 16 twisted by 2 rad pole to centre: 1.04 M pairs, all
                                 ///< >= 0.2 outside cells with kNewton > 1/2; its density integral
                                 ///< still within 1.6e-4 of the volume); 0 for mild states
    Index candidates = 0;        ///< voxel-cell pairs solved (the prefilter's survivors)
    Index slowSolves = 0;        ///< voxel-cell pairs the batched Newton steps left unconverged
                                 ///< (finished one at a time; strongly distorted cells)
    VdbStageSeconds stages;      ///< where the time went
};

/// `<dir>/<scene>.####.vdb` (four digits, more past 9999).
std::filesystem::path vdbFramePath(const std::filesystem::path& dir, const std::string& scene, int frame);

/// Builds the grids of one frame and writes them to `path` atomically.
/// Throws InputError("", "vdb", ...) for inconsistent inputs (sizes, missing fields, no object,
/// a non-positive voxel size or one making the world grid too large), RuntimeError naming
/// `path` when the file cannot be written or does not read back (a full disk); then no file
/// and no temporary are left.
VdbWriteReport writeVdbFrame(const std::filesystem::path& path, const std::vector<VdbObjectFrame>& objects,
                             const VdbFrameInfo& info, const VdbWriteSettings& settings = {});

}  // namespace dgv
