// The frame loop of a scene's dynamics (simulation.hpp).

#include "sim/simulation.hpp"

#include "base/check.hpp"
#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "base/progress.hpp"
#include "base/types.hpp"
#include "collide/gln_network.hpp"
#include "geom/embedding.hpp"
#include "sim/forces_from_scene.hpp"
#include "sim/body_contact.hpp"
#include "sim/levelset_collider.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace dgv {

namespace {

/// Union-find over 0..n-1 (path halving): the groups of bodies that meet.
struct DisjointSets {
    std::vector<std::size_t> parent;
    explicit DisjointSets(std::size_t n) : parent(n) {
        for (std::size_t i = 0; i < n; ++i) parent[i] = i;
    }
    std::size_t root(std::size_t i) {
        while (parent[i] != i) i = parent[i] = parent[parent[i]];
        return i;
    }
    void join(std::size_t a, std::size_t b) { parent[root(a)] = root(b); }
};

}  // namespace

Simulation::Simulation(const SceneDesc& scene, const std::vector<const Lattice*>& lattices, bool always)
    : mScene(scene) {
    DGV_CHECK_EQ(lattices.size(), scene.objects.size());
    mField = forceFieldFromScene(scene.forces, scene.path);
    for (std::size_t i = 0; i < scene.colliders.size(); ++i) {
        const ColliderDesc& d = scene.colliders[i];
        Collider c;
        c.friction = d.friction;
        c.restitution = d.restitution;
        switch (d.type) {
            case ColliderType::Ground:
                c.kind = Collider::Kind::Plane;
                c.point = Vec3(0, d.height, 0);
                c.normal = Vec3::UnitY();
                break;
            case ColliderType::Plane:
                c.kind = Collider::Kind::Plane;
                c.point = d.centre;
                c.normal = d.normal.normalized();
                break;
            case ColliderType::Sphere:
                c.kind = Collider::Kind::Sphere;
                c.point = d.centre;
                c.radius = d.radius;
                break;
            case ColliderType::Mesh:
            case ColliderType::LevelSet: {
                const bool mesh = d.type == ColliderType::Mesh;
                if (!d.levelSet)  // a SceneDesc built by hand without loading the file
                    throw InputError(
                        scene.path, "colliders[" + std::to_string(i) + (mesh ? "].mesh" : "].file"),
                        (mesh ? "the mesh " + d.meshPath : "the level set " + d.levelSetPath) + " was not loaded");
                c.kind = Collider::Kind::Distance;
                // a mesh's distance grid is built in world space; a level set is placed by its transform
                c.distance = levelSetDistance(d.levelSet, mesh ? TransformDesc{} : d.transform);
                break;
            }
        }
        mColliders.push_back(std::move(c));
    }
    bool anyMotion = !scene.forces.empty();
    mBodies.resize(scene.objects.size());
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const ObjectDesc& o = scene.objects[i];
        if (!lattices[i] || !o.deformable) continue;
        if (o.velocity.squaredNorm() > 0 || o.spinDegrees.squaredNorm() > 0) anyMotion = true;
    }
    mActive = anyMotion;
    mFrame = scene.frameStart;
    mMostSubsteps = std::max(scene.substeps, scene.maxSubsteps);
    if (!mActive && !always) return;
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const ObjectDesc& o = scene.objects[i];
        if (!lattices[i] || !o.deformable || lattices[i]->size() == 0) continue;
        const Lattice& lat = *lattices[i];
        DynamicsSettings set;
        set.density = o.material.density;
        set.solver = o.material.solver == MaterialDesc::Solver::One ? StepSolver::One : StepSolver::Chain;
        {
            Real yMin = std::numeric_limits<Real>::infinity(), yMax = -yMin;
            for (Index p = 0; p < lat.size(); ++p) {
                yMin = std::min(yMin, lat.restPosition(p).y());
                yMax = std::max(yMax, lat.restPosition(p).y());
            }
            set.shapeStiffness = resolvedStiffness(o.material, 0.5 * (yMax - yMin + lat.spacing));
        }
        set.damping = resolvedDamping(o.material, set.shapeStiffness);
        set.viscosity = o.material.viscosity;
        if (o.material.stiffnessFrom != MaterialDesc::StiffnessFrom::Value || o.material.wobbles > 0) {
            char line[240];
            std::snprintf(line, sizeof line, "object '%s': stiffness %.4g/s^2 (a wobble of %.3g Hz), damping %.3g/s",
                          o.name.c_str(), set.shapeStiffness, std::sqrt(set.shapeStiffness) / 6.283185307179586,
                          set.damping);
            logInfo(line);
        }
        set.yieldStrain = o.material.yield;
        set.volumeTolerance = o.material.volumeTolerance;
        set.maxDeltaGamma = o.material.maxDeltaGamma;
        set.pinnedLoad = o.material.pinnedLoad;
        std::vector<unsigned char> pinned(at(lat.size()), 0);
        if (o.pin.kind == PinDesc::Kind::Group) {
            // The material points that carry the group's vertices: the corners of a vertex's
            // cell, or its anchor where the cell is not all material (geom/embedding).
            if (o.pin.groupVertices.empty())
                throw InputError(scene.path, "objects[" + std::to_string(i) + "].pin.group",
                                 "the vertex group '" + o.pin.group + "' has no vertices");
            const MeshEmbedding emb = embedVertices(lat, o.pin.groupVertices);
            for (std::size_t v = 0; v < emb.size(); ++v) {
                if (emb.trilinear(v)) {
                    for (const Index q : emb.corners[v]) pinned[at(q)] = 1;
                } else {
                    pinned[at(emb.anchor[v])] = 1;
                }
            }
        } else if (o.pin.kind != PinDesc::Kind::None) {
            for (Index p = 0; p < lat.size(); ++p) pinned[at(p)] = o.pin.contains(lat.restPosition(p)) ? 1 : 0;
        }
        // A large pinned body's load modes take seconds to make (docs/math.md, "A pinned body
        // under a uniform load": 17 s at 137k points on 2 cores): say so, rather than sit silent.
        const bool slowModes =
            set.pinnedLoad && lat.size() >= 20000 && std::find(pinned.begin(), pinned.end(), 1) != pinned.end();
        const auto made = std::chrono::steady_clock::now();
        if (slowModes) {
            char line[200];
            std::snprintf(line, sizeof line,
                          "object '%s': making the load modes of a pinned body of %lld points (once per run)",
                          o.name.c_str(), static_cast<long long>(lat.size()));
            logInfo(line);
        }
        try {
            mBodies[i] = std::make_unique<DeformableBody>(lat, restPositions(lat), set, pinned);
        } catch (const InputError& e) {
            throw InputError(scene.path, "objects[" + std::to_string(i) + "].material", e.problem());
        }
        if (slowModes) {
            char line[200];
            std::snprintf(line, sizeof line, "object '%s': load modes made in %.1f s", o.name.c_str(),
                          std::chrono::duration<double>(std::chrono::steady_clock::now() - made).count());
            logInfo(line);
        }
        mBodies[i]->setRigidVelocity(o.velocity, o.spinDegrees * (M_PI / 180.0));
    }
    fitSubsteps();
    // GLN contact detection (docs/gln.md): a network per body, R per collider and step.
    mNetworks.resize(mBodies.size());
    mObjectContact = scene.collision.objects &&
                     std::count_if(mBodies.begin(), mBodies.end(), [](const auto& b) { return b != nullptr; }) >= 2;
    mGlnDetect = scene.collision.detect == CollisionDesc::Detect::Gln && (!mColliders.empty() || mObjectContact);
    for (std::size_t i = 0; i < mBodies.size(); ++i) attachNetwork(i);
    // A body without pins is re-voxelised when its lattice no longer follows it: goo when its
    // lattice has distorted past the bound or it fails a frame, putty when it fails a frame at
    // every substep count; a jelly keeps its lattice (docs/math.md, "Re-parametrisation").
    mLattices = lattices;
    mRemapped.resize(mBodies.size());
    mRemapRefused.resize(mBodies.size());
    mRemapAllowed.assign(mBodies.size(), 0);
    for (std::size_t i = 0; i < mBodies.size(); ++i) {
        const ObjectDesc& o = scene.objects[i];
        mRemapAllowed[i] = mBodies[i] && o.material.reparametrise && !mBodies[i]->anyPinned() &&
                           (mBodies[i]->settings().shapeStiffness == 0 || mBodies[i]->settings().yieldStrain > 0);
    }
    mFrame = scene.frameStart;
}

