// The simulation's state as a drawable frame (frame_view.hpp).

#include "view/frame_view.hpp"

#include "base/check.hpp"
#include "base/progress.hpp"
#include "view/lattice_overlay.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace dgv {

namespace {

/// Passes of smoothVertexScalar over a body's highlight: enough to round off the lattice's
/// steps on the shipped scenes' meshes (2-4 triangles a voxel), not so many that it blurs the
/// patch (each pass reaches one triangle further).
constexpr int kHighlightSmoothing = 4;

}  // namespace

FrameView::FrameView(const SceneDesc& scene, std::vector<ViewObject> objects, std::vector<DrawMesh> colliders)
    : mRender(scene.render), mObjects(std::move(objects)) {
    const RenderDesc& rd = mRender;
    for (const ViewObject& o : mObjects) mBounds.extend(meshBounds(*o.restMesh));
    mFrame.groundPlane = rd.ground;
    // A ground collider is drawn as the render's ground plane, at its height (the highest, if
    // there are several): a falling body then approaches a fixed floor.
    for (const ColliderDesc& c : scene.colliders)
        if (c.type == ColliderType::Ground)
            mFrame.groundHeight = std::max(mFrame.groundHeight.value_or(c.height), c.height);
    mFrame.meshes.resize(mObjects.size());
    for (std::size_t i = 0; i < mObjects.size(); ++i) {
        mFrame.meshes[i].triangles = mObjects[i].restMesh->triangles;
        mFrame.meshes[i].colour = mObjects[i].colour;
        mFrame.meshes[i].creasePositions = mObjects[i].restMesh->vertices;  // same split for any --frames
        const TriangleMesh& rest = *mObjects[i].restMesh;
        if (rest.hasMaterials()) {  // the file's look, carried by the rest triangles as they deform
            mFrame.meshes[i].triangleMaterials = rest.triangleMaterials;
            mFrame.meshes[i].cornerUvs = rest.cornerUvs;
            mFrame.meshes[i].materials = rest.materials;
        }
    }
    // Static colliders after the objects, framed with them.
    mFirstCollider = mFrame.meshes.size();
    for (DrawMesh& m : colliders) {
        for (const Vec3& p : m.positions) mBounds.extend(p);
        m.opacity = rd.colliderOpacity;  // render.collider_opacity: see the contact behind
        mFrame.meshes.push_back(std::move(m));
    }
    // A moving shot without a ground collider: a floor under each frame's lowest point followed
    // the bodies, so floating goo looked as if it slid on a table, and a floor under the whole
    // shot's lowest point is not known until the shot has run (a range of frames rendered on a
    // farm must draw the same floor as the whole). So the floor is off; where the scene sets
    // render.ground, it is fixed under the shapes at rest (what passes below it is cut by it).
    if (!mFrame.groundHeight && sceneMoves(scene)) {
        if (rd.groundGiven && rd.ground && !mBounds.empty())
            mFrame.groundHeight = mBounds.min.y();
        else
            mFrame.groundPlane = false;
    }
    // Contact highlighting (render.contact): the contact set R as a ramp on each moving surface.
    for (std::size_t i = 0; i < mObjects.size(); ++i) {
        ScalarRamp& ramp = mFrame.meshes[i].ramp;
        // Colours not given are chosen to stand out from the surface (an orange putty gets blue).
        const HighlightColours auto_ = contrastingHighlight(mObjects[i].colour);
        ramp.high = rd.contactHighSet ? rd.contactHigh : auto_.high;
        ramp.glow = rd.contactGlow;
        if (rd.contactMode == ContactHighlightMode::Recent) {
            // From `high` (in R now) back to `low`, by default the surface's own colour.
            ramp.low = rd.contactLowSet ? rd.contactLow : mObjects[i].colour;
            ramp.min = 0;
            ramp.max = 1;
        } else {
            // Scalars are depth + edge in R and -edge outside (contactPointScalar).
            const Real depthMax = rd.contactDepthMax > 0 ? rd.contactDepthMax : mObjects[i].lattice->spacing;
            ramp.low = rd.contactLowSet ? rd.contactLow : auto_.low;
            ramp.min = 0.25 * depthMax;
            ramp.max = 1.25 * depthMax;
        }
    }
    // Footprints (render.contact.footprint): the colliders carry the highlight where bodies
    // touch them, from the collider's colour to the highlight's, and the ground plane takes
    // marks, so a contact under a body or on its far side still shows around it. Each body's
    // contacts show in its own highlight colour, on the body and on what it touches.
    if (footprints())
        for (std::size_t m = mFirstCollider; m < mFrame.meshes.size(); ++m) {
            Box3 box;
            for (const Vec3& v : mFrame.meshes[m].positions) box.extend(v);
            mColliderBounds.push_back(box);
            mFrame.meshes[m].ramp.low = mFrame.meshes[m].colour;
            mFrame.meshes[m].ramp.min = 0;
            mFrame.meshes[m].ramp.max = 1;
            mFrame.meshes[m].ramp.glow = rd.contactGlow;
        }
    mFrame.groundMarkGlow = rd.contactGlow;
    // render.pins: each object's pinned lattice points as dots, after the lattice overlay's.
    mFirstPinSet = rd.overlayLattice ? mObjects.size() : 0;
    if (rd.pins) {
        mFrame.points.resize(mFirstPinSet + mObjects.size());
        for (std::size_t i = 0; i < mObjects.size(); ++i) {
            PointSet& pins = mFrame.points[mFirstPinSet + i];
            pins.colour = rd.pinColour;
            pins.size = rd.pinPointSize;
            pins.onTop = false;  // the pins on the near side, as the body hides the rest
        }
    }
    // render.overlays.lattice: the points drawn, per object (lattice_set "boundary": the
    // surface layer facing the camera, so the dots do not stack into stripes through the body).
    mLatticeShown.resize(mObjects.size());
    if (rd.overlayLattice) {
        mFrame.points.resize(std::max(mFrame.points.size(), mObjects.size()));
        for (std::size_t i = 0; i < mObjects.size(); ++i) {
            mFrame.points[i].colour = rd.overlayLatticeColour;
            mFrame.points[i].size = rd.overlayPointSize;
            if (rd.overlayLatticeSet == LatticeDotSet::Boundary)
                mLatticeShown[i] = boundaryPoints(*mObjects[i].lattice);
        }
    }
    // GLN network loops (render.overlays.gln_loops): each object's network built here as the
    // simulation builds it (the loops depend only on the lattice), so the loops can be shown
    // whichever way the scene detects contact.
    mLoopNetworks.resize(mObjects.size());
    if (rd.overlayGlnLoops) {
        if (rd.overlayGlnLoopSet == GlnLoopSet::Contact && scene.collision.detect != CollisionDesc::Detect::Gln)
            logInfo(
                "render.overlays.gln_loops: collision.detect is not \"gln\", so the loops drawn are those of the "
                "points in the signed-distance contact set");
        for (std::size_t i = 0; i < mObjects.size(); ++i)
            if (mObjects[i].lattice->size() > 0) mLoopNetworks[i] = std::make_unique<GlnNetwork>(*mObjects[i].lattice);
    }
}

