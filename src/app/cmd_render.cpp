// dgv render: scene -> objects -> per frame: deform the embedded meshes, draw, write PNG.

#include "app/commands.hpp"
#include "app/curve_scene.hpp"
#include "app/resume.hpp"
#include "app/dynamics_run.hpp"
#include "app/movie.hpp"
#include "io/scene_build.hpp"
#include "app/collider_draw.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "geom/lattice.hpp"
#include "io/atomic_file.hpp"
#include "io/exr.hpp"
#include "io/png.hpp"
#include "io/scene_json.hpp"
#include "io/state_file.hpp"
#include "render/camera.hpp"
#include "render/renderer.hpp"
#include "view/camera_path.hpp"
#include "view/frame_view.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>

namespace dgv::app {
namespace fs = std::filesystem;

namespace {

/// Parses "WxH" (16..16384 each).
void parseResolution(const std::string& text, int& width, int& height) {
    auto bad = [&] {
        throw InputError("--resolution", "", "expected WxH with W and H in 16..16384, got \"" + text + "\"");
    };
    const std::size_t x = text.find_first_of("xX");
    if (x == std::string::npos || x == 0 || x + 1 >= text.size()) bad();
    try {
        std::size_t pos = 0;
        width = std::stoi(text.substr(0, x), &pos);
        if (pos != x) bad();
        const std::string rest = text.substr(x + 1);
        height = std::stoi(rest, &pos);
        if (pos != rest.size()) bad();
    } catch (const std::logic_error&) {
        bad();
    }
    if (width < 16 || width > 16384 || height < 16 || height > 16384) bad();
}

/// Thumbnail of at most `maxWidth` pixels across: a box filter over whole source pixels (on
/// the sRGB-encoded 16-bit values: a preview, not a resample for compositing).
Image thumbnail(const Image& src, int maxWidth) {
    const int step = std::max(1, (src.width + maxWidth - 1) / maxWidth);
    Image t(std::max(1, src.width / step), std::max(1, src.height / step));
    for (int y = 0; y < t.height; ++y)
        for (int x = 0; x < t.width; ++x)
            for (int c = 0; c < 4; ++c) {
                std::uint64_t sum = 0;
                for (int j = 0; j < step; ++j)
                    for (int i = 0; i < step; ++i) sum += src.pixel(x * step + i, y * step + j)[c];
                t.pixel(x, y)[c] = static_cast<std::uint16_t>((sum + step * step / 2) / (step * step));
            }
    return t;
}

/// Writes `number` into `image` at its lower left corner: 3x5-pixel digits scaled by 2, white on
/// a dark box, so a contact sheet says which frame each thumbnail is.
void stampFrameNumber(Image& image, int number) {
    static const char* const kDigits[10][5] = {
        {"###", "#.#", "#.#", "#.#", "###"}, {".#.", "##.", ".#.", ".#.", "###"}, {"###", "..#", "###", "#..", "###"},
        {"###", "..#", "###", "..#", "###"}, {"#.#", "#.#", "###", "..#", "..#"}, {"###", "#..", "###", "..#", "###"},
        {"###", "#..", "###", "#.#", "###"}, {"###", "..#", ".#.", ".#.", ".#."}, {"###", "#.#", "###", "#.#", "###"},
        {"###", "#.#", "###", "..#", "###"}};
    const std::string text = std::to_string(number);
    constexpr int kScale = 2, kPad = 2;
    const int w = static_cast<int>(text.size()) * 4 * kScale - kScale + 2 * kPad, h = 5 * kScale + 2 * kPad;
    const int x0 = 2, y0 = image.height - h - 2;
    if (x0 + w > image.width || y0 < 0) return;
    auto set = [&](int x, int y, std::uint16_t v) {
        std::uint16_t* p = image.pixel(x, y);
        p[0] = p[1] = p[2] = v;
        p[3] = 65535;
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) set(x0 + x, y0 + y, 6000);
    for (std::size_t c = 0; c < text.size(); ++c)
        for (int row = 0; row < 5; ++row)
            for (int col = 0; col < 3; ++col)
                if (kDigits[text[c] - '0'][row][col] == '#')
                    for (int dy = 0; dy < kScale; ++dy)
                        for (int dx = 0; dx < kScale; ++dx)
                            set(x0 + kPad + (static_cast<int>(c) * 4 + col) * kScale + dx,
                                y0 + kPad + row * kScale + dy, 65535);
}

/// The thumbnails in a grid, row by row in frame order, ceil(sqrt(n)) columns; gaps are the
/// background (or transparent).
Image contactSheet(const std::vector<Image>& thumbs, const Image& gap) {
    const int n = static_cast<int>(thumbs.size());
    const int cols = static_cast<int>(std::ceil(std::sqrt(double(n))));
    const int rows = (n + cols - 1) / cols;
    const int tw = thumbs[0].width, th = thumbs[0].height, pad = 4;
    Image sheet(cols * tw + (cols + 1) * pad, rows * th + (rows + 1) * pad);
    for (int y = 0; y < sheet.height; ++y)
        for (int x = 0; x < sheet.width; ++x) std::copy(gap.pixel(0, 0), gap.pixel(0, 0) + 4, sheet.pixel(x, y));
    for (int k = 0; k < n; ++k) {
        const int ox = pad + (k % cols) * (tw + pad), oy = pad + (k / cols) * (th + pad);
        for (int y = 0; y < th; ++y)
            std::copy(thumbs[static_cast<std::size_t>(k)].pixel(0, y),
                      thumbs[static_cast<std::size_t>(k)].pixel(0, y) + 4 * tw, sheet.pixel(ox, oy + y));
    }
    return sheet;
}

/// The command line's overrides of the scene (solver, frames, folder, mesh cache, size, format)
/// and the GL backend asked for; bad values and sizes beyond the GL limit are refused.
GlBackend applyRenderOverrides(const RenderOptions& options, SceneDesc& scene, int& first, int& last) {
    first = scene.frameStart;
    last = scene.frameEnd;
    if (!options.solver.empty()) overrideSolver(scene, options.solver);
    if (!options.frames.empty()) parseFrameRange(options.frames, scene, first, last);
    if (!options.outDir.empty()) scene.output.dir = fs::absolute(options.outDir).lexically_normal().string();
    if (!options.mesh.empty()) scene.output.mesh = options.mesh;
    checkOutputFolder(scene.output.dir, options.outDir.empty() ? scene.path : "--out",
                      options.outDir.empty() ? "output.dir" : "");
    if (options.width > 0) scene.render.width = options.width;
    if (options.height > 0) scene.render.height = options.height;
    if (!options.resolution.empty()) parseResolution(options.resolution, scene.render.width, scene.render.height);
    GlBackend backend = GlBackend::Auto;
    if (options.glBackend == "egl")
        backend = GlBackend::Egl;
    else if (options.glBackend == "osmesa")
        backend = GlBackend::OsMesa;
    else if (options.glBackend != "auto")
        throw InputError("--gl-backend", "", "expected auto, egl or osmesa, got \"" + options.glBackend + "\"");
    if (static_cast<long long>(scene.render.width) * scene.render.supersample > 16384 ||
        static_cast<long long>(scene.render.height) * scene.render.supersample > 16384)
        throw InputError("--resolution", "",
                         "width and height times the scene's supersample (" + std::to_string(scene.render.supersample) +
                             ") must stay within 16384");
    if (options.format == "exr") scene.render.format = RenderDesc::Format::Exr;
    if (options.format == "png") scene.render.format = RenderDesc::Format::Png;
    if (!options.motionBlur.empty()) scene.render.motionBlur = options.motionBlur == "on";
    return backend;
}

/// The combinations refused before anything is written: a movie of EXR frames, a curve scene as
/// EXR, a movie without ffmpeg.
void checkRenderOutputs(const RenderOptions& options, const SceneDesc& scene) {
    const bool exr = scene.render.format == RenderDesc::Format::Exr;
    if (options.movie && exr)
        throw InputError("--movie", "",
                         "the preview movie is made from PNG frames, and this render writes EXR: render the PNG "
                         "frames for the movie (--format png) in another folder");
    if (!scene.curves.empty() && exr)
        throw InputError(options.format.empty() ? scene.path : "--format", options.format.empty() ? "render.format" : "",
                         "'" + scene.name + "' is a curve scene (the GLN figures), drawn as PNG plots: drop exr");
    if (options.movie && !onPath("ffmpeg"))
        throw InputError("--movie", "",
                         "ffmpeg is not on PATH: install it (Debian: apt-get install ffmpeg) or drop --movie");
}

/// After --resume kept the last frames: stats.csv, the VDB cache and the checkpoints still reach
/// the end of the range, as in an uninterrupted run. False when interrupted (said on stderr).
bool simulateToEnd(DynamicsRun& dynamics, const SceneDesc& scene, int last) {
    dynamics.restoreCheckpoint(last);
    if (dynamics.done() < last && (dynamics.active() || scene.output.vdb))
        logInfo("simulating frames " + std::to_string(dynamics.done() + 1) + "-" + std::to_string(last) +
                " (kept) for stats.csv" + (scene.output.vdb ? " and the VDB cache" : ""));
    while (dynamics.done() < last) {
        if (cancelRequested()) {
            std::fprintf(stderr, "dgv: interrupted; the files already written are complete\n");
            return false;
        }
        dynamics.advanceTo(std::max(dynamics.done() + 1, scene.frameStart));
    }
    return true;
}

/// <name>.contact.png: the frames' thumbnails in a grid on the background.
void writeContactSheetOf(const SceneDesc& scene, const RenderSettings& rs, const std::vector<Image>& thumbs,
                         const PngWriteOptions& png, int first, int last) {
    Image gap(1, 1);
    for (int c = 0; c < 3; ++c)
        gap.pixel(0, 0)[c] = static_cast<std::uint16_t>(std::lround(65535 * encodeSrgb(rs.background[c])));
    gap.pixel(0, 0)[3] = rs.transparentBackground ? 0 : 65535;
    const fs::path sheetPath = fs::path(scene.output.dir) / (scene.name + ".contact.png");
    PngWriteOptions sheetPng = png;
    sheetPng.text = {
        {"Software", std::string("dgv ") + DGV_VERSION_STRING},
        {"dgv:scene", fs::path(scene.path).filename().string()},  // as the frames': not the path as typed
        {"dgv:frames", std::to_string(first) + "-" + std::to_string(last)}};
    writePng(sheetPath, contactSheet(thumbs, gap), sheetPng);
    logInfo("wrote the contact sheet " + sheetPath.string());
}

/// On-screen travel, in output pixels, that one more render of a blurred frame covers.
constexpr Real kBlurPixelsPerSample = 1.5;

/// The renders a blurred frame takes (render.motion_blur): one where no surface vertex moves half
/// a pixel on screen while the shutter is open (the frame is then drawn as without blur, byte for
/// byte: a shot's frames at rest cost what they did), else one per kBlurPixelsPerSample pixels of
/// the largest travel, at least 2 and at most render.motion_blur.samples.
int blurSamples(const SceneDesc& scene, const DynamicsRun& dynamics, const std::vector<BuiltObject>& objects,
                int frame, const Box3& bounds, const RenderSettings& rs) {
    const Real aspect = Real(rs.width) / Real(rs.height);
    const Real opens = frame - scene.render.motionBlurShutter / 360;
    const Camera c0 = frameCamera(scene, bounds, opens, aspect), c1 = frameCamera(scene, bounds, frame, aspect);
    const Mat4 m0 = c0.clipFromView(aspect, 0.1, 10) * c0.viewFromWorld();
    const Mat4 m1 = c1.clipFromView(aspect, 0.1, 10) * c1.viewFromWorld();
    const bool cameraMoves = !(m0 - m1).isZero(0);
    auto pixel = [&](const Mat4& m, const Vec3& x, Vec2& out) {
        const Vec4 c = m * Vec4(x.x(), x.y(), x.z(), 1);
        if (!(c.w() > 0)) return false;  // behind the camera
        out = Vec2((c.x() / c.w() + 1) / 2 * rs.width, (c.y() / c.w() + 1) / 2 * rs.height);
        return true;
    };
    Real travel = 0;
    std::vector<Vec3> before, after;
    for (std::size_t i = 0; i < objects.size(); ++i) {
        const bool moves = dynamics.surfaceAt(i, frame, opens, before) && dynamics.surfaceAt(i, frame, frame, after);
        if (!moves && !cameraMoves) continue;
        if (!moves) {
            dynamics.drawnSurface(i, after);
            before = after;
        }
        Vec2 a, b;
        for (std::size_t v = 0; v < after.size(); ++v)
            if (pixel(m0, before[v], a) && pixel(m1, after[v], b)) travel = std::max(travel, (b - a).norm());
    }
    if (!(travel >= 0.5)) return 1;
    const Real n = std::ceil(travel / kBlurPixelsPerSample) + 1;
    return static_cast<int>(std::clamp(n, Real(2), Real(scene.render.motionBlurSamples)));
}

/// A frame drawn as the mean of n renders (docs/rendering.md, "Motion blur", "Depth of field"):
/// in linear light, the contact matte averaged as the colour is, the depth the nearest over the
/// renders. Under motion blur (`spread`) their times are spread evenly over the shutter, from its
/// opening to the frame's time: each moving body where the simulation's own substeps had it then
/// (DynamicsRun::surfaceAt), the camera on its path. With camera.depth_of_field each is seen
/// through its own point of the lens (lensSample).
LinearImage accumulatedFrame(Renderer& renderer, FrameView& view, const SceneDesc& scene, const DynamicsRun& dynamics,
                             std::vector<ViewBody> bodies, int frame, int n, bool spread, const Box3& bounds,
                             Real aspect) {
    const Real shutter = scene.render.motionBlurShutter / 360;
    std::vector<std::vector<Vec3>> surfaces(bodies.size());
    LinearImage sum, sample;
    for (int j = 0; j < n; ++j) {
        const Real t = spread ? frame - shutter * Real(n - 1 - j) / Real(n - 1) : Real(frame);
        if (spread)
            for (std::size_t i = 0; i < bodies.size(); ++i)
                if (bodies[i].body && dynamics.surfaceAt(i, frame, t, surfaces[i])) bodies[i].vertices = &surfaces[i];
        Camera camera = frameCamera(scene, bounds, t, aspect);
        if (scene.camera.depthOfField) camera = lensSample(camera, scene.camera, aspect, j, n);
        renderer.render(view.update(bodies, camera), camera, &sample);
        if (j == 0) {
            sum = sample;
            continue;
        }
        for (std::size_t k = 0; k < sum.rgba.size(); ++k) sum.rgba[k] += sample.rgba[k];
        for (std::size_t k = 0; k < sum.contact.size(); ++k) {
            sum.contact[k] += sample.contact[k];
            sum.depth[k] = std::min(sum.depth[k], sample.depth[k]);
        }
    }
    const float scale = 1.0f / static_cast<float>(n);
    for (float& v : sum.rgba) v *= scale;
    for (float& v : sum.contact) v *= scale;
    return sum;
}

/// What draws a simulated frame: the bodies as the dynamics left them (their surfaces as drawn,
/// DynamicsRun::drawnSurface) through the view and the renderer, once, or as the mean of renders
/// under motion blur and depth of field.
struct FrameDrawer {
    Renderer& renderer;
    FrameView& view;
    const SceneDesc& scene;
    const DynamicsRun& dynamics;
    const std::vector<BuiltObject>& objects;
    const Box3& bounds;
    const RenderSettings& rs;
    std::vector<ViewBody> bodies = std::vector<ViewBody>(objects.size());
    std::vector<std::vector<Vec3>> drawn = std::vector<std::vector<Vec3>>(objects.size());

