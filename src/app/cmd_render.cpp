// dgv render: scene -> objects -> per frame: deform the embedded meshes, draw, write PNG.

#include "app/commands.hpp"
#include "app/scene_build.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/png.hpp"
#include "io/scene_json.hpp"
#include "render/camera.hpp"
#include "render/renderer.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace dgv::app {
namespace fs = std::filesystem;

namespace {

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

Camera frameCamera(const SceneDesc& scene, const Box3& bounds, int frame, Real aspect) {
    const CameraDesc& c = scene.camera;
    if (c.type == CameraType::LookAt) {
        Camera cam;
        cam.eye = c.eye;
        cam.target = c.target;
        cam.up = c.up;
        cam.fovYDegrees = c.fovDegrees;
        return cam;
    }
    // A full turn over the range comes back to the start on the frame after the last, so the
    // sequence loops without a repeated frame.
    const Real frames = scene.frameEnd - scene.frameStart + 1;
    const Real angle = c.startDegrees + c.degrees * (frame - scene.frameStart) / frames;
    return turntableCamera(bounds, angle, c.elevationDegrees, c.fovDegrees, aspect, c.margin);
}

std::string framePath(const std::string& dir, const std::string& name, int frame) {
    char num[32];
    std::snprintf(num, sizeof num, "%04d", frame);
    return (fs::path(dir) / (name + "." + num + ".png")).string();
}

}  // namespace

int runRender(const RenderOptions& options) {
    SceneDesc scene = loadScene(options.scene);
    int first = scene.frameStart, last = scene.frameEnd;
    if (!options.frames.empty()) parseFrameRange(options.frames, scene, first, last);
    if (!options.outDir.empty()) scene.output.dir = fs::absolute(options.outDir).lexically_normal().string();
    if (options.width > 0) scene.render.width = options.width;
    if (options.height > 0) scene.render.height = options.height;
    if (scene.output.vdb)
        throw InputError(scene.path, "output.vdb", "VDB caches are not built yet (a coming milestone); set it to false");
    if (!scene.forces.empty() || !scene.colliders.empty())
        logWarning(scene.path + ": forces and colliders are validated but not simulated yet; objects render at rest");

    // Build every object before anything is written: bad meshes or settings fail up front.
    std::vector<BuiltObject> objects;
    Box3 bounds;
    for (int i = 0; i < static_cast<int>(scene.objects.size()); ++i) {
        objects.push_back(buildObject(scene, i));
        bounds.extend(meshBounds(objects.back().restMesh));
        logInfo(describe(objects.back()));
    }

    RenderSettings rs;
    rs.width = scene.render.width;
    rs.height = scene.render.height;
    rs.supersample = scene.render.supersample;
    rs.background = scene.render.background;
    rs.transparentBackground = scene.render.transparent;
    Renderer renderer(rs);
    const std::string glName = renderer.glRenderer();

    ensureDirectory(scene.output.dir);
    FrameScene frameScene;
    frameScene.groundPlane = scene.render.ground;
    frameScene.meshes.resize(objects.size());
    for (std::size_t i = 0; i < objects.size(); ++i) {
        frameScene.meshes[i].triangles = objects[i].restMesh.triangles;
        frameScene.meshes[i].colour = objects[i].color;
    }

    PngWriteOptions png;
    png.bitDepth = scene.render.bitDepth;
    png.alpha = scene.render.transparent;

    logInfo("rendering frames " + std::to_string(first) + "-" + std::to_string(last) + " of '" + scene.name +
            "' at " + std::to_string(rs.width) + "x" + std::to_string(rs.height) + " into " + scene.output.dir +
            " (" + glName + ")");
    Progress progress("render", last - first + 1, "frames");
    const Real aspect = Real(rs.width) / Real(rs.height);
    for (int frame = first; frame <= last; ++frame) {
        if (cancelRequested()) {
            progress.finish();
            std::fprintf(stderr, "dgv: interrupted before frame %d; the frames written are complete\n", frame);
            return kExitInterrupted;
        }
        for (std::size_t i = 0; i < objects.size(); ++i)
            deformVertices(objects[i].embedding, objects[i].state, frameScene.meshes[i].positions);
        Image image = renderer.render(frameScene, frameCamera(scene, bounds, frame, aspect));
        const std::string path = framePath(scene.output.dir, scene.name, frame);
        png.text = {{"Software", std::string("dgv ") + DGV_VERSION_STRING},
                    {"Source", glName},
                    {"dgv:scene", scene.path},
                    {"dgv:frame", std::to_string(frame)}};
        writePng(path, image, png);
        progress.step(path);
    }
    progress.finish();
    if (cancelRequested()) return kExitInterrupted;
    logInfo("wrote " + std::to_string(last - first + 1) + " frames: " + scene.output.dir + "/" + scene.name +
            ".####.png");
    return kExitOk;
}

std::string defaultScenePath() {
    const fs::path local = fs::path("scenes") / "default.json";
    if (fs::exists(local)) return local.string();
    const fs::path src = fs::path(DGV_SOURCE_DIR) / "scenes" / "default.json";
    if (fs::exists(src)) return src.string();
    std::error_code ec;
    fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        fs::path share = exe.parent_path().parent_path() / "share" / "dgv" / "scenes" / "default.json";
        if (fs::exists(share)) return share.string();
    }
    throw InputError("scenes/default.json", "", "default scene not found (run dgv from the project folder, or give a scene: dgv render SCENE)");
}

}  // namespace dgv::app
