// The scene's colliders as surfaces to draw (collider_draw.hpp).

#include "app/collider_draw.hpp"

#include "geom/primitives.hpp"
#include "io/vdb_mesh.hpp"

#include <cmath>

namespace dgv::app {

std::vector<DrawMesh> colliderDrawMeshes(const SceneDesc& scene) {
    std::vector<DrawMesh> out;
    for (const ColliderDesc& c : scene.colliders) {
        if (c.type == ColliderType::Sphere) {
            // 128 x 64 facets: within r (1 - cos(pi/128)) = 0.03 % of the radius of the true
            // sphere the bodies collide with.
            const TriangleMesh local = makeSphere(c.radius, 128, 64);
            DrawMesh m;
            m.positions.reserve(local.vertices.size());
            for (const Vec3& v : local.vertices) m.positions.push_back(v + c.centre);
            m.triangles = local.triangles;
            m.colour = colliderColour();
            m.creasePositions = m.positions;
            out.push_back(std::move(m));
            continue;
        }
        if (c.type == ColliderType::Plane) {
            // A square of side `size` centred on the point, in 64 x 64 cells (the footprint's
            // ramp is per vertex), two-sided.
            constexpr int kCells = 64;
            const Vec3 n = c.normal.normalized();
            const Vec3 u = (std::abs(n.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitX()).cross(n).normalized();
            const Vec3 v = n.cross(u);
            DrawMesh m;
            for (int j = 0; j <= kCells; ++j)
                for (int i = 0; i <= kCells; ++i)
                    m.positions.push_back(c.centre + c.size * ((Real(i) / kCells - 0.5) * u + (Real(j) / kCells - 0.5) * v));
            for (int j = 0; j < kCells; ++j)
                for (int i = 0; i < kCells; ++i) {
                    const int a = j * (kCells + 1) + i, b = a + 1, d = a + kCells + 1, e = d + 1;
                    m.triangles.push_back({a, b, e});  // counter-clockwise seen from the free side
                    m.triangles.push_back({a, e, d});
                }
            m.colour = colliderColour();
            m.creasePositions = m.positions;
            out.push_back(std::move(m));
            continue;
        }
        if (c.type == ColliderType::Mesh && c.worldMesh) {
            DrawMesh m;
            m.positions = c.worldMesh->vertices;
            m.triangles = c.worldMesh->triangles;
            m.colour = colliderColour();
            m.creasePositions = m.positions;
            out.push_back(std::move(m));
            continue;
        }
        if (c.type != ColliderType::LevelSet || !c.levelSet) continue;
        const TriangleMesh local = levelSetMesh(*c.levelSet);
        const Mat3 A = c.transform.linear();
        DrawMesh m;
        m.positions.reserve(local.vertices.size());
        for (const Vec3& v : local.vertices) m.positions.push_back(A * v + c.transform.translate);
        m.triangles = local.triangles;
        m.colour = colliderColour();
        m.creasePositions = m.positions;
        out.push_back(std::move(m));
    }
    return out;
}

}  // namespace dgv::app
