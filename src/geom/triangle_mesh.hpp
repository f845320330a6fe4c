#pragma once
/// @file triangle_mesh.hpp
/// @brief Triangle meshes as dgv holds them after import: world-space vertices (double),
/// counter-clockwise triangles seen from outside (outward normals by the right-hand rule).

#include "base/material.hpp"
#include "base/types.hpp"

#include <array>
#include <string>
#include <vector>

namespace dgv {

struct TriangleMesh {
    std::vector<Vec3> vertices;                 ///< #V positions, world units
    std::vector<std::array<int, 3>> triangles;  ///< #T vertex indices, CCW from outside
    /// The file's look (io/mesh_import with MeshImportOptions::materials), kept in step with
    /// `triangles` by every function here that drops or turns triangles. Per triangle: its
    /// material (an index into `materials`, −1: none, drawn in its object's colour) and its
    /// corners' texture coordinates (seams are per corner, so the weld by position keeps them).
    /// Both empty: no look of its own.
    std::vector<int> triangleMaterials;
    std::vector<std::array<Eigen::Vector2f, 3>> cornerUvs;
    std::vector<SurfaceMaterial> materials;

    std::size_t vertexCount() const { return vertices.size(); }
    std::size_t triangleCount() const { return triangles.size(); }
    /// Whether the triangles carry materials and texture coordinates of their own.
    bool hasMaterials() const {
        return !materials.empty() && triangleMaterials.size() == triangles.size() && cornerUvs.size() == triangles.size();
    }
    /// Drops the look (a scene's `color` overrides the file's).
    void clearMaterials() {
        triangleMaterials.clear();
        cornerUvs.clear();
        materials.clear();
    }
};

/// The colour of the surface seen from afar: each triangle's material's mean colour (factor times
/// its map's mean), weighted by the triangle's area; `fallback` for the triangles without one, and
/// for a mesh without materials.
Vec3 meanSurfaceColour(const TriangleMesh& mesh, const Vec3& fallback);

/// What `dgv info` reports about a mesh's topology and size.
struct MeshReport {
    std::size_t vertices = 0;
    std::size_t triangles = 0;
    std::size_t degenerateDropped = 0;  ///< zero-area or repeated-index triangles removed
    Box3 bounds;
    bool closed = false;               ///< every edge has exactly two incident triangles
    bool manifold = false;             ///< every edge has at most two incident triangles, and
                                       ///< consistently oriented ones where two
    std::size_t boundaryEdges = 0;     ///< edges with one triangle (holes)
    std::size_t nonManifoldEdges = 0;  ///< edges with three or more triangles
    Real signedVolume = 0;             ///< sum of signed tetrahedra to the origin (exact for closed meshes)
};

/// Removes triangles with repeated indices or zero area (|cross| <= 1e-14 * longest edge^2);
/// returns how many were dropped. Unreferenced vertices are kept.
std::size_t dropDegenerateTriangles(TriangleMesh& mesh);

/// For each vertex, the lowest index of the vertices at exactly its position (itself when none
/// is lower): the weld by position that the importer applies and the voxeliser's topology reads.
std::vector<int> samePositionRepresentatives(const std::vector<Vec3>& vertices);

/// Bounds of the vertices referenced by triangles (empty box for an empty mesh).
Box3 meshBounds(const TriangleMesh& mesh);

/// Signed volume by the divergence theorem: sum over triangles of det(a, b, c) / 6.
Real meshSignedVolume(const TriangleMesh& mesh);

/// Edge topology, bounds and volume in one pass (degenerateDropped is left at 0). Edges are
/// vertex-index pairs (vertices at the same position but with different indices are different
/// vertices). An empty mesh is neither closed nor manifold.
MeshReport analyseMesh(const TriangleMesh& mesh);

/// Applies x -> A x + t to every vertex. A with det < 0 also flips every triangle's winding so
/// that normals stay outward.
void transformMesh(TriangleMesh& mesh, const Mat3& linear, const Vec3& translation);

/// What orientOutward did.
struct OrientReport {
    std::size_t parts = 0;         ///< connected parts (triangles sharing vertices)
    std::size_t flippedParts = 0;  ///< parts that were inside out and were turned around
    Real volumeBefore = 0;         ///< the mesh's signed volume before (negative: inside out)
};

/// Turns every connected part of the mesh whose signed volume (about the part's bounds centre,
/// so that an open part does not depend on where the origin is) is negative: its triangles'
/// winding is reversed so that normals point out. A negative part within the bounds of an
/// outward part is a cavity and stays. The winding number, which decides what is
/// inside (geom/voxelise), integrates to the signed volume, so an inside-out part voxelises to
/// nothing until turned. Deterministic; parts are found by shared vertex indices.
OrientReport orientOutward(TriangleMesh& mesh);

/// Per-vertex normals: area-weighted sum of incident face normals, normalised; zero for a
/// vertex no (non-degenerate) triangle uses.
std::vector<Vec3> vertexNormals(const TriangleMesh& mesh);
/// The same for positions and triangles held apart (a deformed surface on its rest triangles).
std::vector<Vec3> vertexNormals(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles);

/// Taubin's λ|μ smoothing: `iterations` pairs of umbrella steps v += λ (mean of v's edge
/// neighbours − v), then the same with μ < −λ, which undoes the shrinking of the first: a
/// low-pass filter on the surface that takes a staircase off and keeps the volume within a per
/// cent (the outer faces of a voxel ball of radius 8, 10 pairs: volume +0.6 %, the radial spread
/// of its vertices 0.45 → 0.12 voxel; tests/geom/test_triangle_mesh.cpp).
void smoothTaubin(TriangleMesh& mesh, int iterations, Real lambda = 0.5, Real mu = -0.53);

}  // namespace dgv
