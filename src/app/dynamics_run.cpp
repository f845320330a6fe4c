// A scene's dynamics as the commands drive it (dynamics_run.hpp).

#include "app/dynamics_run.hpp"

#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/gltf_cache.hpp"
#include "io/state_file.hpp"
#include "io/stats_csv.hpp"
#include "io/vdb_cache.hpp"
#include "io/vdb_mesh.hpp"
#include "io/vdb_read.hpp"

#include <algorithm>
#include <filesystem>

namespace dgv::app {
namespace fs = std::filesystem;

/// Parses "A-B" or "N" and checks it lies within the scene's frame range.
void overrideSolver(SceneDesc& scene, const std::string& solver) {
    for (ObjectDesc& o : scene.objects)
        o.material.solver = solver == "one" ? MaterialDesc::Solver::One : MaterialDesc::Solver::Chain;
}

void parseFrameRange(const std::string& text, const SceneDesc& scene, int& first, int& last) {
    auto bad = [&](const std::string& what) { throw InputError("--frames", "", what); };
    try {
        std::size_t pos = 0;
        std::size_t dash = text.find('-', 1);
        if (dash == std::string::npos) {
            first = last = std::stoi(text, &pos);
            if (pos != text.size()) bad("expected A-B or N, got \"" + text + "\"");
        } else {
            first = std::stoi(text.substr(0, dash), &pos);
            if (pos != dash) bad("expected A-B or N, got \"" + text + "\"");
            std::string rest = text.substr(dash + 1);
            last = std::stoi(rest, &pos);
            if (pos != rest.size()) bad("expected A-B or N, got \"" + text + "\"");
        }
    } catch (const std::logic_error&) {
        bad("expected A-B or N, got \"" + text + "\"");
    }
    if (last < first) bad("the range " + text + " is empty (B < A)");
    if (first < scene.frameStart || last > scene.frameEnd)
        bad("frames " + text + " lie outside the scene's range " + std::to_string(scene.frameStart) + "-" +
            std::to_string(scene.frameEnd));
}

DynamicsRun::DynamicsRun(const SceneDesc& scene, const std::vector<BuiltObject>& objects, bool writeVdb)
    : mScene(scene),
      mObjects(objects),
      mVdb(writeVdb),
      mMesh(scene.output.mesh.empty() ? MeshCacheFormat::None
                                      : meshCacheFormatFromName(scene.output.mesh, "output.mesh")) {
    std::vector<const Lattice*> lattices;
    for (const BuiltObject& o : objects) lattices.push_back(&o.lattice);
    mSim = std::make_unique<Simulation>(scene, lattices, writeVdb);
    // Goo that is re-parametrised takes its surface from its volume, an OpenVDB level set of its
    // lattice surface meshed again (sim/simulation, volumeSurface).
    mSim->setSurfaceDistance([](const TriangleMesh& mesh, Real voxel, int band) {
        return meshLevelSet(mesh, voxel, band, "an object's deformed surface");
    });
    mSim->setLevelSetMesher([](const SdfGrid& grid) { return levelSetMesh(grid); });
    if (mSim->active()) mSim->checkStartOverlap();
    // Each frame's rendered surface is checked before the frame is written (docs/math.md, "Never a
    // torn frame").
    for (std::size_t i = 0; i < objects.size(); ++i)
        if (mSim->body(i)) mSim->setSurface(i, &objects[i].restMesh, &objects[i].embedding);
    if (mSim->active()) mSceneKey = sceneDynamicsKey(scene, lattices);
    if (mVdb || mMesh != MeshCacheFormat::None) mFrameKey = sceneFrameKey(scene);
}

DynamicsRun::~DynamicsRun() = default;

const DeformableBody* DynamicsRun::body(std::size_t i) const { return mSim->active() ? mSim->body(i) : nullptr; }

const TriangleMesh& DynamicsRun::surfaceMesh(std::size_t i) const {
    const TriangleMesh* m = mSim->body(i) ? mSim->surfaceMesh(i) : nullptr;
    return m ? *m : mObjects[i].restMesh;
}

void DynamicsRun::drawnSurface(std::size_t i, std::vector<Vec3>& vertices) const {
    if (!body(i)) {
        vertices = mObjects[i].restMesh.vertices;
        return;
    }
    mSim->drawnSurface(i, vertices);  // every moving object's surface is set (constructor)
}

const MeshEmbedding& DynamicsRun::embedding(std::size_t i) const {
    const MeshEmbedding* e = mSim->body(i) ? mSim->surfaceEmbedding(i) : nullptr;
    return e ? *e : mObjects[i].embedding;
}

void DynamicsRun::recordMotion(Real shutterFrames) {
    mShutterFrames = shutterFrames;
    mSim->setSubstepObserver([this](int frame, int k, int sub) {
        if (k == 0) {  // a frame (or a frame simulated again) starts
            mMotion.clear();
            mMotionFrame = frame;
        }
        // Kept when the shutter is open at the next substep's end (this one brackets its opening),
        // and always the frame's last.
        const Real opens = frame - mShutterFrames;
        if (k < sub && (frame - 1) + Real(k + 1) / sub <= opens) return;
        MotionSample m;
        m.time = (frame - 1) + Real(k) / sub;
        m.surfaces.resize(mObjects.size());
        for (std::size_t i = 0; i < mObjects.size(); ++i)
            if (body(i)) drawnSurface(i, m.surfaces[i]);
        mMotion.push_back(std::move(m));
    });
}

bool DynamicsRun::surfaceAt(std::size_t i, int frame, Real t, std::vector<Vec3>& vertices) const {
    if (frame != mMotionFrame || mMotion.empty() || mMotion.back().time < frame) return false;
    if (i >= mMotion[0].surfaces.size() || mMotion[0].surfaces[i].empty()) return false;
    std::size_t b = 0;
    while (b + 1 < mMotion.size() && mMotion[b].time < t) ++b;
    const std::size_t a = b > 0 ? b - 1 : 0;
    const std::vector<Vec3>& va = mMotion[a].surfaces[i];
    const std::vector<Vec3>& vb = mMotion[b].surfaces[i];
    const Real span = mMotion[b].time - mMotion[a].time;
    const Real w = span > 0 ? std::clamp((t - mMotion[a].time) / span, Real(0), Real(1)) : Real(1);
    vertices.resize(vb.size());
    for (std::size_t v = 0; v < vb.size(); ++v) vertices[v] = (1 - w) * va[v] + w * vb[v];
    return true;
}

void DynamicsRun::record(const FrameStats& s) {
    mLast = s;
    mDone = s.frame;
    mContactHistory.resize(mObjects.size());
    if (mSim->active())
        for (std::size_t i = 0; i < mObjects.size(); ++i)
            if (const DeformableBody* b = mSim->body(i)) mContactHistory[i].observe(b->contact());
    if (mMesh != MeshCacheFormat::None && s.frame >= mFirstWritten && !mReadOnly) writeMeshes(s.frame);
    if (!mSim->active() && !mVdb) return;
    if (mVdb && s.frame >= mFirstWritten && !mReadOnly) writeVdb(s.frame);
    mStats.add(s);
    if (mReadOnly) return;
    writeStats();
    if (mSim->active() && s.frame > mScene.frameStart) writeCheckpoint(s.frame);
}

void DynamicsRun::writeStats() { mStats.write(mScene.output.dir); }

void DynamicsRun::writeVdb(int frame) {
    std::vector<VdbObjectFrame> objs;
    std::vector<TriangleMesh> surfaces(mObjects.size());
    for (std::size_t i = 0; i < mObjects.size(); ++i) {
        const DeformableBody* b = mSim->body(i);
        if (!b) continue;
        VdbObjectFrame o;
        o.name = mObjects[i].name;
        o.lattice = &b->lattice();
        o.cells = &b->cells();
        o.positions = &b->positions();
        o.velocities = &b->velocities();
        o.contact = &b->contact();
        o.restVolumes = &b->restVolumes();
        if (mScene.output.vdbSurface) {
            surfaces[i].triangles = surfaceMesh(i).triangles;
            drawnSurface(i, surfaces[i].vertices);
            o.surface = &surfaces[i];
        }
        objs.push_back(o);
    }
    if (objs.empty()) return;
    VdbFrameInfo info;
    info.frame = frame;
    info.time = (frame - mScene.frameStart) / mScene.fps;
    info.fps = mScene.fps;
    info.scene = mScene.name;
    info.key = mFrameKey;
    VdbWriteSettings set;
    set.worldVoxelSize = mScene.output.vdbVoxelSize;
    set.halfFloat = mScene.output.vdbHalf;
    set.surface = mScene.output.vdbSurface;
    const fs::path dir = fs::path(mScene.output.dir) / "vdb";
    ensureDirectory(dir);
    (void)writeVdbFrame(vdbFramePath(dir, mScene.name, frame), objs, info, set);
}

fs::path DynamicsRun::gltfPath() const { return fs::path(mScene.output.dir) / "mesh" / (mScene.name + ".glb"); }

void DynamicsRun::writeMeshes(int frame) {
    const fs::path dir = fs::path(mScene.output.dir) / "mesh";
    ensureDirectory(dir);
    if (mMesh == MeshCacheFormat::Gltf && !mMeshWritten) {
        // The shot's glTF is remade from the frames when the run ends; until then an older one
        // would be stale (another version of the scene, or frames this run replaces).
        std::error_code ec;
        fs::remove(gltfPath(), ec);
    }
    mMeshWritten = true;
    std::vector<Vec3> positions;
    std::vector<Real> contact;
    for (std::size_t i = 0; i < mObjects.size(); ++i) {
        const DeformableBody* b = body(i);
        MeshCacheFrame f;
        f.object = mObjects[i].name;
        f.frame = frame;
        f.key = mFrameKey;
        f.colour = mObjects[i].color;
        f.triangles = &surfaceMesh(i).triangles;
        if (b) {
            drawnSurface(i, positions);
            // The contact set R (0/1 per lattice point) carried to the vertices like the positions.
            std::vector<Real> inR(b->contact().begin(), b->contact().end());
            pointScalarToVertices(embedding(i), inR, contact);
            f.positions = &positions;
            f.contact = &contact;
        } else {
            f.positions = &mObjects[i].restMesh.vertices;
        }
        writeMeshCacheFrame(meshCachePath(dir, f.object, frame, mMesh), mMesh, f);
    }
}

std::string DynamicsRun::finishCaches() {
    if (mMesh != MeshCacheFormat::Gltf || mReadOnly || mDone < mScene.frameStart) return "";
    const fs::path dir = fs::path(mScene.output.dir) / "mesh";
    const int first = std::max(mScene.frameStart, mFirstWritten);
    std::vector<GltfTrack> tracks;
    for (const BuiltObject& o : mObjects) {
        GltfTrack track;
        track.name = o.name;
        track.colour = o.color;
        if (o.restMesh.hasMaterials()) track.materials = o.restMesh.materials;
        for (int f = first; f <= mDone; ++f) {
            const fs::path file = meshCachePath(dir, o.name, f, mMesh);
            const std::string problem = meshCacheFileProblem(file, mMesh, f, mFrameKey);
            if (!problem.empty())
                throw RuntimeError(file.string() + " " + problem + "; the shot's glTF (" + gltfPath().string() +
                                   ") is made from every frame's file: run with --resume to make it again");
            MeshCacheData d = readMeshCacheFrame(file);
            if (track.segments.empty() || track.segments.back().triangles != d.triangles) {
                GltfSegment& seg = track.segments.emplace_back();
                seg.firstFrame = f;
                seg.triangles = std::move(d.triangles);
                if (!track.materials.empty() && seg.triangles == o.restMesh.triangles) {  // not goo's remeshed surface
                    seg.triangleMaterials = o.restMesh.triangleMaterials;
                    seg.cornerUvs = o.restMesh.cornerUvs;
                }
            }
            track.segments.back().positions.push_back(std::move(d.positions));
            track.segments.back().normals.push_back(std::move(d.normals));
        }
        tracks.push_back(std::move(track));
    }
    GltfShotInfo info;
    info.fps = mScene.fps;
    info.firstFrame = 0;  // t = frame / fps: Blender's and Houdini's frame N is the shot's frame N
    info.generator = std::string("dgv ") + DGV_VERSION_STRING;
    info.key = mFrameKey;
    writeGltfShot(gltfPath(), tracks, info);
    return gltfPath().string();
}

void DynamicsRun::writeCheckpoint(int frame) {
    StateCheckpoint c;
    c.dgvVersion = DGV_VERSION_STRING;
    c.sceneKey = mSceneKey;
    c.frame = frame;
    c.statsRows = mStats.rows();
    c.objects = mSim->saveState();
    for (const ContactHistory& h : mContactHistory) c.contactAges.push_back(h.age());
    const fs::path path = stateFilePath(mScene.output.dir, mScene.name, frame);
    ensureDirectory(path.parent_path());
    writeStateFile(path, c);
}

int DynamicsRun::restoreCheckpoint(int frame) {
    if (!mSim->active()) return -1;
    const int lowest = std::max(mDone + 1, mScene.frameStart + 1);
    int stale = 0;
    std::string firstStale;
    auto skip = [&](const fs::path& path, const std::string& why) {
        if (stale++ == 0) firstStale = path.string() + ": " + why;
    };
    int restored = -1;
    // The first bad VDB file found and why: checkpoints are tried from the latest down, so every
    // later one that skips it is refused without reading the files again, and every earlier one
    // skips only files already read good.
    int badVdb = -1;
    std::string badWhy;
    // Checkpoints passed over because an output of a frame they skip is not whole: counted, and
    // the first reason told once.
    int notUsed = 0, notUsedHigh = -1, notUsedLow = -1;
    std::string notUsedWhy;
    auto passOver = [&](int k, const std::string& why) {
        if (notUsed++ == 0) {
            notUsedHigh = k;
            notUsedWhy = why;
        }
        notUsedLow = k;
    };
    for (int k = frame; k >= lowest && restored < 0; --k) {
        const fs::path path = stateFilePath(mScene.output.dir, mScene.name, k);
        std::error_code ec;
        if (!fs::exists(path, ec)) continue;
        StateCheckpoint c;
        std::string problem = readStateFile(path, c);
        if (problem.empty()) {
            if (c.dgvVersion != DGV_VERSION_STRING)
                problem = "written by dgv " + c.dgvVersion;
            else if (c.sceneKey != mSceneKey)
                problem = "of another scene or lattice";
            else if (c.frame != k)
                problem = "holds frame " + std::to_string(c.frame);
            else if (c.statsRows.size() != static_cast<std::size_t>(k - mScene.frameStart + 1) ||
                     !mSim->stateFits(c.objects) || c.contactAges.size() != mObjects.size())
                problem = "its arrays do not fit the scene's lattices";
        }
        if (!problem.empty()) {
            skip(path, problem);
            continue;
        }
        if (mVdb) {
            // The frames skipped must have their VDB files, complete (every grid reads) and of
            // this version of the scene: a truncated, emptied, renamed or foreign file is not
            // kept; the checkpoint is not used and the frames from an earlier one are made again.
            if (badVdb < 0)
                for (int f = std::max({mDone + 1, mScene.frameStart, mFirstWritten}); f <= k && badVdb < 0; ++f) {
                    badWhy = vdbFrameProblem(vdbFramePath(fs::path(mScene.output.dir) / "vdb", mScene.name, f), f,
                                             mFrameKey);
                    if (!badWhy.empty()) badVdb = f;
                }
            if (badVdb >= 0 && badVdb <= k) {
                passOver(k, "the VDB file of frame " + std::to_string(badVdb) + " " + badWhy);
                continue;
            }
        }
        if (mMesh != MeshCacheFormat::None) {
            // The same for the mesh cache: every object's file of every frame skipped.
            std::string why;
            for (int f = std::max({mDone + 1, mScene.frameStart, mFirstWritten}); f <= k && why.empty(); ++f)
                for (const BuiltObject& o : mObjects) {
                    const fs::path file = meshCachePath(fs::path(mScene.output.dir) / "mesh", o.name, f, mMesh);
                    const std::string fileProblem = meshCacheFileProblem(file, mMesh, f, mFrameKey);
                    if (!fileProblem.empty()) {
                        why = file.string() + " " + fileProblem;
                        break;
                    }
                }
            if (!why.empty()) {
                passOver(k, "the mesh cache file " + why);
                continue;
            }
        }
        mSim->restoreState(k, std::move(c.objects));
        mContactHistory.assign(mObjects.size(), ContactHistory());
        for (std::size_t i = 0; i < mObjects.size(); ++i) mContactHistory[i].restore(std::move(c.contactAges[i]));
        mStats.restore(std::move(c.statsRows));
        if (!mReadOnly) writeStats();
        mLast = FrameStats();
        mLast.frame = k;
        mDone = k;
        restored = k;
    }
    if (notUsed > 0)
        logInfo("resume: " + std::to_string(notUsed) + " state checkpoint" + (notUsed > 1 ? "s" : "") + " (frame" +
                (notUsed > 1 ? "s " + std::to_string(notUsedLow) + "-" : " ") + std::to_string(notUsedHigh) +
                ") not used: " + notUsedWhy + "; the frames after the checkpoint used are made again");
    if (stale > 0)
        logWarning("ignored " + std::to_string(stale) + " state checkpoint" + (stale > 1 ? "s" : "") + " (" +
                   firstStale + (stale > 1 ? "; ..." : "") + "); they are rewritten as the frames are simulated");
    if (restored >= 0)
        logInfo("resuming the simulation from frame " + std::to_string(restored) + " (" +
                stateFilePath(mScene.output.dir, mScene.name, restored).string() + ")");
    return restored;
}

void DynamicsRun::advanceTo(int frame) {
    if (mDone < 0) record(mSim->currentStats(mScene.frameStart));
    while (mDone < frame) record(mSim->advanceTo(mDone + 1));
}

}  // namespace dgv::app
