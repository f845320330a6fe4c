// Surfaces of deformed lattices for contact between objects (body_contact.hpp).

#include "sim/body_contact.hpp"

#include <array>

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

}  // namespace dgv
