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

namespace dgv {

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

/// Mesh, lattice, state and embedding of object `index` of the scene. Its lattice is refused
/// (InputError naming objects[i].resolution or .voxel_size and a value that fits) when it would
/// need more than `memoryBudget` bytes (0: memoryBudgetBytes()) at `bytesPerPoint` a point.
BuiltObject buildObject(const SceneDesc& scene, int index, std::size_t memoryBudget = 0,
                        double bytesPerPoint = kLatticeBytesPerPoint);

/// What a simulated body keeps per material point: its lattice and state, the step's work
/// arrays, the solvers, the checkpoint written each frame and, with the VDB cache, the resampler's
/// share. Measured with `dgv simulate` (maximum RSS, the slope between 7,208, 33,440 and 136,664
/// points of jelly_big_land at resolutions 24, 40 and 64): 6.0-6.1 KB a point, 7.0 KB with --vdb.
constexpr double kSimulatedBytesPerPoint = 7 * 1024;
constexpr double kSimulatedVdbBytesPerPoint = 8 * 1024;
/// Bytes a frame's VDB cache takes per active voxel of the world grid when `output.vdb_voxel_size`
/// is given (the density, vel, rest and contact grids and the resampler's work). Measured with
/// `dgv simulate --vdb` on a ball of 0.5 m (maximum RSS over the run at voxel sizes 0.02, 0.006
/// and 0.004 m: 123, 200 and 407 MB; the slope 32-35 bytes per voxel of the ball's volume), with
/// room for the surface band and a body spread by its motion.
constexpr double kVdbBytesPerVoxel = 48;

/// Every object of the scene, built in order (buildObject), their memory summed: a body that
/// the command simulates (the scene has forces or initial motion, or `vdb`) counts
/// kSimulatedBytesPerPoint (kSimulatedVdbBytesPerPoint with the VDB cache), any other
/// kLatticeBytesPerPoint; each object may take what the ones before it left of
/// memoryBudgetBytes(). Logs describe() of each.
std::vector<BuiltObject> buildObjects(const SceneDesc& scene, bool vdb);

/// One line describing a built object, for logs.
std::string describe(const BuiltObject& object);

/// A share of the mesh's vertices this far from the lattice (geom/embedding: kFitFull voxels and
/// more, carried by their neighbourhood's fit) is worth a warning: the user sees those parts move
/// stiffly with the body.
constexpr double kUnresolvedShare = 0.05;
/// The warning for an object whose unresolved vertices reach kUnresolvedShare, else "".
std::string unresolvedWarning(const BuiltObject& object);

}  // namespace dgv
