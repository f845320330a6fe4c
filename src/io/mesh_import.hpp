#pragma once
/// @file mesh_import.hpp
/// @brief Mesh files through assimp (OBJ, PLY, STL, glTF/GLB, FBX, Collada, 3DS, ...): node
/// transforms applied, all meshes merged (or one chosen by name), triangulated, identical
/// vertices joined, degenerate triangles dropped and counted.

#include "geom/triangle_mesh.hpp"

#include <filesystem>
#include <string>

namespace dgv {

struct MeshImportOptions {
    std::string meshName;   ///< import only meshes (or nodes) with this name; empty: all
};

struct MeshImportReport {
    std::size_t meshesMerged = 0;
    std::size_t degenerateDropped = 0;
    std::size_t nonTriangleFaces = 0;   ///< points and lines ignored
};

/// Imports the file. Throws InputError("<path>", "", what) when the file is missing, unreadable
/// or a folder, assimp cannot read it, a coordinate is NaN or infinite, an index is out of
/// range, or no triangle remains; never crashes or hangs on broken files.
TriangleMesh importMesh(const std::filesystem::path& path, const MeshImportOptions& options = {},
                        MeshImportReport* report = nullptr);

}  // namespace dgv