Simulation::~Simulation() = default;

void Simulation::fitSubsteps() {
    // One of frameSubsteps' bounds is set by the scene alone, before anything moves: a chain-step
    // body's shape memory is a leapfrog oscillator, unstable past δt √k = 2 and kept at δt √k ≤ 1,
    // so it needs √k / fps substeps (the one solve is implicit in it). The jelly preset's k grows
    // as 1/size: a 0.1 mm ball wobbles at 352 Hz and needs 92 at 24 fps, where the default most
    // is 16 (32 on a retry): it faulted at frame 2. Measured on small balls and low frame rates,
    // every scene that needed more than 0.95 of the retry's count faulted, every one below ran;
    // such a scene gets the substeps it needs when it does not set max_substeps. One that sets
    // it, or a count past what dgv takes, is refused where no substep count it allows can be
    // stable (δt √k > 2 at the most a frame may take). (frameSubsteps' other bounds depend on
    // the motion: a goo ball of a micrometre, whose force bound asks for 700, runs at 16.)
    constexpr Real kRaiseAt = 0.95, kUnstable = 2;
    constexpr int kMostSubstepsAccepted = 1000;  // io/scene_json's range for max_substeps
    Real need = 0, stiffness = 0;
    std::size_t worst = 0;
    for (std::size_t i = 0; i < mBodies.size(); ++i) {
        const DeformableBody* b = mBodies[i].get();
        if (!b || b->settings().solver == StepSolver::One) continue;
        const Real k = b->settings().shapeStiffness, n = std::sqrt(k) / mScene.fps;
        if (n > need) {
            need = n;
            worst = i;
            stiffness = k;
        }
    }
    const int most = mMostSubsteps;  // the scene's (the constructor)
    const bool adaptive = most > mScene.substeps;
    auto ceilingOf = [&](int m) { return adaptive ? kRetrySubstepFactor * m : m; };  // the retry's count
    if (!(need > kRaiseAt * ceilingOf(most))) return;
    const int needed = static_cast<int>(std::ceil(std::min(need, Real(1e9))));
    char count[32];
    if (need <= 1e6)
        std::snprintf(count, sizeof count, "%d", needed);
    else
        std::snprintf(count, sizeof count, "%.3g", need);
    char line[400];
    std::snprintf(line, sizeof line,
                  "\"%s\" has a stiffness of %.3g/s^2 (a wobble of %.3g Hz), which needs %s substeps per frame at "
                  "%g fps",
                  mScene.objects[worst].name.c_str(), stiffness, std::sqrt(stiffness) / 6.283185307179586, count,
                  mScene.fps);
    if (mScene.maxSubstepsGiven) {
        if (need > kUnstable * ceilingOf(most))
            throw InputError(mScene.path, "max_substeps",
                             std::string(line) + ", more than max_substeps " + std::to_string(mScene.maxSubsteps) +
                                 " allows: set it to " + std::to_string(needed) + " or more");
        return;  // past the comfortable bound but not past stability: as the scene asks
    }
    const int raised = std::max(most, std::min(needed, kMostSubstepsAccepted));
    if (need > kUnstable * ceilingOf(raised)) {
        const Real fpsNeeded = 1.001 * std::sqrt(stiffness) / kMostSubstepsAccepted;  // rounded up when printed
        char fix[240];
        std::snprintf(fix, sizeof fix,
                      ", more than the %d dgv takes: raise frames.fps to %.3g or more, or make it larger or softer "
                      "(material.sag, wobble_hz or stiffness)",
                      kMostSubstepsAccepted, fpsNeeded);
        throw InputError(mScene.path, "objects[" + std::to_string(worst) + "].material", std::string(line) + fix);
    }
    mMostSubsteps = raised;
    logInfo(std::string(line) + ": up to " + std::to_string(mMostSubsteps) +
            " substeps per frame are taken (max_substeps sets the most)");
}

