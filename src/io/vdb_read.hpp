#pragma once
/// @file vdb_read.hpp
/// @brief Loading a level-set grid from a .vdb file into a dense SdfGrid (geom/sdf_grid.hpp),
/// e.g. a static collider made in Houdini. OpenVDB appears only in vdb_read.cpp.

#include "geom/sdf_grid.hpp"

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

}  // namespace dgv
