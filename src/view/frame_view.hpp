#pragma once
/// @file frame_view.hpp
/// @brief The simulation's state as a drawable frame: the scene's objects and colliders as the
/// renderer's FrameScene, with the render settings' contact highlight (on the bodies, the
/// colliders' footprints and the ground's marks), the lattice dots, the pins and the GLN loops
/// (docs/rendering.md, "Contact highlighting" and "Overlays"). Built once per render from the
/// scene and its objects at rest; updated each frame from the bodies as the dynamics left them.
/// Reads no file and writes none: the colliders' drawn surfaces come in ready-made.
#include "base/types.hpp"
#include "collide/gln_network.hpp"
#include "dynamics/stepper.hpp"
#include "geom/embedding.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"
#include "render/camera.hpp"
#include "render/renderer.hpp"
#include "sim/scene.hpp"
#include "view/contact_highlight.hpp"
#include "view/gln_overlay.hpp"

#include <cstddef>
#include <memory>
#include <vector>

namespace dgv {

/// One scene object at rest, as it was built (the pointers must outlive the view).
struct ViewObject {
    const TriangleMesh* restMesh = nullptr;    ///< world space, at rest
    const Lattice* lattice = nullptr;          ///< its material lattice
    const MeshEmbedding* embedding = nullptr;  ///< restMesh in that lattice
    const GeometricState* state = nullptr;     ///< the lattice at rest
    Vec3 colour = Vec3::Constant(0.8);         ///< linear RGB
};

/// What this frame's dynamics shows of one object.
struct ViewBody {
    const DeformableBody* body = nullptr;          ///< null: the object is drawn at rest
    const TriangleMesh* surface = nullptr;         ///< its surface on the body's lattice now (goo remaps it)
    const MeshEmbedding* embedding = nullptr;      ///< ... and its embedding there
    const std::vector<int>* contactAge = nullptr;  ///< ContactHistory::age of its points
    /// The surface's deformed vertices to draw (a motion blur sample between substeps); null:
    /// from the body's state now.
    const std::vector<Vec3>* vertices = nullptr;
};

class FrameView {
public:
    /// @param colliders the static colliders' drawn surfaces (level sets: their zero isosurface),
    ///                  drawn after the objects and framed with them
    FrameView(const SceneDesc& scene, std::vector<ViewObject> objects, std::vector<DrawMesh> colliders);
    ~FrameView();
    FrameView(const FrameView&) = delete;
    FrameView& operator=(const FrameView&) = delete;

    /// The objects at rest and the colliders: what the camera frames.
    const Box3& bounds() const { return mBounds; }
    /// Redraws every object from `bodies` (one per object) for `camera`: positions, highlight,
    /// footprints, ground marks, dots and loops. Returns the frame to render.
    const FrameScene& update(const std::vector<ViewBody>& bodies, const Camera& camera);

private:
    /// A highlight is drawn and render.contact.footprint is on: the colliders and ground are marked.
    bool footprints() const { return mRender.contactMode != ContactHighlightMode::Off && mRender.contactFootprint; }

    RenderDesc mRender;  ///< the scene's render settings (a copy: the view outlives no scene)
    std::vector<ViewObject> mObjects;
    FrameScene mFrame;
    Box3 mBounds;
    std::size_t mFirstCollider = 0;                 ///< mFrame.meshes: the objects', then the colliders'
    std::size_t mFirstPinSet = 0;                   ///< mFrame.points: the lattice dots', then the pins'
    bool mFootprints = false;                       ///< a highlight is drawn and render.contact.footprint is on
    std::vector<Box3> mColliderBounds;              ///< the static colliders' bounds (footprints)
    std::vector<std::vector<Index>> mLatticeShown;  ///< per object: the dots' candidate points
    std::vector<std::unique_ptr<GlnNetwork>> mLoopNetworks;  ///< per object (gln_loops)
};

}  // namespace dgv
