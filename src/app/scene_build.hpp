#pragma once
// From a validated scene description to the objects the pipeline works on: the surface mesh
// (imported or built in, transformed to world space), its material lattice, geometric state
// and the embedding that carries the mesh with the lattice.

#include "geom/embedding.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"
#include "geom/voxelise.hpp"
#include "sim/scene.hpp"

#include <string>
#include <vector>

namespace dgv::app {

struct BuiltObject {
    std::string name;
    TriangleMesh restMesh;  ///< world space, at rest
    MeshReport meshReport;
    Lattice lattice;
    VoxeliseReport voxelReport;
    Index loosePoints = 0;  ///< voxels dropped from the lattice: in no complete cell (withoutLoosePoints)
    GeometricState state;
    MeshEmbedding embedding;
    Vec3 color;
};

/// The surface mesh of an object description, in world space. InputError names the scene file
/// and the JSON path (objects[i].mesh) as well as the mesh file.
TriangleMesh objectMesh(const ObjectDesc& desc, const std::string& sceneFile, int index);

/// Reads the vertices of every pin's vertex group (`pin.group`: a mesh or node of the object's
/// mesh file) into PinDesc::groupVertices, in world space with the object's transform, before
/// the simulation is built. InputError names the scene file and objects[i].pin.group (an unknown
/// name lists the names the file has).
void resolvePinGroups(SceneDesc& scene);

/// Mesh, lattice, state and embedding of object `index` of the scene.
BuiltObject buildObject(const SceneDesc& scene, int index);

/// One line describing a built object, for logs.
std::string describe(const BuiltObject& object);

}  // namespace dgv::app
