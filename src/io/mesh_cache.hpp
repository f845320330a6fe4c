#pragma once
/// @file mesh_cache.hpp
/// @brief The deformed surfaces as a mesh cache (scene `output.mesh`, `--mesh`): one file per
/// object and frame, `<dir>/mesh/<object>.####.ply` (or `.obj`), which Houdini's File SOP reads as
/// a sequence (`$F4`) and Blender imports per frame or as a sequence. Binary little-endian PLY
/// with positions, vertex normals, the object's colour (8-bit sRGB) and `contact` (a float per
/// vertex: 1 where the vertex's lattice cell is all in the contact set R, 0 where none of it is);
/// OBJ with positions and normals (`vn`, `f v//vn`). Each file carries its frame and the scene's
/// frame key in comments, and its checksum (io/checksum.hpp), so --resume keeps only whole files
/// of this version of the scene; each is
/// written to a temporary name and renamed. `gltf` writes the PLY sequence too, and at the end of
/// the run assembles it into one animated glTF 2.0 file (io/gltf_cache.hpp).

#include "base/types.hpp"

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

/// Gltf: the Ply sequence per frame, and the animated `<scene>.glb` assembled from it at the end.
enum class MeshCacheFormat { None, Ply, Obj, Gltf };

/// "ply", "obj", "gltf" (an InputError naming `where` otherwise).
MeshCacheFormat meshCacheFormatFromName(const std::string& name, const std::string& where);
/// The per-frame files' extension: "obj" for Obj, else "ply".
const char* meshCacheExtension(MeshCacheFormat format);

struct MeshCacheFrame {
    std::string object;  ///< the object's name
    int frame = 0;
    std::string key;  ///< the scene's frame key (io/state_file.hpp)
    const std::vector<Vec3>* positions = nullptr;
    const std::vector<std::array<int, 3>>* triangles = nullptr;
    const std::vector<Real>* contact = nullptr;  ///< per vertex in [0, 1], or null (all 0)
    Vec3 colour = Vec3(0.8, 0.8, 0.8);           ///< linear RGB
};

/// <dir>/<object>.####.<ext>
std::filesystem::path meshCachePath(const std::filesystem::path& dir, const std::string& object, int frame,
                                    MeshCacheFormat format);

/// Writes one object's frame atomically. RuntimeError naming the file on failure.
void writeMeshCacheFrame(const std::filesystem::path& path, MeshCacheFormat format, const MeshCacheFrame& frame);

/// Why the file at `path` is not a complete cache file of `frame` with key `key` ("" when it
/// is): missing, unsealed or corrupt (every byte is checked against the file's own checksum,
/// io/checksum.hpp), truncated (its size is not what its header declares; OBJ: no end line),
/// another frame's, or of another version of the scene.
std::string meshCacheFileProblem(const std::filesystem::path& path, MeshCacheFormat format, int frame,
                                 const std::string& key);

/// One PLY frame as this module writes it.
struct MeshCacheData {
    std::vector<Vec3> positions, normals;
    std::vector<std::array<int, 3>> triangles;
    std::vector<float> contact;
    Vec3 colour = Vec3(0.8, 0.8, 0.8);  ///< linear RGB (decoded from the file's 8-bit sRGB)
};

/// Reads a PLY frame written by writeMeshCacheFrame (check it with meshCacheFileProblem first).
/// RuntimeError naming the file when it is not one: another layout, short, or an index out of range.
MeshCacheData readMeshCacheFrame(const std::filesystem::path& path);

}  // namespace dgv
