#pragma once
/// @file vdb_read.hpp
/// @brief Loading a level-set grid from a .vdb file into a dense SdfGrid (geom/sdf_grid.hpp),
/// e.g. a static collider made in Houdini. OpenVDB appears only in vdb_read.cpp.

#include "geom/sdf_grid.hpp"
#include "geom/triangle_mesh.hpp"

#include <filesystem>
#include <string>

namespace dgv {

/// Reads the float level set named `gridName` from `path`, or, when `gridName` is empty, the
/// first grid of class level set (in file order). The dense box is the grid's active voxel
/// box padded by one voxel on each side (samples there hold +-background); the grid's transform
/// must be a uniform scale plus translation (voxel centres = samples).
/// Throws InputError naming the file for: a missing or unreadable file, not a .vdb, no such grid,
/// no level set, a non-float grid, an unsupported transform, an empty grid, or a box of more
/// than `maxSamples` samples.
SdfGrid readVdbLevelSet(const std::filesystem::path& path, const std::string& gridName = "",
                        std::size_t maxSamples = std::size_t(256) << 20);

/// The signed distance to a closed, consistently oriented triangle mesh (world units, negative
/// inside) as a dense SdfGrid of `voxelSize` (OpenVDB's meshToSignedDistanceField): exact within
/// `exteriorBandVoxels` voxels outside the surface and as far in inside (farther out the
/// SdfGrid's clamp applies); deeper inside, filled by OpenVDB's sweep (measured within ~1 % in
/// size, 0.2 rad in direction, for a torus tube), so a point however deep in the mesh is pushed
/// back out rather than left at a flat -band with no gradient.
/// Throws InputError(what, ...) for a voxel size that is not a positive number or a grid of
/// more than `maxSamples` samples.
SdfGrid meshLevelSet(const TriangleMesh& mesh, Real voxelSize, int exteriorBandVoxels, const std::string& what,
                     std::size_t maxSamples = std::size_t(256) << 20);

/// Whether `path` is a complete frame `frame` of the VDB cache of the scene whose frame key is
/// `key` (io/vdb_cache.hpp writes both into the file's metadata): empty when it is, else why
/// not ("missing", "has no checksum", "is corrupt (its checksum does not match)", "does not
/// read: ...", "holds frame N", "of another version of the scene", "has no grids"). The file's
/// seal (io/checksum.hpp) is checked before OpenVDB reads it, so any changed byte is found; then
/// OpenVDB's default reader loads every leaf of every grid.
std::string vdbFrameProblem(const std::filesystem::path& path, int frame, const std::string& key);

}  // namespace dgv