void Simulation::attachNetwork(std::size_t i) {
    if (!mGlnDetect || !mBodies[i]) return;
    GlnNetworkSettings gs;
    gs.coarseToFine = mScene.collision.coarseToFine;
    mNetworks[i] = std::make_unique<GlnNetwork>(mBodies[i]->lattice(), gs);
    const GlnNetwork* net = mNetworks[i].get();
    mBodies[i]->setContactDetector(
        [net](const std::vector<Vec3>& x, const Collider& col, std::vector<unsigned char>& R) {
            const SignedDistance phi = [&col](const Vec3& p, Vec3* g) {
                Vec3 gg;
                const Real v = col.evaluate(p, gg);
                if (g) *g = gg;
                return v;
            };
            net->contactSet(x, phi, R);
        });
}

const TriangleMesh* Simulation::surfaceMesh(std::size_t object) const {
    return object < mSurfaces.size() ? mSurfaces[object].mesh : nullptr;
}

const MeshEmbedding* Simulation::surfaceEmbedding(std::size_t object) const {
    return object < mSurfaces.size() ? mSurfaces[object].embedding : nullptr;
}

int Simulation::reparametrisations(std::size_t object) const {
    return object < mRemapped.size() ? mRemapped[object].count : 0;
}

void Simulation::installLattice(std::size_t i, Lattice lattice, DeformableBodyState state, TriangleMesh surface,
                                int remaps) {
    const DynamicsSettings settings = mBodies[i]->settings();
    Remapped r;
    r.count = remaps;
    const Lattice* lat = mLattices[i];
    if (remaps > 0) {
        r.lattice = std::make_unique<Lattice>(std::move(lattice));
        lat = r.lattice.get();
    }
    // A re-parametrised body is never pinned (mRemapAllowed), so its own lattice's body is not.
    auto body = std::make_unique<DeformableBody>(*lat, restPositions(*lat), settings);
    body->restoreState(std::move(state));
    mBodies[i] = std::move(body);  // the old body goes before the lattice it was built on
    mSurfaces.resize(mBodies.size());
    mOwnSurfaces.resize(mBodies.size());
    const bool surfaced = remaps > 0 && mOwnSurfaces[i].mesh && !surface.vertices.empty();
    if (surfaced) {
        r.mesh = std::move(surface);
        r.embedding = embedVertices(*lat, r.mesh.vertices);
        // The vertices outside the cells (the surface lies half a voxel beyond the lattice points)
        // follow their anchor's frame to first order: a goo boundary's second derivatives are
        // rough at the lattice scale, and the quadratic term threw them (torn edges).
        r.embedding.secondOrder = false;
    }
    mRemapped[i] = std::move(r);
    if (surfaced) {
        mSurfaces[i].mesh = &mRemapped[i].mesh;
        mSurfaces[i].embedding = &mRemapped[i].embedding;
        mSurfaces[i].setup = prepareSurfaceCheck(mRemapped[i].mesh);
    } else {
        mSurfaces[i] = mOwnSurfaces[i];
    }
    attachNetwork(i);
}

TriangleMesh Simulation::volumeSurface(std::size_t i) const {
    TriangleMesh m;
    if (!mSurfaceDistance || !mLevelSetMesher || !mBodies[i]) return m;
    const DeformableBody& b = *mBodies[i];
    const Real h = b.lattice().spacing;
    // A level set of the lattice's outer faces on the lattice's spacing, 3 voxels of band.
    SdfGrid g = mSurfaceDistance(latticeSurface(b.lattice(), b.positions()), h, 3);
    if (g.empty()) return m;
    for (float& v : g.values) v -= static_cast<float>(h / 2);
    m = mLevelSetMesher(g);
    // The level set of a voxel staircase keeps its steps; ten λ|μ pairs take them off.
    smoothTaubin(m, 10);
    return m;
}

bool Simulation::reparametriseBody(std::size_t i, int frame, const std::string& why) {
    const DeformableBody& b = *mBodies[i];
    Reparametrisation r = reparametrise(b);
    if (!r.refused.empty()) {
        if (mRemapRefused[i].empty())
            logInfo("frame " + std::to_string(frame) + ": object '" + mScene.objects[i].name + "' keeps its lattice (" +
                    why + "): " + r.refused);
        mRemapRefused[i] = r.refused;
        return false;
    }
    mRemapRefused[i].clear();
    char line[320];
    std::snprintf(line, sizeof line,
                  "frame %d: object '%s' re-voxelised in its current shape (%s): %lld -> %lld points, spacing x %.5f, "
                  "%.2f %% of its volume moved more than a cell, %.1f %% seen",
                  frame, mScene.objects[i].name.c_str(), why.c_str(), static_cast<long long>(b.lattice().size()),
                  static_cast<long long>(r.lattice.size()), r.dilation, 100 * r.mismatch, 100 * r.sampled);
    logInfo(line);
    // The surface from here on, in the new lattice's frame: goo's from its volume (or, without the
    // callbacks that make it, the old surface carried on); putty keeps its imported mesh, carried on.
    TriangleMesh surface;
    if (i < mSurfaces.size() && mSurfaces[i].mesh) {
        if (b.settings().shapeStiffness == 0) surface = volumeSurface(i);
        if (surface.vertices.empty()) {
            surface.triangles = mSurfaces[i].mesh->triangles;
            deformVertices(*mSurfaces[i].embedding, b.state(), surface.vertices);
        }
        for (Vec3& v : surface.vertices) v = r.pivot + r.dilation * (v - r.pivot);
    }
    installLattice(i, std::move(r.lattice), std::move(r.state), std::move(surface), mRemapped[i].count + 1);
    return true;
}

Index Simulation::reparametriseDistorted(int frame) {
    Index done = 0;
    for (std::size_t i = 0; i < mBodies.size(); ++i) {
        if (!mBodies[i] || i >= mRemapAllowed.size() || !mRemapAllowed[i]) continue;
        const DeformableBody& b = *mBodies[i];
        if (b.settings().shapeStiffness > 0) continue;  // putty: remapped only after a failed frame
        if (b.lastStepLength() == 0) continue;
        const LatticeDistortion d = latticeDistortion(b);
        if (!mRemapBound.exceeded(d)) continue;
        char why[160];
        std::snprintf(why, sizeof why, "max |Γ| %.2f, frame aspect %.1f, min det %.2f", d.maxGamma, d.maxAspect,
                      d.minFrameDet);
        if (reparametriseBody(i, frame, why)) ++done;
    }
    return done;
}

Real Simulation::PairSurface::distance(const Vec3& x, Vec3* gradient) const {
    if (exact) return exact->signedDistance(x, gradient, beyond);
    return sampled->distance(x, gradient);
}

