// `dgv bench vdb`: writing one OpenVDB cache frame (io/vdb_cache.hpp) for a ball of radius 32
// voxels (137,065 lattice points; radius 8 with --quick) twisted about Y, with a rigid-spin
// velocity and a contact band, on a world grid of voxel size h/4 (the ball spans 256 voxels).
// Prints the write time (min and median of the repeats; resampling and file writing apart, and
// the stages of the fastest repeat), the (voxel, cell) pairs solved,
// the file size per frame, the active voxels and the peak RSS. The frames go to a temporary
// folder that is removed afterwards.
#include "bench/bench.hpp"

#include "deform/volume.hpp"
#include "geom/lattice.hpp"
#include "io/atomic_file.hpp"
#include "io/vdb_cache.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace dgv::bench {

void vdb(std::ostream& out, const BenchOptions& options) {
    const int repeats = std::max(1, options.repeats);
    const Real radius = options.quick ? 8 : 32;
    const Lattice lat = ballLattice(radius);
    const LatticeCells cells = buildCells(lat);
    const Real twist = 0.6 / radius;  // radians per unit height: 0.6 rad from centre to pole
    std::vector<Vec3> x = restPositions(lat), v(x.size());
    std::vector<unsigned char> contact(x.size(), 0);
    for (std::size_t p = 0; p < x.size(); ++p) {
        const Vec3 r = x[p];
        const Real a = twist * r.y(), c = std::cos(a), s = std::sin(a);
        x[p] = Vec3(c * r.x() + s * r.z(), r.y(), -s * r.x() + c * r.z());
        v[p] = Vec3(x[p].z(), 0, -x[p].x()) * 0.5 + Vec3(0, -1, 0);  // spin about Y, falling
        contact[p] = x[p].y() < -0.8 * radius ? 1 : 0;
    }
    const std::vector<Real> rest(static_cast<std::size_t>(cells.size()), 1.0);
    VdbObjectFrame obj;
    obj.name = "ball";
    obj.lattice = &lat;
    obj.cells = &cells;
    obj.positions = &x;
    obj.velocities = &v;
    obj.contact = &contact;
    obj.restVolumes = &rest;
    VdbWriteSettings settings;
    settings.worldVoxelSize = lat.spacing / 4;
    VdbFrameInfo info;
    info.scene = "bench";

    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("dgv-bench-vdb-" + std::to_string(::getpid()));
    ensureDirectory(dir);
    std::vector<double> total, resample, write;
    std::vector<VdbStageSeconds> stages;
    VdbWriteReport last;
    for (int r = 0; r < repeats; ++r) {
        info.frame = r + 1;
        last = writeVdbFrame(vdbFramePath(dir, "bench", info.frame), {obj}, info, settings);
        total.push_back(last.seconds);
        resample.push_back(last.resampleSeconds);
        write.push_back(last.writeSeconds);
        stages.push_back(last.stages);
    }
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    const Vec3 span = Vec3::Constant(2 * radius / settings.worldVoxelSize);
    out << "vdb.points: " << lat.size() << " points\n";
    out << "vdb.world_grid_span: " << span.x() << " voxels\n";
    out << "vdb.active_voxels: " << last.activeVoxels << " voxels\n";
    out << "vdb.frame_seconds_min: " << *std::min_element(total.begin(), total.end()) << " s\n";
    out << "vdb.frame_seconds_median: " << median(total) << " s\n";
    out << "vdb.resample_seconds_median: " << median(resample) << " s\n";
    out << "vdb.write_seconds_median: " << median(write) << " s\n";
    // the stages of the fastest frame
    const VdbStageSeconds& st =
        stages[static_cast<std::size_t>(std::min_element(total.begin(), total.end()) - total.begin())];
    out << "vdb.stage_cells: " << st.cells << " s\n";
    out << "vdb.stage_bins: " << st.bins << " s\n";
    out << "vdb.stage_voxels: " << st.voxels << " s\n";
    out << "vdb.voxel_cell_solves: " << last.candidates << " (voxel, cell) pairs\n";
    out << "vdb.slow_solves: " << last.slowSolves << " (voxel, cell) pairs left to the scalar Newton\n";
    out << "vdb.stage_trees: " << st.trees << " s\n";
    out << "vdb.stage_lattice: " << st.lattice << " s\n";
    out << "vdb.stage_file: " << st.file << " s\n";
    out << "vdb.stage_verify: " << st.verify << " s\n";
    out << "vdb.file_size: " << double(last.bytes) / (1024.0 * 1024.0) << " MiB\n";
    out << "vdb.density_volume_error: " << std::abs(last.densityVolume / last.objectVolume - 1) << " relative\n";
    out << "vdb.peak_rss: " << peakRssMiB() << " MiB" << std::endl;
}

}  // namespace dgv::bench
