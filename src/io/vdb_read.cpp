#include "io/vdb_read.hpp"

#include "base/errors.hpp"
#include "io/checksum.hpp"
#include "io/read_file.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/math/Maps.h>
#include <openvdb/tools/MeshToVolume.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace dgv {

namespace {

/// The dense SdfGrid of a float level set: its active voxel box padded by one voxel on each
/// side (samples there hold +-background); `bad` throws the caller's InputError.
SdfGrid denseLevelSet(const openvdb::FloatGrid& g, std::size_t maxSamples,
                      const std::function<void(const std::string&)>& bad) {
    const openvdb::FloatGrid* grid = &g;
    const openvdb::math::MapBase::ConstPtr map = grid->transform().baseMap();
    const openvdb::Vec3d vox = grid->voxelSize();
    const bool uniform = std::abs(vox[0] - vox[1]) <= 1e-9 * vox[0] && std::abs(vox[0] - vox[2]) <= 1e-9 * vox[0];
    if (!map->isLinear() || !uniform ||
        !(map->isType<openvdb::math::UniformScaleTranslateMap>() || map->isType<openvdb::math::UniformScaleMap>() ||
          map->isType<openvdb::math::TranslationMap>() || map->isType<openvdb::math::ScaleTranslateMap>() ||
          map->isType<openvdb::math::ScaleMap>()))
        bad("grid '" + grid->getName() + "': only uniform scale + translation transforms are supported (got " +
            map->type() + ")");

    const openvdb::CoordBBox active = grid->evalActiveVoxelBoundingBox();
    if (active.empty()) bad("grid '" + grid->getName() + "' has no active voxels");
    const openvdb::Coord lo = active.min() - openvdb::Coord(1), hi = active.max() + openvdb::Coord(1);
    SdfGrid out;
    out.dims = Vec3i(hi.x() - lo.x() + 1, hi.y() - lo.y() + 1, hi.z() - lo.z() + 1);
    const double n = double(out.dims.x()) * out.dims.y() * out.dims.z();
    if (n > double(maxSamples))
        bad("grid '" + grid->getName() + "' needs " + std::to_string(static_cast<long long>(n)) +
            " dense samples, more than the limit");
    const openvdb::Vec3d o = grid->indexToWorld(lo);
    out.origin = Vec3(o.x(), o.y(), o.z());
    out.spacing = vox[0];
    out.narrowBand = std::abs(double(grid->background()));
    out.values.resize(static_cast<std::size_t>(n));
    auto acc = grid->getConstAccessor();
    for (int k = 0; k < out.dims.z(); ++k)
        for (int j = 0; j < out.dims.y(); ++j)
            for (int i = 0; i < out.dims.x(); ++i)
                out.values[static_cast<std::size_t>(out.linearIndex(i, j, k))] =
                    acc.getValue(lo + openvdb::Coord(i, j, k));
    for (float v : out.values)
        if (!std::isfinite(v)) bad("grid '" + grid->getName() + "' holds non-finite distances");
    return out;
}

}  // namespace

SdfGrid readVdbLevelSet(const std::filesystem::path& path, const std::string& gridName, std::size_t maxSamples) {
    const std::string file = path.string();
    auto bad = [&](const std::string& what) { throw InputError(file, "", what); };
    // A failing disk's EIO is exit 1 (RuntimeError), not OpenVDB's complaint about the content.
    if (std::error_code ec; std::filesystem::is_regular_file(path, ec)) checkInputReadable(path, "level-set file");
    {
        std::ifstream in(path, std::ios::binary);
        if (!in) bad("cannot open the file");
        char magic[8] = {};
        in.read(magic, 8);
        // OpenVDB files start with the int32 magic 0x56444220 ("VDB" + space), little endian
        if (in.gcount() != 8 || !(magic[0] == 0x20 && magic[1] == 0x42 && magic[2] == 0x44 && magic[3] == 0x56))
            bad("not an OpenVDB file");
    }
    openvdb::initialize();
    openvdb::FloatGrid::Ptr grid;
    try {
        openvdb::io::File f(file);
        f.open(false);
        openvdb::GridBase::Ptr base;
        if (!gridName.empty()) {
            if (!f.hasGrid(gridName)) {
                const bool none = f.readAllGridMetadata()->empty();
                f.close();
                bad(none ? "the file holds no grids (is it cut short?)" : "no grid named '" + gridName + "'");
            }
            base = f.readGrid(gridName);
        } else {
            auto metas = f.readAllGridMetadata();
            for (const auto& m : *metas)
                if (m->getGridClass() == openvdb::GRID_LEVEL_SET) {
                    base = f.readGrid(m->getName());
                    break;
                }
            if (!base) {
                f.close();
                bad("no level-set grid in the file");
            }
        }
        f.close();
        grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
        if (!grid) bad("grid '" + base->getName() + "' holds " + base->valueType() + " values, not float distances");
        if (grid->getGridClass() != openvdb::GRID_LEVEL_SET) bad("grid '" + grid->getName() + "' is not a level set");
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        bad("cannot read it as OpenVDB: " + libraryMessage(e.what()));
    }

    return denseLevelSet(*grid, maxSamples, bad);
}

