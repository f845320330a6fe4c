#pragma once
// The scene's colliders as surfaces to draw: spheres (a fine UV sphere), meshes (the imported
// mesh, transformed) and level sets (their zero isosurface, io/vdb_mesh.hpp, moved by the
// collider's transform). Ground planes are not drawn here: the renderer's own ground stands
// in for them.

#include "render/renderer.hpp"
#include "sim/scene.hpp"

#include <vector>

namespace dgv::app {

/// Linear RGB albedo of a drawn collider.
inline Vec3 colliderColour() { return Vec3(0.42, 0.44, 0.47); }

/// One static mesh per sphere, mesh or level-set collider of the scene, in world space (in order).
std::vector<DrawMesh> colliderDrawMeshes(const SceneDesc& scene);

}  // namespace dgv::app
