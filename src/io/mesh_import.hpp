#pragma once
/// @file mesh_import.hpp
/// @brief Mesh files through assimp (OBJ, PLY, STL, glTF/GLB, FBX, Collada, 3DS, ...): node
/// transforms applied, all meshes merged (or one chosen by name), triangulated, identical
/// vertices joined, degenerate triangles dropped and counted.

#include "geom/triangle_mesh.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

struct MeshImportOptions {
    std::string meshName;  ///< import only meshes (or nodes) with this name; empty: all
    /// Turn inside-out parts around (orientOutward), with a warning naming the file. Off for
    /// imports that use only the vertices (a pin's vertex group).
    bool orientOutward = true;
    /// Log the line saying a file's unit scale was applied (off for a second import of the
    /// same file, a pin's vertex group).
    bool logUnitScale = true;
    /// Metres per file unit to apply instead of the file's own (a scene's `transform.units`); 0:
    /// the file's (FBX's UnitScaleFactor, else 1).
    double unitScale = 0;
    /// Also read the file's look (TriangleMesh::materials, triangleMaterials, cornerUvs): each
    /// material's base colour, roughness and metalness, and its base-colour texture decoded
    /// (io/texture) from beside the file or from the file itself. A texture that cannot be found
    /// or read is a warning naming it; the material keeps its colour. Off: positions only.
    bool materials = false;
    /// With `materials`: decode the textures (false: find them only, quietly, for
    /// MeshImportReport::filesRead; the materials then have no maps).
    bool decodeTextures = true;
};

struct MeshImportReport {
    std::size_t meshesMerged = 0;  ///< mesh instances (mesh x node) that gave triangles
    std::size_t degenerateDropped = 0;
    std::size_t nonTriangleFaces = 0;  ///< points and lines ignored
    OrientReport orientation;          ///< parts turned around (orientOutward)
    double unitScale = 1;              ///< metres per file unit applied (FBX UnitScaleFactor / 100)
    std::size_t materials = 0;         ///< materials read (options.materials)
    std::size_t textures = 0;          ///< of them with a base-colour texture
    std::size_t texturesMissing = 0;   ///< textures named that could not be read (each warned of)
    /// Every file the import read, absolute, sorted, once each: the mesh file, the files assimp
    /// opened beside it (an OBJ's MTL, a glTF's buffers) and the textures found. What a frame
    /// drawn from the mesh is a function of (io/state_file, sceneFrameKey).
    std::vector<std::string> filesRead;
};

/// Imports the file: scales it to metres by the file's unit (FBX's UnitScaleFactor, with one
/// logInfo line naming the scale), walks the node tree accumulating transforms (a transform with
/// det < 0 flips the winding), merges the selected meshes, welds vertices at exactly the same world position
/// (so STL files and meshes split by normals come out closed), drops degenerate triangles, and
/// turns inside-out parts around with a warning (options.orientOutward).
/// Throws InputError("<path>", "", what) when the file is missing, unreadable
/// or a folder, assimp cannot read it, a coordinate is NaN or infinite, an index is out of
/// range, or no triangle remains; never crashes or hangs on broken files. The message is one line,
/// e.g. "no triangles (the file holds only points and lines)", "mesh 'Cube' vertex 12 has a
/// non-finite coordinate", "assimp could not read it: <assimp's message>", "no mesh or node named
/// 'x'; available: 'a', 'b'". Silences assimp's logger.
TriangleMesh importMesh(const std::filesystem::path& path, const MeshImportOptions& options = {},
                        MeshImportReport* report = nullptr);

/// A warning for a mesh whose size in metres is unlikely for a shot, which usually means a file
/// in another unit: larger than 100 m across ("... 150 m across: is the file in centimetres? ...")
/// or smaller than 1 mm, or lying more than 10⁴ times its size from the origin (floats keep
/// about 7 digits); "" otherwise. `what` names the mesh ("object 'duck' (duck.dae)"). A mesh not
/// from a file (`fromFile` false: a primitive, given in metres) is warned of only outside
/// 1e-6..1e6 m or far from the origin.
std::string unlikelySizeWarning(const TriangleMesh& mesh, const std::string& what, bool fromFile = true);

}  // namespace dgv
