#pragma once
/// @file body_contact.hpp
/// @brief Contact between deformable objects (scene key collision.objects): each object's
/// deformed lattice surface at its predicted positions, turned into a signed distance every
/// substep, is a collider for the others (docs/gln.md, "Objects colliding").

#include "base/types.hpp"
#include "dynamics/cell_solve.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"

#include <vector>

namespace dgv {

/// The closed surface of a deformed lattice at positions x (#P): the outer faces of its complete
/// cells (cells whose 8 corners are material points; a face is outer when the cell across it is
/// not complete), two triangles per face, counter-clockwise seen from outside. The vertices are
/// the material points on those faces, at x. Points in no complete cell are not on it.
/// points (if given): the lattice point of each vertex.
TriangleMesh latticeSurface(const Lattice& lat, const std::vector<Vec3>& x, std::vector<Index>* points = nullptr);

/// The contacts between bodies solved as one system (dynamics/cell_solve.hpp, BodyContact), at
/// positions x (#bodies, each #P of its lattice; the substep's start): each point on a body's
/// lattice surface within margin = (h_a + h_b)/2 of another body's lattice surface, plus a voxel
/// and `approach` (how far the two may close in the step), against the nearest point of that
/// surface. The margin keeps the lattice points that far apart, where the rendered surfaces
/// (half a voxel beyond them) meet. In the order of the bodies, then of the points: the same on
/// any number of threads.
void findBodyContacts(const std::vector<const Lattice*>& lattices, const std::vector<const std::vector<Vec3>*>& x,
                      Real approach, Real friction, std::vector<BodyContact>& out);

}  // namespace dgv