    /// The image of `frame`; its linear planes in `linear` too where it is a mean of renders or
    /// `wantLinear` (EXR).
    Image draw(int frame, LinearImage& linear, bool wantLinear) {
        const Real aspect = Real(rs.width) / Real(rs.height);
        for (std::size_t i = 0; i < objects.size(); ++i) {
            const DeformableBody* body = dynamics.body(i);
            if (body) dynamics.drawnSurface(i, drawn[i]);
            bodies[i] = body ? ViewBody{body, &dynamics.surfaceMesh(i), &dynamics.embedding(i),
                                        &dynamics.contactHistory(i).age(), &drawn[i]}
                             : ViewBody{};
        }
        const int moving = scene.render.motionBlur ? blurSamples(scene, dynamics, objects, frame, bounds, rs) : 1;
        const int samples = std::max(moving, scene.camera.depthOfField ? scene.camera.dofSamples : 1);
        if (samples > 1) {
            linear = accumulatedFrame(renderer, view, scene, dynamics, bodies, frame, samples, moving > 1, bounds,
                                      aspect);
            return encodedImageOf(linear);
        }
        const Camera camera = frameCamera(scene, bounds, frame, aspect);
        return renderer.render(view.update(bodies, camera), camera, wantLinear ? &linear : nullptr);
    }
};

}  // namespace

int runRender(const RenderOptions& options) {
    SceneDesc scene = loadScene(options.scene);
    int first = 0, last = 0;
    const GlBackend backend = applyRenderOverrides(options, scene, first, last);
    checkRenderOutputs(options, scene);
    const bool exr = scene.render.format == RenderDesc::Format::Exr;
    const std::string extension = scene.render.frameExtension();
    if (!scene.curves.empty()) {  // the GLN figures
        if (options.contactSheet)
            logInfo("--contact-sheet: '" + scene.name +
                    "' is a curve scene (the GLN figures), which has no contact sheet; "
                    "rendering its frames without one");
        if (scene.render.motionBlur || scene.camera.depthOfField)
            logInfo("render.motion_blur and camera.depth_of_field: '" + scene.name +
                    "' is a curve scene (the GLN figures), whose frames are drawn without them");
        scene.render.motionBlur = false;
        return renderCurveScene(scene, renderSettingsOf(scene.render, backend), first, last);
    }

    // Build every object before anything is written: bad meshes or settings fail up front.
    resolvePinGroups(scene);
    std::vector<BuiltObject> objects = buildObjects(scene, scene.output.vdb);

    // The dynamics (a scene with forces or initial velocities): frames are sequential in time,
    // so a range A-B simulates from the scene's first frame; stats.csv is rewritten each frame.
    DynamicsRun dynamics(scene, objects, scene.output.vdb);
    dynamics.setFirstWrittenFrame(first);
    dynamics.setReadOnly(options.farmTask);
    const bool blur = scene.render.motionBlur;
    if (blur) dynamics.recordMotion(scene.render.motionBlurShutter / 360);

    RenderSettings rs = renderSettingsOf(scene.render, backend);
    rs.linearPlanes = rs.linearPlanes || scene.camera.depthOfField;  // its renders are averaged in linear light
    Renderer renderer(rs);
    const std::string glName = renderer.glRenderer();

    ensureDirectory(scene.output.dir);
    removeStaleOutputTemporaries(scene.output.dir);
    // The frame as drawn: objects, colliders (level sets: their zero isosurface), highlight and
    // overlays (view/frame_view).
    std::vector<ViewObject> viewObjects;
    for (const BuiltObject& o : objects)
        viewObjects.push_back({&o.restMesh, &o.lattice, &o.embedding, &o.state, o.color});
    FrameView view(scene, std::move(viewObjects), colliderDrawMeshes(scene));
    const Box3& bounds = view.bounds();
    FrameDrawer drawer{renderer, view, scene, dynamics, objects, bounds, rs};

    PngWriteOptions png;
    png.bitDepth = scene.render.bitDepth;
    png.alpha = scene.render.transparent;

    logInfo("rendering frames " + std::to_string(first) + "-" + std::to_string(last) + " of '" + scene.name + "' at " +
            std::to_string(rs.width) + "x" + std::to_string(rs.height) + " into " + scene.output.dir + " (" + glName +
            ")");
    Progress progress("render", last - first + 1, "frames");
    // Frame n is encoded and written on a worker thread while frame n+1 draws (same bytes,
    // same atomic writes; one frame in flight). Progress counts frames once they are on disk.
    PngWriteQueue writer;
    std::vector<Image> thumbs;
    std::string inFlight;
    int kept = 0;      // --resume: complete frames already on disk, not rendered again
    int replaced = 0;  // --resume: frames on disk that were incomplete or of another version of the scene
    // What every frame is a function of (io/state_file.hpp), and the GL renderer that drew it:
    // --resume keeps only frames that carry both.
    const std::string frameKey = sceneFrameKey(scene) + " " + glName +
                                 (options.motionBlur.empty() ? std::string() : " motion_blur " + options.motionBlur);
    for (int frame = first; frame <= last; ++frame) {
        if (cancelRequested()) {
            writer.finish();
            if (!inFlight.empty()) progress.step(inFlight);
            progress.finish();
            std::fprintf(stderr, "dgv: interrupted before frame %d; the frames written are complete\n", frame);
            return kExitInterrupted;
        }
        const std::string onDisk = framePath(scene.output.dir, scene.name, frame, extension);
        if (Image done; options.resume && frameIsComplete(onDisk, frame, rs.width, rs.height, frameKey,
                                                          options.contactSheet ? &done : nullptr)) {
            writer.finish();  // keeps the progress lines in frame order
            if (!inFlight.empty()) progress.step(std::exchange(inFlight, std::string()));
            progress.step(onDisk + " (complete, kept)");
            if (options.contactSheet) {
                thumbs.push_back(thumbnail(done, 320));
                stampFrameNumber(thumbs.back(), frame);
            }
            ++kept;
            continue;  // a kept frame needs no state
        }
        if (options.resume && fs::exists(onDisk)) ++replaced;
        // Frames were skipped (--frames A-B, --resume): restart from the latest state checkpoint
        // up to this frame when there is one; otherwise (and from there) simulate frame by frame.
        // Under motion blur the frame itself is simulated (its substeps are the blur's samples).
        if (frame > dynamics.done() + 1) dynamics.restoreCheckpoint(blur ? frame - 1 : frame);
        dynamics.advanceTo(frame);
        LinearImage linear;
        Image image = drawer.draw(frame, linear, exr);
        const std::string& path = onDisk;
        png.text = {{"Software", std::string("dgv ") + DGV_VERSION_STRING},
                    {"Source", glName},
                    {"dgv:scene", fs::path(scene.path).filename().string()},
                    {"dgv:key", frameKey},
                    {"dgv:frame", std::to_string(frame)}};
        if (options.contactSheet) {
            thumbs.push_back(thumbnail(image, 320));
            stampFrameNumber(thumbs.back(), frame);
        }
        if (exr)
            writeExr(path, linear, png.text);  // here: the PNG queue stays idle
        else
            writer.submit(path, std::move(image), png);  // waits for the previous frame's write
        if (!inFlight.empty()) progress.step(inFlight);
        inFlight = path;
    }
    writer.finish();
    if (!inFlight.empty()) progress.step(inFlight);
    progress.finish();
    if (cancelRequested()) {
        // The signal came while the last frame was written: every frame is there, but the run
        // was stopped, and says so as an interruption anywhere else does.
        std::fprintf(stderr, "dgv: interrupted after the last frame; the frames written are complete\n");
        return kExitInterrupted;
    }
    if (dynamics.done() < last && !options.farmTask && !simulateToEnd(dynamics, scene, last)) return kExitInterrupted;
    if (const std::string glb = dynamics.finishCaches(); !glb.empty()) logInfo("wrote the shot's glTF " + glb);
    if (options.contactSheet) writeContactSheetOf(scene, rs, thumbs, png, first, last);
    if (options.movie) logInfo("wrote the preview movie " + writePreviewMovie(scene, first, last));
    if (options.resume)
        logInfo("resume: kept " + std::to_string(kept) + " complete frames, rendered " +
                std::to_string(last - first + 1 - kept) +
                (replaced > 0 ? " (" + std::to_string(replaced) +
                                    " of them were on disk but incomplete, or of another version of the scene or its "
                                    "settings, and were replaced)"
                              : std::string()));
    logInfo("wrote " + std::to_string(last - first + 1) + " frames: " + scene.output.dir + "/" + scene.name +
            ".####." + extension);
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
    throw InputError("scenes/default.json", "",
                     "default scene not found (run dgv from the project folder, or give a scene: dgv render SCENE)");
}

}  // namespace dgv::app
