// A scene's dynamics as the commands drive it (dynamics_run.hpp).

#include "app/dynamics_run.hpp"

#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/vdb_cache.hpp"

#include <filesystem>

namespace dgv::app {
namespace fs = std::filesystem;

/// Parses "A-B" or "N" and checks it lies within the scene's frame range.
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
    : mScene(scene), mObjects(objects), mVdb(writeVdb) {
    std::vector<const Lattice*> lattices;
    for (const BuiltObject& o : objects) lattices.push_back(&o.lattice);
    mSim = std::make_unique<Simulation>(scene, lattices, writeVdb);
    mRows.push_back(statsCsvHeader());
}

DynamicsRun::~DynamicsRun() = default;

const DeformableBody* DynamicsRun::body(std::size_t i) const { return mSim->active() ? mSim->body(i) : nullptr; }

void DynamicsRun::record(const FrameStats& s) {
    mLast = s;
    mDone = s.frame;
    if (!mSim->active() && !mVdb) return;
    if (mVdb && s.frame >= mFirstWritten) writeVdb(s.frame);
    mRows.push_back(statsCsvRow(s));
    std::string text;
    for (const std::string& r : mRows) text += r + "\n";
    writeTextAtomically(fs::path(mScene.output.dir) / "stats.csv", text);
}

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
            surfaces[i].triangles = mObjects[i].restMesh.triangles;
            deformVertices(mObjects[i].embedding, b->state(), surfaces[i].vertices);
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
    VdbWriteSettings set;
    set.worldVoxelSize = mScene.output.vdbVoxelSize;
    set.halfFloat = mScene.output.vdbHalf;
    set.surface = mScene.output.vdbSurface;
    const fs::path dir = fs::path(mScene.output.dir) / "vdb";
    ensureDirectory(dir);
    (void)writeVdbFrame(vdbFramePath(dir, mScene.name, frame), objs, info, set);
}

void DynamicsRun::advanceTo(int frame) {
    if (mDone < 0) record(mSim->currentStats(mScene.frameStart));
    while (mDone < frame) record(mSim->advanceTo(mDone + 1));
}

}  // namespace dgv::app