bool Simulation::objectContact() const { return mObjectContact; }

void Simulation::forClosePairs(bool predicted, const PairFn& f) const {
    const std::size_t n = mBodies.size();
    auto positions = [&](std::size_t i) -> const std::vector<Vec3>& {
        return predicted ? mBodies[i]->predictedPositions() : mBodies[i]->positions();
    };
    // Each body's lattice points are kept (h_i + h_j)/2 outside body j's lattice surface: the
    // rendered surfaces reach about half a voxel beyond the lattice points, so the two meet.
    std::vector<Box3> boxes(n);
    for (std::size_t i = 0; i < n; ++i)
        if (mBodies[i])
            for (const Vec3& x : positions(i)) boxes[i].extend(x);
    std::vector<std::shared_ptr<const PairSurface>> surfaces(n);
    Real largestSpacing = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (mBodies[i]) largestSpacing = std::max(largestSpacing, mBodies[i]->lattice().spacing);
    for (std::size_t i = 0; i < n; ++i) {
        if (!mBodies[i]) continue;
        const Real hi = mBodies[i]->lattice().spacing;
        for (std::size_t j = 0; j < n; ++j) {
            if (j == i || !mBodies[j]) continue;
            const Real hj = mBodies[j]->lattice().spacing;
            const Real margin = 0.5 * (hi + hj);
            // Close enough to touch this substep: the boxes within the margin and two voxels.
            const Real pad = margin + 2 * std::max(hi, hj);
            if ((boxes[i].min.array() > boxes[j].max.array() + pad).any() ||
                (boxes[j].min.array() > boxes[i].max.array() + pad).any())
                continue;
            if (!surfaces[j]) {
                auto surface = std::make_shared<PairSurface>();
                TriangleMesh mesh = latticeSurface(mBodies[j]->lattice(), positions(j));
                if (mScene.collision.distance == CollisionDesc::Distance::Exact) {
                    surface->exact = std::make_shared<const MeshDistance>(mesh);
                    // Every margin a body keeps from j, (h_i + h_j)/2, is below 3 of the largest
                    // spacing: beyond that, a lower bound decides as well as the distance.
                    surface->beyond = 3 * largestSpacing;
                } else {
                    const Real voxel = 0.5 * hj;
                    const int band = std::max(3, static_cast<int>(std::ceil(2 * pad / voxel)) + 2);
                    if (mesh.triangles.empty())  // no complete cell: infinitely far, as exact has it
                        surface->exact = std::make_shared<const MeshDistance>(mesh);
                    else
                        surface->sampled = std::make_shared<const SampledDistance>(mesh, voxel, band);
                }
                surfaces[j] = std::move(surface);
            }
            f(i, j, margin, surfaces[j]);
        }
    }
}

std::vector<std::vector<Collider>> Simulation::substepColliders() const {
    std::vector<std::vector<Collider>> out(mBodies.size(), mColliders);
    if (!objectContact()) return out;
    // Whether each pair touches, decided once for both bodies: a point of either inside the
    // other (their lattice surfaces are faceted differently, so often only one side's points
    // are). The points of both push out of the other body, weighted as position-based dynamics
    // weights two points (by inverse mass: equal halves for the same density and voxel); when
    // only one side's points are inside, they take all of the push; with pins on either side,
    // both do, as at a static wall. Momentum is then put right for the pair as a whole
    // (keepPairMomentum).
    const std::size_t n = mBodies.size();
    struct Touch {
        bool near = false, inside = false;
        std::size_t slot = 0;
    };
    auto pointMass = [&](std::size_t i) {
        return mBodies[i]->totalMass() / static_cast<Real>(mBodies[i]->lattice().size());
    };
    std::vector<Touch> touch(n * n);
    forClosePairs(true, [&](std::size_t i, std::size_t j, Real margin,
                            const std::shared_ptr<const PairSurface>& distance) {
        Touch& t = touch[i * n + j];
        t.near = true;
        t.slot = out[i].size();
        for (const Vec3& x : mBodies[i]->predictedPositions())
            if (distance->distance(x) < margin) {
                t.inside = true;
                break;
            }
        Collider c;
        c.kind = Collider::Kind::Distance;
        c.friction = mScene.collision.friction;
        c.restitution = mScene.collision.restitution;
        c.object = true;
        c.body = static_cast<int>(j);
        c.velocity = mBodies[j]->predictedCentreVelocity();
        if (!mBodies[i]->anyPinned() && !mBodies[j]->anyPinned())
            c.share = pointMass(j) / (pointMass(i) + pointMass(j));
        c.distance = [surface = distance, margin](const Vec3& x, Vec3* g) { return surface->distance(x, g) - margin; };
        out[i].push_back(std::move(c));
    });
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
            const Touch& a = touch[i * n + j];
            const Touch& b = touch[j * n + i];
            if (!a.near || !b.near || !(a.inside || b.inside)) continue;
            Collider& ci = out[i][a.slot];
            Collider& cj = out[j][b.slot];
            if (!b.inside) ci.share = 1;  // only i's points are inside: they take all of the push
            if (!a.inside) cj.share = 1;
            ci.pairContact = cj.pairContact = true;
        }
    return out;
}

std::vector<std::vector<std::size_t>> Simulation::solveGroups(const std::vector<std::vector<Collider>>& colliders) const {
    // One-solve bodies close enough to touch this substep (an object collider between them)
    // are solved as one system; union-find over those pairs.
    const std::size_t n = mBodies.size();
    DisjointSets sets(n);
    auto one = [&](std::size_t i) { return mBodies[i] && mBodies[i]->settings().solver == StepSolver::One; };
    for (std::size_t i = 0; i < n; ++i) {
        if (!one(i)) continue;
        for (const Collider& c : colliders[i])
            if (c.object && c.body >= 0 && one(static_cast<std::size_t>(c.body)))
                sets.join(i, static_cast<std::size_t>(c.body));
    }
    std::vector<std::vector<std::size_t>> members(n), out(n);
    for (std::size_t i = 0; i < n; ++i)
        if (one(i)) members[sets.root(i)].push_back(i);
    for (std::size_t i = 0; i < n; ++i)
        if (one(i)) out[i] = members[sets.root(i)];
    return out;
}

