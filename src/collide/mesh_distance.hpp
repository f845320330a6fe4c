#pragma once
/// @file mesh_distance.hpp
/// @brief The exact signed distance to a closed triangle mesh, queried point by point through a
/// bounding-volume hierarchy over its triangles: the distance between bodies in contact
/// (sim/simulation, the other body's lattice surface; docs/gln.md, "Objects colliding").
///
/// The magnitude is the Euclidean distance to the nearest point of the mesh. The sign is that of
/// (x − c) · n at the nearest point c, n the angle-weighted pseudonormal of the feature c lies on
/// (the face's normal inside a face; the sum of the two faces' normals on an edge; the
/// angle-weighted sum of the faces' normals at a vertex), which is exact for a closed,
/// consistently oriented manifold mesh. Negative inside.
///
/// Built in O(T log T) (a median split on the triangles' centroids, leaves of at most 4); a query
/// visits the nodes nearest first and prunes by the best distance so far. Queries are const and
/// may run on any number of threads; the result does not depend on the thread count.

#include "base/types.hpp"
#include "collide/box_tree.hpp"
#include "geom/triangle_mesh.hpp"

#include <array>
#include <limits>
#include <vector>

namespace dgv {

class MeshDistance {
public:
    MeshDistance() = default;
    /// The mesh must be closed and consistently oriented for the sign to mean inside/outside.
    explicit MeshDistance(const TriangleMesh& mesh);

    bool empty() const { return mTriangles.empty(); }
    /// Bounds of the mesh's triangles.
    const Box3& bounds() const { return mBounds; }
    std::size_t triangleCount() const { return mTriangles.size(); }

    /// Signed distance at x (negative inside); *gradient (if given) is its gradient, a unit
    /// vector: sign · (x − c)/|x − c|, or the pseudonormal at c when x lies on the surface.
    /// An empty mesh is infinitely far away (gradient +y).
    /// A point farther than `beyond` from the mesh's bounding box gets the distance to that box
    /// instead, a lower bound of the true one (and outside, so positive), with the box's
    /// gradient: the query a contact test needs only up to some distance costs no descent there.
    Real signedDistance(const Vec3& x, Vec3* gradient = nullptr,
                        Real beyond = std::numeric_limits<Real>::infinity()) const;

    /// The nearest point of the mesh to a query, with what signedDistance gives.
    struct Closest {
        Real distance = std::numeric_limits<Real>::infinity();  ///< signed, negative inside
        Vec3 gradient = Vec3::UnitY();                           ///< as signedDistance's
        int triangle = -1;                   ///< the nearest triangle's index in the mesh (−1: beyond or empty)
        Vec3 barycentric = Vec3::Zero();     ///< of the nearest point on that triangle's vertices
    };
    /// As signedDistance; beyond `beyond` (or for an empty mesh) triangle is −1.
    Closest closest(const Vec3& x, Real beyond = std::numeric_limits<Real>::infinity()) const;

private:
    struct Tri {
        std::array<Vec3, 3> v;
        Vec3 faceNormal;                 ///< unit (zero for a degenerate triangle)
        std::array<Vec3, 3> edgeNormal;  ///< edge k runs from v[k] to v[(k+1)%3]
        std::array<Vec3, 3> vertexNormal;
        int source = 0;  ///< the triangle's index in the mesh
    };
    std::vector<Tri> mTriangles;  ///< in the hierarchy's leaf order
    BoxTree mTree;                ///< over the triangles (centroid splits, leaves of 4)
    Box3 mBounds;
};

}  // namespace dgv