SdfGrid meshLevelSet(const TriangleMesh& mesh, Real voxelSize, int exteriorBandVoxels, const std::string& what,
                     std::size_t maxSamples) {
    auto bad = [&](const std::string& problem) { throw InputError(what, "", problem); };
    if (!(voxelSize > 0) || !std::isfinite(voxelSize)) bad("the level set's voxel size must be a positive number");
    const Box3 box = meshBounds(mesh);
    const Vec3 extent = box.size();
    const double cells = (extent.x() / voxelSize + 2 * exteriorBandVoxels + 3) *
                         (extent.y() / voxelSize + 2 * exteriorBandVoxels + 3) *
                         (extent.z() / voxelSize + 2 * exteriorBandVoxels + 3);
    if (!(cells <= double(maxSamples)))
        bad("a level set of voxel " + std::to_string(voxelSize) + " needs about " +
            std::to_string(static_cast<long long>(std::min(cells, 1e18))) +
            " samples, more than the limit; use a larger voxel_size");
    openvdb::initialize();
    std::vector<openvdb::Vec3s> points;
    points.reserve(mesh.vertices.size());
    for (const Vec3& v : mesh.vertices) points.emplace_back(float(v.x()), float(v.y()), float(v.z()));
    std::vector<openvdb::Vec3I> triangles;
    triangles.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles)
        triangles.emplace_back(openvdb::Index32(t[0]), openvdb::Index32(t[1]), openvdb::Index32(t[2]));
    const std::vector<openvdb::Vec4I> quads;
    const openvdb::math::Transform::Ptr xform = openvdb::math::Transform::createLinearTransform(voxelSize);
    // The interior filled to its full depth (a band as wide as the mesh): a point however deep
    // inside gets a distance and a gradient back out, not the band's flat -background.
    const float interior = float(extent.maxCoeff() / voxelSize + 2);
    openvdb::FloatGrid::Ptr grid = openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(
        *xform, points, triangles, quads, float(exteriorBandVoxels), interior);
    grid->setName("mesh");
    return denseLevelSet(*grid, maxSamples, bad);
}

std::string vdbFrameProblem(const std::filesystem::path& path, int frame, const std::string& key) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return "missing";
    // The bytes first: OpenVDB's reader trusts the topology it reads, and a flipped bit there can
    // corrupt its heap (measured: an abort in malloc), so nothing damaged reaches it.
    if (std::string why = fileChecksumProblem(path); !why.empty()) return why;
    try {
        // OpenVDB's default reader (delayed loading, what Houdini and Blender use), every leaf
        // of every grid loaded.
        openvdb::initialize();
        openvdb::io::File file(path.string());
        file.open();
        const openvdb::MetaMap::Ptr meta = file.getMetadata();
        const openvdb::GridPtrVecPtr grids = file.getGrids();
        if (grids)
            for (const openvdb::GridBase::Ptr& g : *grids)
                if (g) g->readNonresidentBuffers();
        file.close();
        if (!meta) return "has no metadata";
        const auto storedFrame = meta->getMetadata<openvdb::Int32Metadata>("dgv_frame");
        if (!storedFrame) return "has no dgv_frame";
        if (storedFrame->value() != frame) return "holds frame " + std::to_string(storedFrame->value());
        const auto storedKey = meta->getMetadata<openvdb::StringMetadata>("dgv_key");
        if (!storedKey || storedKey->value() != key) return "of another version of the scene";
        if (!grids || grids->empty()) return "has no grids";
        for (const openvdb::GridBase::Ptr& g : *grids)
            if (!g) return "has an unreadable grid";
    } catch (const std::exception& e) {
        return "does not read: " + libraryMessage(e.what());
    }
    return {};
}

}  // namespace dgv