void Simulation::solveGroup(const std::vector<std::size_t>& group, const std::vector<std::vector<Collider>>& colliders,
                            std::vector<StepReport>& reports, std::vector<unsigned char>& done) {
    // Each body's colliders less the bodies of the group (those meet in the solve), one solve of
    // them all, then each body's step finished.
    std::vector<CellSolveMember> members;
    std::vector<const Lattice*> lattices;
    for (std::size_t i : group) {
        std::vector<Collider> own;
        for (const Collider& c : colliders[i])
            if (!(c.object && std::find(group.begin(), group.end(), static_cast<std::size_t>(c.body)) != group.end()))
                own.push_back(c);
        members.push_back(mBodies[i]->beginSolve(own));
        lattices.push_back(&mBodies[i]->lattice());
    }
    // How far two bodies may close in the solve: twice the farthest a point's prediction goes.
    Real motion = 0;
    for (const CellSolveMember& m : members) {
        const std::vector<Vec3>& from = *m.in.feasible;
        const std::vector<Vec3>& to = *m.in.inertial;
        for (std::size_t p = 0; p < from.size(); ++p) motion = std::max(motion, (to[p] - from[p]).norm());
    }
    const Real friction = mScene.collision.friction;
    solveTogether(members, [&](const std::vector<const std::vector<Vec3>*>& x, std::vector<BodyContact>& out) {
        findBodyContacts(lattices, x, 2 * motion, friction, out);
    });
    // A group that nothing else holds (no pin, no collider) keeps its momentum: the minimiser
    // has Σ m (x − x̃) = 0 over the group (the contacts' forces balance); the solve stops within
    // its tolerance of it, and one shift of every point puts it right.
    bool free = true;
    for (std::size_t k = 0; k < group.size(); ++k)
        free = free && !mBodies[group[k]]->anyPinned() && members[k].report.colliderContacts == 0;
    if (free) {
        Vec3 off = Vec3::Zero();
        Real mass = 0;
        for (std::size_t k = 0; k < group.size(); ++k) {
            const std::vector<Real>& m = mBodies[group[k]]->masses();
            const std::vector<Vec3>& x = *members[k].x;
            const std::vector<Vec3>& xt = *members[k].in.inertial;
            for (std::size_t p = 0; p < m.size(); ++p) off += m[p] * (x[p] - xt[p]);
            mass += mBodies[group[k]]->totalMass();
        }
        for (CellSolveMember& m : members)
            for (Vec3& x : *m.x) x -= off / mass;
    }
    for (std::size_t k = 0; k < group.size(); ++k) {
        reports[group[k]] = mBodies[group[k]]->endSolve(members[k]);
        done[group[k]] = 1;
    }
}

void Simulation::keepPairMomentum(const std::vector<std::vector<Collider>>& colliders,
                                  const std::vector<unsigned char>& staticContact) {
    // Bodies touching each other (pairContact) form groups; a group in which no body is pinned
    // or touches a static collider exchanges momentum only within itself, so its momentum after
    // the step must be what the forces alone made it (the sum of the predicted centre
    // velocities times the masses). The pushes between the bodies, applied by each body to its
    // own points, do not balance exactly (the two lattice surfaces are faceted differently, and
    // a squashed body's spring-back pushes through position): the difference is removed as one
    // velocity shift of the whole group, which keeps every relative velocity.
    const std::size_t n = mBodies.size();
    DisjointSets sets(n);
    std::vector<unsigned char> touches(n, 0);
    for (std::size_t i = 0; i < n; ++i)
        for (const Collider& c : colliders[i])
            if (c.object && c.pairContact && c.body >= 0) {
                touches[i] = 1;
                sets.join(i, static_cast<std::size_t>(c.body));
            }
    std::vector<unsigned char> excluded(n, 0);
    std::vector<Vec3> gained(n, Vec3::Zero());
    std::vector<Real> mass(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
        if (!touches[i]) continue;
        const DeformableBody& b = *mBodies[i];
        const std::size_t r = sets.root(i);
        if (staticContact[i] || b.anyPinned()) excluded[r] = 1;
        gained[r] += b.totalMass() * (b.centreVelocity() - b.predictedCentreVelocity());
        mass[r] += b.totalMass();
    }
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t r = sets.root(i);
        if (touches[i] && !excluded[r]) mBodies[i]->shiftVelocity(-gained[r] / mass[r]);
    }
}

void Simulation::checkStartOverlap() const {
    if (!objectContact()) return;
    // The deepest point of each ordered pair; the first pair (in object order) past the bound is
    // reported, with its depth in world units and in voxels of the body whose point it is.
    std::size_t worstI = 0, worstJ = 0;
    Real worst = 0, worstVoxels = 0;
    forClosePairs(false,
                  [&](std::size_t i, std::size_t j, Real margin, const std::shared_ptr<const PairSurface>& distance) {
                      const Real h = mBodies[i]->lattice().spacing;
                      Real deepest = 0;
                      for (const Vec3& x : mBodies[i]->positions())
                          deepest = std::max(deepest, margin - distance->distance(x));
                      if (deepest / h > kStartOverlapVoxels && deepest / h > worstVoxels) {
                          worstI = i;
                          worstJ = j;
                          worst = deepest;
                          worstVoxels = deepest / h;
                      }
                  });
    if (worstVoxels == 0) return;
    const std::size_t a = std::min(worstI, worstJ), b = std::max(worstI, worstJ);
    char text[300];
    std::snprintf(text, sizeof text,
                  "objects '%s' and '%s' start inside each other, %.3g deep (%.1f voxels of '%s'); move them apart or "
                  "set collision.objects to false",
                  mScene.objects[a].name.c_str(), mScene.objects[b].name.c_str(), worst, worstVoxels,
                  mScene.objects[worstI].name.c_str());
    throw InputError(mScene.path, "objects[" + std::to_string(b) + "].transform", text);
}

Real Simulation::objectPenetration() const {
    Real deepest = 0;
    if (!objectContact()) return deepest;
    forClosePairs(false,
                  [&](std::size_t i, std::size_t, Real margin, const std::shared_ptr<const PairSurface>& distance) {
                      const Real h = mBodies[i]->lattice().spacing;
                      for (const Vec3& x : mBodies[i]->positions())
                          deepest = std::max(deepest, (margin - distance->distance(x)) / h);
                  });
    return deepest;
}

