#pragma once
/// @file gltf_cache.hpp
/// @brief A shot's deformed surfaces as one animated glTF 2.0 file (scene `output.mesh: "gltf"`):
/// `<dir>/mesh/<scene>.glb`, which Blender imports as objects with animated shape keys and
/// three.js, Houdini (glTF ROP/SOP) and most viewers play as morph-target animation.
///
/// Layout (binary glTF, one buffer): one node and mesh per object, named after it, with its
/// colour as the material's base colour. The mesh holds the object's first frame as POSITION and
/// NORMAL, and every later frame as a morph target (the change of positions and normals from the
/// first, named `frame_####` in the mesh's `extras.targetNames`, which Blender uses as the shape
/// keys' names). One animation, `dgv`, keys each mesh's weights at the frames' times
/// (t = frame / fps, so that an importer's frame N at that fps is the shot's frame N): at frame k only target k has
/// weight 1 (none at the first), and LINEAR interpolation blends two neighbouring frames between their times (a
/// sub-frame sample, e.g. for motion blur, gets the blend of the frames either side).
///
/// An object drawn in its mesh file's look (docs/rendering.md, "Materials from the file") keeps
/// it: its materials as glTF PBR materials (base colour factor and texture, metalness, roughness),
/// their textures as PNG images inside the file, TEXCOORD_0 on its vertices (a vertex on a UV seam
/// written once for each side: the morph targets follow), one primitive per material.
///
/// A goo body that is re-parametrised changes its triangles (docs/math.md); glTF's morph targets
/// need one topology, so each run of frames with the same triangles is a mesh and node of its own
/// (`<object>`, `<object>.2`, ...), shown only for its frames by a STEP animation of its scale
/// (0 outside them).

#include "base/material.hpp"
#include "base/types.hpp"

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

/// One run of frames of an object with the same triangles.
struct GltfSegment {
    int firstFrame = 0;
    std::vector<std::array<int, 3>> triangles;
    std::vector<std::vector<Vec3>> positions;  ///< per frame from firstFrame, one per vertex
    std::vector<std::vector<Vec3>> normals;    ///< the same shape
    /// The look, per triangle (TriangleMesh's lists; both empty: the track's colour): its
    /// material in GltfTrack::materials (−1: the track's colour) and its corners' coordinates.
    std::vector<int> triangleMaterials;
    std::vector<std::array<Eigen::Vector2f, 3>> cornerUvs;
};

struct GltfTrack {
    std::string name;
    Vec3 colour = Vec3(0.8, 0.8, 0.8);  ///< linear RGB
    std::vector<GltfSegment> segments;  ///< in frame order, each starting where the last ends
    std::vector<SurfaceMaterial> materials;  ///< the segments' looks index into these
};

struct GltfShotInfo {
    double fps = 24;
    int firstFrame = 0;     ///< the frame at t = 0
    std::string generator;  ///< asset.generator
    std::string key;        ///< the scene's frame key, in asset.extras.dgv_key (fps in dgv_fps)
};

/// The GLB bytes of `tracks`; RuntimeError past the format's 4 GiB.
std::string gltfShotBytes(const std::vector<GltfTrack>& tracks, const GltfShotInfo& info);

/// Writes gltfShotBytes atomically (a temporary name, renamed). RuntimeError naming the file on
/// failure.
void writeGltfShot(const std::filesystem::path& path, const std::vector<GltfTrack>& tracks, const GltfShotInfo& info);

}  // namespace dgv
