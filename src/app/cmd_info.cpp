// dgv info: what import and voxelisation make of a mesh.

#include "app/commands.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "geom/embedding.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"
#include "geom/voxelise.hpp"
#include "io/mesh_import.hpp"

#include <cmath>
#include <filesystem>
#include <cstdio>

namespace dgv::app {

int runInfo(const InfoOptions& options) {
    // A scene file given where a mesh is expected: assimp said only "No suitable reader found".
    if (std::filesystem::path(options.mesh).extension() == ".json")
        throw InputError(options.mesh, "",
                         "is a scene file; 'dgv info' reads a mesh (give the mesh file the scene names, "
                         "or run 'dgv render' or 'dgv simulate' on the scene)");
    MeshImportOptions importOptions;
    importOptions.meshName = options.meshName;
    importOptions.materials = true;  // what a scene without `color` draws
    MeshImportReport importReport;
    TriangleMesh mesh = importMesh(options.mesh, importOptions, &importReport);
    if (const std::string w = unlikelySizeWarning(mesh, options.mesh); !w.empty()) logWarning(w);
    MeshReport m = analyseMesh(mesh);

    VoxeliseSettings vs;
    if (options.voxelSize > 0)
        vs.voxelSize = options.voxelSize;
    else
        vs.resolution = options.resolution > 0 ? options.resolution : 64;
    VoxeliseReport v;
    Lattice lat;
    try {
        lat = voxelise(mesh, vs, &v);
    } catch (const InputError& e) {
        throw InputError(options.mesh, options.voxelSize > 0 ? "--voxel-size" : "--resolution", e.problem());
    }

    const Vec3 size = m.bounds.size();
    std::printf("file: %s\n", options.mesh.c_str());
    std::printf("meshes_merged: %zu\n", importReport.meshesMerged);
    std::printf("unit_scale: %.6g\n", importReport.unitScale);
    std::printf("materials: %zu  (%zu with a texture, %zu textures not read)\n", importReport.materials,
                importReport.textures, importReport.texturesMissing);
    std::printf("vertices: %zu\n", m.vertices);
    std::printf("triangles: %zu\n", m.triangles);
    std::printf("degenerate_dropped: %zu\n", importReport.degenerateDropped);
    std::printf("bounds_min: %.6g %.6g %.6g\n", m.bounds.min.x(), m.bounds.min.y(), m.bounds.min.z());
    std::printf("bounds_max: %.6g %.6g %.6g\n", m.bounds.max.x(), m.bounds.max.y(), m.bounds.max.z());
    std::printf("size: %.6g %.6g %.6g\n", size.x(), size.y(), size.z());
    std::printf("closed: %s\n", m.closed ? "yes" : "no");
    std::printf("manifold: %s\n", m.manifold ? "yes" : "no");
    std::printf("boundary_edges: %zu\n", m.boundaryEdges);
    std::printf("non_manifold_edges: %zu\n", m.nonManifoldEdges);
    std::printf("mesh_volume: %.6g%s\n", m.signedVolume,
                m.closed ? "" : "  (open mesh: signed tetrahedra, approximate)");
    std::printf("voxel_size: %.6g\n", v.spacing);
    std::printf("lattice: %d x %d x %d\n", v.dims.x(), v.dims.y(), v.dims.z());
    std::printf("voxels: %lld\n", static_cast<long long>(v.points));
    std::printf("components: %d\n", v.components);
    std::printf("voxel_volume: %.6g\n", v.voxelVolume);
    if (std::abs(m.signedVolume) > 0)
        std::printf("voxel_to_mesh_volume: %.4f\n", v.voxelVolume / std::abs(m.signedVolume));
    else
        std::printf("voxel_to_mesh_volume: n/a (zero mesh volume)\n");
    std::printf("voxelise_seconds: %.3f\n", v.seconds);
    // What a scene builds from it (io/scene_build): the lattice without its loose voxels, and the
    // vertices too far from it to move with dynamics of their own (docs/math.md, "Embedding").
    Index loose = 0;
    const Lattice kept = withoutLoosePoints(lat, &loose);
    std::printf("material_points: %lld  (%lld loose voxels in no complete cell dropped)\n",
                static_cast<long long>(kept.size()), static_cast<long long>(loose));
    if (kept.size() > 0 && !mesh.vertices.empty()) {
        const MeshEmbedding emb = embedVertices(kept, mesh.vertices);
        const Index far = emb.farVertices();
        std::printf(
            "unresolved_vertices: %lld of %zu  (%.1f voxels or more from the lattice: thinner than it "
            "resolves)\n",
            static_cast<long long>(far), mesh.vertices.size(), double(kFitFull));
    }
    if (m.signedVolume < 0 && m.closed)
        std::printf("note: negative volume: the triangles face inwards (dgv voxelises it all the same)\n");
    return kExitOk;
}

}  // namespace dgv::app