const DeformableBody* Simulation::body(std::size_t object) const {
    return object < mBodies.size() ? mBodies[object].get() : nullptr;
}

FrameStats Simulation::currentStats(int frame) const {
    FrameStats s;
    s.frame = frame;
    s.time = (frame - mScene.frameStart) / mScene.fps;
    Real total = 0, rest = 0;
    for (const auto& b : mBodies) {
        if (!b) continue;
        Real err = 0, drift = 0;
        Index inv = 0;
        b->volumeFigures(err, drift, inv);
        s.maxCellVolumeError = std::max(s.maxCellVolumeError, err);
        s.invertedCells += inv;
        Real r = 0;
        for (Real v : b->restVolumes()) r += v;
        rest += r;
        total += r * (1 + drift);
        for (Index p = 0; p < b->lattice().size(); ++p) {
            s.kineticEnergy += 0.5 * b->masses()[at(p)] * b->velocities()[at(p)].squaredNorm();
            s.contacts += b->contact()[at(p)] ? 1 : 0;
        }
    }
    s.totalVolumeDrift = rest > 0 ? total / rest - 1 : 0;
    return s;
}

int Simulation::frameSubsteps(int frame) const {
    // Adaptive substeps (docs/math.md, "Adaptive substeps"), enough that
    //  - no point moves more than `cfl` lattice spacings in one substep at the speed it had over
    //    the last one (a ball landing at 2.8 m/s, 3 spacings a step, folded the lattice at every
    //    stiffness; at 1.5 it landed);
    //  - the force at the frame's start moves a point from rest by at most a fifth of that in
    //    one substep, a δt² ≤ cfl h / 5 (a jelly resting on the ground, pushed into it by each
    //    substep's gravity: 0.34 of a spacing folded it at frame 21, 0.085 rested);
    //  - the shape memory's oscillator keeps δt √k ≤ 1 (its leapfrog is unstable past 2: a stiff
    //    ball in a vortex ran at 2.00 and faulted at 2.13);
    //  - the twist's change per substep stays within half its limiter at the last step's rate.
    // Within [substeps, max_substeps]; a function of the state, so a resumed run takes the same.
    const int lo = mScene.substeps, hi = std::max(lo, mMostSubsteps);
    if (hi == lo) return lo;
    const Real frameTime = 1 / mScene.fps;
    Real need = lo;
    for (std::size_t i = 0; i < mBodies.size(); ++i) {
        const DeformableBody* b = mBodies[i].get();
        if (!b) continue;
        const std::vector<Vec3>& v = b->velocities();
        const Real fastest = parallelReduce(
            b->lattice().size(), Real(0), [&](Real& acc, Index p) { acc = std::max(acc, v[at(p)].norm()); },
            [](Real x, Real y) { return std::max(x, y); });
        need = std::max(need, fastest * frameTime / (mScene.cfl * b->lattice().spacing));
        // The one-solve step is implicit in every force of the body: only the motion per substep
        // bounds it (how far a point may travel into a collider or another body in one solve).
        if (b->settings().solver == StepSolver::One) continue;
        ForceSamples fs;
        mField.sample(b->positions(), frame - 1, ForceOrder::Value, fs);
        const Real strongest = parallelReduce(
            b->lattice().size(), Real(0), [&](Real& acc, Index p) { acc = std::max(acc, fs.value[at(p)].norm()); },
            [](Real x, Real y) { return std::max(x, y); });
        need = std::max(need, frameTime * std::sqrt(strongest / (Real(0.2) * mScene.cfl * b->lattice().spacing)));
        need = std::max(need, std::sqrt(b->settings().shapeStiffness) * frameTime);
        if (b->lastStepLength() > 0) {
            const auto& dg = b->deltaGamma();
            const Real largest = parallelReduce(
                b->lattice().size(), Real(0),
                [&](Real& acc, Index p) {
                    acc = std::max(acc, std::sqrt(dg[0][at(p)].squaredNorm() + dg[1][at(p)].squaredNorm() +
                                                  dg[2][at(p)].squaredNorm()));
                },
                [](Real x, Real y) { return std::max(x, y); });
            const Real rate = largest / b->lastStepLength();  // per second
            need = std::max(need, rate * frameTime / (Real(0.5) * b->settings().maxDeltaGamma));
        }
    }
    if (!(need < hi)) return hi;  // also NaN
    return std::max(lo, static_cast<int>(std::ceil(need)));
}

std::string Simulation::faultHint(std::size_t i) const {
    // A pinned body with load modes that faults may be one held by a small patch (docs/math.md,
    // "What the step does not do yet"): the fault says what keeps it rigid instead.
    if (mBodies[i] && !mBodies[i]->loadModes().empty())
        return " (a pinned body held by a small patch is unstable: pin a face several voxels deep, or set "
               "material.pinned_load to false to hold it rigid)";
    return "";
}

void Simulation::setSurface(std::size_t object, const TriangleMesh* restMesh, const MeshEmbedding* embedding) {
    DGV_CHECK(object < mBodies.size());
    DGV_CHECK((restMesh == nullptr) == (embedding == nullptr));
    if (restMesh) DGV_CHECK_EQ(restMesh->vertices.size(), embedding->size());
    DGV_CHECK(reparametrisations(object) == 0);
    mSurfaces.resize(mBodies.size());
    mSurfaces[object].mesh = restMesh;
    mSurfaces[object].embedding = embedding;
    mSurfaces[object].setup = restMesh ? prepareSurfaceCheck(*restMesh) : SurfaceCheckSetup{};
    mOwnSurfaces.resize(mBodies.size());
    mOwnSurfaces[object] = mSurfaces[object];
}

void Simulation::drawnSurface(std::size_t i, std::vector<Vec3>& vertices) const {
    vertices.clear();
    const MeshEmbedding* embedding = surfaceEmbedding(i);
    if (i >= mBodies.size() || !mBodies[i] || !embedding) return;
    deformVertices(*embedding, mBodies[i]->state(), vertices);
    liftOutOfColliders(mColliders, vertices);
}

