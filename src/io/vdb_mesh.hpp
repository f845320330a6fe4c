#pragma once
/// @file vdb_mesh.hpp
/// @brief The zero isosurface of a dense level set (geom/sdf_grid.hpp) as a triangle mesh, e.g. to
/// draw a level-set collider. OpenVDB (tools::volumeToMesh) appears only in vdb_mesh.cpp.

#include "geom/sdf_grid.hpp"
#include "geom/triangle_mesh.hpp"

namespace dgv {

/// Meshes the surface distance = 0 of `grid` (dual contouring of OpenVDB's volumeToMesh, no
/// adaptivity: about two triangles per surface voxel, vertices within the voxel they mesh),
/// in the grid's world frame, triangles counter-clockwise seen from outside (the side where the
/// distance grows). Samples farther than the grid's narrow band keep their sign, so nothing is
/// meshed there. An empty mesh when the grid has no zero crossing.
TriangleMesh levelSetMesh(const SdfGrid& grid);

}  // namespace dgv