FrameView::~FrameView() = default;

const FrameScene& FrameView::update(const std::vector<ViewBody>& bodies, const Camera& camera) {
    DGV_CHECK_EQ(bodies.size(), mObjects.size());
    const RenderDesc& rd = mRender;
    if (rd.overlayGlnLoops) mFrame.lines.clear();  // this frame's loops replace the last frame's
    // The points that mark the colliders this frame: where, how strongly (0..1], how wide.
    std::vector<Vec3> markPoints;
    std::vector<Real> markValues, markRadii;
    std::vector<std::size_t> markBody;
    for (std::size_t i = 0; i < mObjects.size(); ++i) {
        const ViewObject& object = mObjects[i];
        const DeformableBody* body = bodies[i].body;
        DrawMesh& mesh = mFrame.meshes[i];
        // A re-parametrised body (goo) lives on a lattice of its own: the overlays made on the
        // object's lattice do not fit it.
        const bool ownLattice = !body || &body->lattice() == object.lattice;
        if (body && bodies[i].surface != object.restMesh && mesh.triangles != bodies[i].surface->triangles) {
            mesh.triangles = bodies[i].surface->triangles;
            mesh.creasePositions = bodies[i].surface->vertices;
            // A surface taken anew from the volume (goo's re-parametrisation) has no texture
            // coordinates: from here on drawn in the object's colour.
            mesh.triangleMaterials.clear();
            mesh.cornerUvs.clear();
        }
        if (body && bodies[i].vertices && bodies[i].vertices->size() == bodies[i].embedding->size())
            mesh.positions = *bodies[i].vertices;
        else
            deformVertices(body ? *bodies[i].embedding : *object.embedding, body ? body->state() : *object.state,
                           mesh.positions);
        if (rd.contactMode != ContactHighlightMode::Off && body) {
            std::vector<Real> pointValue =
                contactPointScalar(rd.contactMode, body->contact(), body->contactDepth(), *bodies[i].contactAge,
                                   rd.contactFadeFrames, mesh.ramp.min);
            if (footprints()) {
                const std::vector<Vec3>& x = body->state().position;
                const Real reach = body->lattice().spacing * (1 + rd.contactSpread);
                for (std::size_t p = 0; p < pointValue.size() && p < x.size(); ++p)
                    if (pointValue[p] > 0) {
                        markPoints.push_back(x[p]);
                        // Depth: every point in R at full strength; recent: as it fades.
                        markValues.push_back(rd.contactMode == ContactHighlightMode::Depth ? Real(1) : pointValue[p]);
                        markRadii.push_back(reach);
                        markBody.push_back(i);
                    }
            }
            spreadPointScalar(body->lattice(), pointValue, rd.contactSpread);
            pointScalarToVertices(*bodies[i].embedding, pointValue, mesh.scalar);
            smoothVertexScalar(mesh.triangles, mesh.scalar, kHighlightSmoothing);
        }
        if (rd.overlayLattice) {
            const std::vector<Vec3>& x = (body ? body->state() : *object.state).position;
            mFrame.points[i].points = rd.overlayLatticeSet == LatticeDotSet::All || !ownLattice
                                          ? x
                                          : latticeOverlayPoints(*object.lattice, x, mLatticeShown[i], &camera.eye);
        }
        if (rd.pins) {
            std::vector<Vec3>& dots = mFrame.points[mFirstPinSet + i].points;
            dots.clear();
            if (body && body->anyPinned()) {
                const std::vector<Vec3>& x = body->state().position;
                for (std::size_t p = 0; p < body->pinned().size() && p < x.size(); ++p)
                    if (body->pinned()[p]) dots.push_back(x[p]);
            }
        }
        if (mLoopNetworks[i] && ownLattice) {
            static const std::vector<unsigned char> kNoContact;
            for (ClosedCurve& loop : glnOverlayLoops(*mLoopNetworks[i], rd.overlayGlnLoopSet,
                                                     (body ? body->state() : *object.state).position,
                                                     body ? body->contact() : kNoContact, &camera.eye)) {
                Polyline line;
                line.points = std::move(loop);
                line.colour = rd.overlayGlnColour;
                line.width = rd.overlayLineWidth;
                line.onTop = true;  // the rings lie on boundary lattice points, under the surface
                mFrame.lines.push_back(std::move(line));
            }
        }
    }
    if (footprints()) {
        Real reach = 0;
        for (Real r : markRadii) reach = std::max(reach, r);
        for (std::size_t m = mFirstCollider; m < mFrame.meshes.size(); ++m) {
            DrawMesh& collider = mFrame.meshes[m];
            footprintScalar(collider.positions, markPoints, markValues, reach, 1e-3, collider.scalar);
            // One ramp per collider: the colour of the body it is touched by most (the
            // first such body on a tie), judged by the marks within reach of its bounds.
            const Box3& box = mColliderBounds[m - mFirstCollider];
            std::vector<std::size_t> near(mObjects.size(), 0);
            for (std::size_t k = 0; k < markPoints.size(); ++k)
                if ((markPoints[k].array() >= box.min.array() - reach).all() &&
                    (markPoints[k].array() <= box.max.array() + reach).all())
                    ++near[markBody[k]];
            const std::size_t most =
                static_cast<std::size_t>(std::max_element(near.begin(), near.end()) - near.begin());
            collider.ramp.high = mFrame.meshes[most].ramp.high;
        }
        // Ground marks from the points within a lattice step of the drawn ground plane.
        mFrame.groundMarks.clear();
        if (mFrame.groundHeight && mFrame.groundPlane)
            for (std::size_t k = 0; k < markPoints.size(); ++k) {
                const Real step = markRadii[k] / (1 + rd.contactSpread);
                if (std::abs(markPoints[k].y() - *mFrame.groundHeight) > step) continue;
                GroundMark g;
                g.x = markPoints[k].x();
                g.z = markPoints[k].z();
                g.radius = markRadii[k];
                g.colour = mFrame.meshes[markBody[k]].ramp.high;
                g.strength = markValues[k];
                mFrame.groundMarks.push_back(g);
            }
    }
    return mFrame;
}

}  // namespace dgv