bool Simulation::checkSurfaces(FrameStats& s, int* failed, SurfaceCheck* failedCheck) const {
    SurfaceCheck all;  // the sums, for the stats; each body's surface passes or fails on its own
    bool allOk = true;
    if (failed) *failed = -1;
    std::vector<Vec3> deformed;
    for (std::size_t i = 0; i < mSurfaces.size() && i < mBodies.size(); ++i) {
        const DeformableBody* b = mBodies[i].get();
        if (!b || !mSurfaces[i].mesh) continue;
        deformVertices(*mSurfaces[i].embedding, b->state(), deformed);
        const SurfaceCheck c = checkSurface(mSurfaces[i].setup, *mSurfaces[i].mesh, *mSurfaces[i].embedding, b->state(),
                                            b->lattice().spacing, deformed);
        if (!c.ok()) {
            allOk = false;
            if (failed && *failed < 0) {
                *failed = static_cast<int>(i);
                if (failedCheck) *failedCheck = c;
            }
        }
        all.triangles += c.triangles;
        all.flippedTriangles += c.flippedTriangles;
        all.tornEdges += c.tornEdges;
        all.worstStretch = std::max(all.worstStretch, c.worstStretch);
    }
    s.flippedTriangles = all.flippedTriangles;
    s.tornEdges = all.tornEdges;
    s.surfaceStretch = all.worstStretch;
    return allOk;
}

FrameStats Simulation::advanceTo(int frame) {
    DGV_CHECK_EQ(frame, mFrame + 1);
    // Goo whose lattice no longer follows it is re-voxelised before the frame. A frame that faults
    // or tears its surface is simulated again from its start: goo re-voxelised first, then at
    // twice the substeps (docs/math.md, "Never a torn frame"). Nothing of the frame has been
    // written yet, and every decision is a function of the state, so a resumed run does the same.
    Index remaps = reparametriseDistorted(frame);
    int sub = frameSubsteps(frame);
    const int firstSub = sub;
    // A fixed count (max_substeps = substeps) stays fixed: such a frame fails without a retry.
    const int most = std::max(mScene.substeps, mMostSubsteps);
    const int cap = most > mScene.substeps ? std::max(sub, kRetrySubstepFactor * most) : sub;
    std::vector<ObjectState> start = saveState();
    std::vector<unsigned char> remappedForRetry(mBodies.size(), 0);
    std::string first;  // the first attempt's fault
    for (;;) {
        std::string fault;
        FaultKind kind = FaultKind::Unknown;
        int failed = -1;  // the body that failed, where known
        try {
            FrameStats s = simulateFrame(frame, sub);
            SurfaceCheck c;
            if (checkSurfaces(s, &failed, &c)) {
                if (!first.empty()) {
                    char line[160];
                    std::snprintf(line, sizeof line, "frame %d: simulated again at %d substeps after: ", frame, sub);
                    logInfo(line + first);
                }
                s.reparametrisations = remaps;
                return s;
            }
            char what[240];
            std::snprintf(what, sizeof what,
                          "dynamics [%s]: frame %d at %d substeps, object '%s': its surface folds or tears (%lld of "
                          "%lld triangles folded over, %lld edges torn)",
                          faultKindName(FaultKind::SurfaceTorn), frame, sub,
                          mScene.objects[static_cast<std::size_t>(failed)].name.c_str(),
                          static_cast<long long>(c.flippedTriangles), static_cast<long long>(c.triangles),
                          static_cast<long long>(c.tornEdges));
            fault = what + faultHint(static_cast<std::size_t>(failed));
            kind = FaultKind::SurfaceTorn;
        } catch (const NumericalError& e) {
            fault = e.what();
            kind = e.kind();
            failed = mFaultBody;
        }
        if (first.empty()) first = fault;
        restoreState(frame - 1, start);
        // A body that fails a frame is re-voxelised at the frame's start and the frame tried
        // again: a fresh lattice, whatever the bound said. Goo first, at the same substeps; putty
        // last, once more substeps have not helped, from the first count again (a frame that more
        // substeps carry keeps its lattice, and its shot its frames).
        const std::size_t fb = static_cast<std::size_t>(failed);
        const bool remappable = failed >= 0 && fb < mBodies.size() && mRemapAllowed[fb] && !remappedForRetry[fb] &&
                                mBodies[fb]->lastStepLength() > 0;
        const bool lastResort = remappable && mBodies[fb]->settings().shapeStiffness > 0;  // putty
        if (remappable && (!lastResort || sub >= cap)) {
            remappedForRetry[fb] = 1;
            if (reparametriseBody(fb, frame,
                                  lastResort ? "it failed the frame at " + std::to_string(firstSub) + " to " +
                                                   std::to_string(sub) + " substeps"
                                             : std::string("it failed the frame"))) {
                ++remaps;
                start = saveState();
                if (lastResort) sub = firstSub;
                continue;
            }
        }
        if (sub >= cap)
            throw NumericalError(fault + " (tried at " + std::to_string(firstSub) + " to " + std::to_string(sub) +
                                     " substeps; nothing of frame " + std::to_string(frame) + " was written)",
                                 kind);
        sub = std::min(cap, 2 * sub);
    }
}

