// Surfaces of deformed lattices for contact between objects (body_contact.hpp).

#include "sim/body_contact.hpp"

#include "base/parallel.hpp"
#include "collide/mesh_distance.hpp"

#include <array>
#include <optional>

namespace dgv {

TriangleMesh latticeSurface(const Lattice& lat, const std::vector<Vec3>& x, std::vector<Index>* points) {
    TriangleMesh mesh;
    if (points) points->clear();
    std::vector<int> vertexOf(static_cast<std::size_t>(lat.size()), -1);
    auto vertex = [&](const Vec3i& u) {
        const Index p = lat.pointAt(u);
        int& v = vertexOf[static_cast<std::size_t>(p)];
        if (v < 0) {
            v = static_cast<int>(mesh.vertices.size());
            mesh.vertices.push_back(x[static_cast<std::size_t>(p)]);
            if (points) points->push_back(p);
        }
        return v;
    };
    for (Index p = 0; p < lat.size(); ++p) {
        const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
        if (!isCompleteCell(lat, u)) continue;
        for (int a = 0; a < 3; ++a) {
            const Vec3i ea = Vec3i::Unit(a), eb = Vec3i::Unit((a + 1) % 3), ec = Vec3i::Unit((a + 2) % 3);
            for (int side = 0; side < 2; ++side) {
                if (isCompleteCell(lat, side ? Vec3i(u + ea) : Vec3i(u - ea))) continue;
                // The face's corners; (eb x ec) = ea, so p0 p1 p2 p3 runs counter-clockwise about +ea.
                const Vec3i q0 = side ? Vec3i(u + ea) : u;
                std::array<int, 4> f = {vertex(q0), vertex(q0 + eb), vertex(q0 + eb + ec), vertex(q0 + ec)};
                if (!side) std::swap(f[1], f[3]);  // outward is −ea
                mesh.triangles.push_back({f[0], f[1], f[2]});
                mesh.triangles.push_back({f[0], f[2], f[3]});
            }
        }
    }
    return mesh;
}

void findBodyContacts(const std::vector<const Lattice*>& lattices, const std::vector<const std::vector<Vec3>*>& x,
                      Real approach, Real friction, std::vector<BodyContact>& out) {
    const std::size_t n = lattices.size();
    std::vector<TriangleMesh> meshes(n);
    std::vector<std::vector<Index>> points(n);
    std::vector<MeshDistance> distance(n);
    std::vector<Box3> boxes(n);
    for (std::size_t b = 0; b < n; ++b) {
        meshes[b] = latticeSurface(*lattices[b], *x[b], &points[b]);
        distance[b] = MeshDistance(meshes[b]);
        for (const Vec3& v : meshes[b].vertices) boxes[b].extend(v);
    }
    for (std::size_t a = 0; a < n; ++a)
        for (std::size_t b = 0; b < n; ++b) {
            if (a == b || distance[b].empty()) continue;
            const Real ha = lattices[a]->spacing, margin = Real(0.5) * (ha + lattices[b]->spacing);
            const Real reach = margin + ha + approach;
            if ((boxes[a].min.array() > boxes[b].max.array() + reach).any() ||
                (boxes[b].min.array() > boxes[a].max.array() + reach).any())
                continue;
            const std::vector<Index>& mine = points[a];
            std::vector<std::optional<BodyContact>> found(mine.size());
            parallelFor(static_cast<Index>(mine.size()), [&](Index k) {
                const Index p = mine[at(k)];
                const MeshDistance::Closest c = distance[b].closest((*x[a])[at(p)], reach);
                if (c.triangle < 0 || !(c.distance < reach)) return;
                BodyContact bc;
                bc.a = static_cast<int>(a);
                bc.p = p;
                bc.b = static_cast<int>(b);
                for (std::size_t j = 0; j < 3; ++j)
                    bc.q[j] = points[b][at(meshes[b].triangles[at(c.triangle)][j])];
                bc.w = c.barycentric;
                bc.normal = c.gradient;
                bc.margin = margin;
                bc.friction = friction;
                found[at(k)] = bc;
            });
            for (const auto& f : found)
                if (f) out.push_back(*f);
        }
}

}  // namespace dgv
