#include "io/vdb_mesh.hpp"

#include "base/check.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <cmath>

namespace dgv {

TriangleMesh levelSetMesh(const SdfGrid& grid) {
    DGV_CHECK(!grid.empty() && (grid.dims.array() >= 2).all());
    openvdb::initialize();
    float band = static_cast<float>(grid.narrowBand);
    if (!(band > 0))
        for (float v : grid.values) band = std::max(band, std::abs(v));
    if (!(band > 0)) return {};
    // Samples within the band active, the rest inactive with their sign (as in a VDB level set);
    // outside the box the background +band (the box's boundary samples lie outside the object).
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(band);
    g->setGridClass(openvdb::GRID_LEVEL_SET);
    openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(grid.spacing);
    xf->postTranslate(openvdb::Vec3d(grid.origin.x(), grid.origin.y(), grid.origin.z()));
    g->setTransform(xf);
    {
        auto acc = g->getAccessor();
        for (int k = 0; k < grid.dims.z(); ++k)
            for (int j = 0; j < grid.dims.y(); ++j)
                for (int i = 0; i < grid.dims.x(); ++i) {
                    const float v = grid.at(i, j, k);
                    const openvdb::Coord c(i, j, k);
                    if (std::abs(v) < band)
                        acc.setValueOn(c, v);
                    else if (v < 0)
                        acc.setValueOff(c, -band);
                }
    }
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*g, points, tris, quads, 0.0, 0.0);

    TriangleMesh mesh;
    mesh.vertices.reserve(points.size());
    for (const openvdb::Vec3s& p : points) mesh.vertices.emplace_back(p.x(), p.y(), p.z());
    mesh.triangles.reserve(tris.size() + 2 * quads.size());
    auto idx = [](openvdb::Index32 v) { return static_cast<int>(v); };
    for (const openvdb::Vec3I& t : tris) mesh.triangles.push_back({idx(t[0]), idx(t[1]), idx(t[2])});
    for (const openvdb::Vec4I& q : quads) {
        mesh.triangles.push_back({idx(q[0]), idx(q[1]), idx(q[2])});
        mesh.triangles.push_back({idx(q[0]), idx(q[2]), idx(q[3])});
    }
    // Orientation: OpenVDB's winding is not part of its documented interface, so vote with the
    // distance's gradient at the triangles' centroids and flip all if most face inwards.
    Real vote = 0;
    for (const auto& t : mesh.triangles) {
        const Vec3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
        const Vec3& b = mesh.vertices[static_cast<std::size_t>(t[1])];
        const Vec3& c = mesh.vertices[static_cast<std::size_t>(t[2])];
        vote += (b - a).cross(c - a).dot(grid.gradient((a + b + c) / 3));
    }
    if (vote < 0)
        for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
    return mesh;
}

}  // namespace dgv