FrameStats Simulation::simulateFrame(int frame, int sub) {
    mFaultBody = -1;
    FrameStats s;
    s.frame = frame;
    s.time = (frame - mScene.frameStart) / mScene.fps;
    s.substeps = sub;
    const Real dt = 1 / (mScene.fps * sub);
    double seconds = 0;
    if (mSubstepObserver) mSubstepObserver(frame, 0, sub);
    for (int k = 0; k < sub; ++k) {
        const Real fieldFrame = (frame - 1) + Real(k) / sub;
        const auto t0 = std::chrono::steady_clock::now();
        bool first = true;
        auto where = [&](std::size_t i) {
            return "frame " + std::to_string(frame) + ", substep " + std::to_string(k + 1) + " of " +
                   std::to_string(sub) + ", object '" + mScene.objects[i].name + "'";
        };
        auto fault = [&](std::size_t i, const std::string& what, FaultKind kind) {
            mFaultBody = static_cast<int>(i);
            if (kind == FaultKind::None) kind = FaultKind::Unknown;  // a fault its site did not classify
            return NumericalError(
                "dynamics [" + std::string(faultKindName(kind)) + "]: " + where(i) + ": " + what + faultHint(i), kind);
        };
        // Every body's prediction first, so the bodies meet each other where they are going.
        for (std::size_t i = 0; i < mBodies.size(); ++i) {
            if (!mBodies[i]) continue;
            const StepReport r = mBodies[i]->predict(mField, fieldFrame, dt);
            if (!r.fault.empty()) throw fault(i, r.fault, r.faultKind);
        }
        const std::vector<std::vector<Collider>> colliders = substepColliders();
        std::vector<unsigned char> staticContact(mBodies.size(), 0);
        const std::vector<std::vector<std::size_t>> groups = solveGroups(colliders);
        std::vector<StepReport> grouped(mBodies.size());
        std::vector<unsigned char> done(mBodies.size(), 0);
        for (std::size_t i = 0; i < mBodies.size(); ++i) {
            if (!mBodies[i]) continue;
            if (!done[i] && groups[i].size() > 1) solveGroup(groups[i], colliders, grouped, done);
            const StepReport r = done[i] ? std::move(grouped[i]) : mBodies[i]->finish(colliders[i]);
            staticContact[i] = r.staticContact ? 1 : 0;
            if (!r.fault.empty()) throw fault(i, r.fault, r.faultKind);
            for (const Vec3& x : mBodies[i]->positions())
                if (!allFiniteNoTrap(x))
                    throw fault(i, "a position became non-finite; use more substeps or damping", FaultKind::NonFinite);
            s.maxCellVolumeError = std::max(s.maxCellVolumeError, r.maxCellVolumeError);
            s.invertedCells = std::max(s.invertedCells, r.invertedCells);
            s.limitedPoints += r.limitedPoints;
            s.maxPenetration = std::max(s.maxPenetration, r.maxPenetration / mBodies[i]->lattice().spacing);
            s.contactSetSize += r.contacts;
            s.contactTruth += r.contactTruth;
            s.contactTruePositive += r.contactTruePositive;
            s.solveIterations = std::max(s.solveIterations, r.solveIterations);
            s.solveUnconverged += r.solveConverged ? 0 : 1;
            if (first) s.lastStep = r;
            first = false;
        }
        if (mObjectContact) keepPairMomentum(colliders, staticContact);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (mSubstepObserver) mSubstepObserver(frame, k + 1, sub);
    }
    // Penetration between bodies, once both have moved: at the end of the frame (each body's
    // step leaves it out: its share of the push leaves the rest to the other body).
    s.maxPenetration = std::max(s.maxPenetration, objectPenetration());
    mFrame = frame;
    const FrameStats now = currentStats(frame);
    s.kineticEnergy = now.kineticEnergy;
    s.totalVolumeDrift = now.totalVolumeDrift;
    s.contacts = now.contacts;
    s.maxCellVolumeError = std::max(s.maxCellVolumeError, now.maxCellVolumeError);
    for (const auto& b : mBodies) {
        if (!b) continue;
        s.sumDeltaGamma2 += b->sumDeltaGamma2();
    }
    s.stepMs = 1000 * seconds / sub;
    return s;
}

std::vector<Simulation::ObjectState> Simulation::saveState() const {
    std::vector<ObjectState> out(mBodies.size());
    for (std::size_t i = 0; i < mBodies.size(); ++i)
        if (mBodies[i]) {
            out[i].present = true;
            out[i].body = mBodies[i]->saveState();
            const Remapped& r = mRemapped[i];
            out[i].remaps = r.count;
            if (r.count > 0) {
                out[i].latticeOrigin = r.lattice->originWorld;
                out[i].latticeSpacing = r.lattice->spacing;
                out[i].latticeDims = r.lattice->dims;
                out[i].latticeCoords = r.lattice->coords;
                out[i].surfaceVertices = r.mesh.vertices;
                out[i].surfaceTriangles = r.mesh.triangles;
            }
        }
    return out;
}

bool Simulation::onCurrentLattice(std::size_t i, const ObjectState& o) const {
    return o.remaps == mRemapped[i].count && (o.remaps == 0 || o.latticeCoords == mRemapped[i].lattice->coords);
}

bool Simulation::stateFits(const std::vector<ObjectState>& states) const {
    if (states.size() != mBodies.size()) return false;
    for (std::size_t i = 0; i < mBodies.size(); ++i) {
        const ObjectState& o = states[i];
        if (o.present != (mBodies[i] != nullptr)) return false;
        if (!mBodies[i]) continue;
        if (o.remaps < 0 || (o.remaps > 0 && !mRemapAllowed[i])) return false;
        if (onCurrentLattice(i, o)) {
            if (!mBodies[i]->stateFits(o.body)) return false;
            continue;
        }
        // Another lattice than the body's now: the arrays must fit a body built on it.
        const std::size_t n = o.remaps > 0 ? o.latticeCoords.size() : static_cast<std::size_t>(mLattices[i]->size());
        if (o.remaps > 0) {
            if (!(o.latticeSpacing > 0) || (o.latticeDims.array() <= 0).any()) return false;
            for (const Vec3i& u : o.latticeCoords)
                if ((u.array() < 0).any() || (u.array() >= o.latticeDims.array()).any()) return false;
            for (const std::array<int, 3>& t : o.surfaceTriangles)
                for (const int v : t)
                    if (v < 0 || static_cast<std::size_t>(v) >= o.surfaceVertices.size()) return false;
        }
        if (o.body.positions.size() != n || o.body.velocities.size() != n || o.body.deltaGamma[0].size() != n)
            return false;
    }
    return true;
}

void Simulation::restoreState(int frame, std::vector<ObjectState> states) {
    DGV_CHECK(stateFits(states));
    DGV_CHECK(frame >= mScene.frameStart);
    for (std::size_t i = 0; i < mBodies.size(); ++i) {
        if (!mBodies[i]) continue;
        ObjectState& o = states[i];
        if (onCurrentLattice(i, o)) {
            mBodies[i]->restoreState(std::move(o.body));
            continue;
        }
        Lattice lat;
        if (o.remaps > 0) {
            std::vector<unsigned char> mask(static_cast<std::size_t>(o.latticeDims.prod()), 0);
            lat.dims = o.latticeDims;
            for (const Vec3i& u : o.latticeCoords) mask[at(lat.linearIndex(u))] = 1;
            lat = buildLattice(o.latticeOrigin, o.latticeSpacing, o.latticeDims, mask);
            DGV_CHECK(lat.coords == o.latticeCoords);
        }
        TriangleMesh surface;
        surface.vertices = std::move(o.surfaceVertices);
        surface.triangles = std::move(o.surfaceTriangles);
        installLattice(i, std::move(lat), std::move(o.body), std::move(surface), o.remaps);
    }
    mFrame = frame;
}


}  // namespace dgv
