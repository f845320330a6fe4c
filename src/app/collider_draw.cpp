// The scene's colliders as surfaces to draw (collider_draw.hpp).

#include "app/collider_draw.hpp"

#include "geom/primitives.hpp"
#include "io/vdb_mesh.hpp"

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
