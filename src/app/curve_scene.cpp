// dgv render for scenes with curves: the seed's GLN figures 1-4 (app/curve_scene.hpp).

#include "app/curve_scene.hpp"

#include "app/plot.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "collide/curve_distance.hpp"
#include "collide/gln_farfield.hpp"
#include "collide/gln_seed.hpp"
#include "geom/tube.hpp"
#include "io/atomic_file.hpp"
#include "io/curve_file.hpp"
#include "io/png.hpp"
#include "render/camera.hpp"
#include "render/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>

namespace dgv::app {
namespace fs = std::filesystem;

namespace {

struct FrameRow {
    int frame = 0;
    Real distance = 0;
    std::vector<Real> seed;  ///< one per scene tolerance
    Real exact = 0;          ///< certified integer; NaN where undefined (the curves touch)
};

std::string number(Real v, const char* fmt = "%.17g") {
    if (!std::isfinite(v)) return "nan";
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

std::string tolName(Real t) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", t);
    return buf;
}

}  // namespace

std::vector<Vec3> curveAtRest(const CurveDesc& c) {
    if (!c.curvePath.empty()) return readCurveFile(c.curvePath);
    // u: the coordinate axis least aligned with the normal (ties: the lower index), projected;
    // v = normal × u. Vertices at quarter turns are exact when 4 divides the count.
    const Vec3 n = c.normal.normalized();
    int axis = 0;
    for (int a = 1; a < 3; ++a)
        if (std::abs(n[a]) < std::abs(n[axis])) axis = a;
    const Vec3 u = (Vec3::Unit(axis) - n[axis] * n).normalized(), v = n.cross(u);
    std::vector<Vec3> pts;
    const int m = c.segments;
    for (int k = 0; k < m; ++k) {
        Real cs, sn;
        if ((4 * k) % m == 0) {
            const int q = 4 * k / m;
            cs = q == 0 ? 1 : q == 2 ? -1 : 0;
            sn = q == 1 ? 1 : q == 3 ? -1 : 0;
        } else {
            const Real phi = 2 * M_PI * k / m;
            cs = std::cos(phi);
            sn = std::sin(phi);
        }
        pts.push_back(c.centre + c.radius * (cs * u + sn * v));
    }
    return pts;
}

/// render.environment as the renderer's ambient light (unset: the studio hemisphere).
std::optional<Environment> environmentOf(const RenderDesc& desc) {
    const Real k = desc.environmentIntensity;
    switch (desc.environment) {
        case RenderDesc::Environment::Studio:
            return std::nullopt;
        case RenderDesc::Environment::Colour:
            return uniformEnvironment(k * desc.environmentColour);
        case RenderDesc::Environment::Sky:
            return skyEnvironment(k * desc.environmentColour, k * desc.environmentGround);
        case RenderDesc::Environment::Image: {
            Environment e = equirectEnvironment(*desc.environmentPixels, desc.environmentWidth, desc.environmentHeight,
                                                desc.environmentRotation);
            for (Vec3& c : e.coefficients) c *= k;
            return e;
        }
    }
    return std::nullopt;
}

RenderSettings renderSettingsOf(const RenderDesc& desc, GlBackend backend) {
    RenderSettings rs;
    rs.width = desc.width;
    rs.height = desc.height;
    rs.supersample = desc.supersample;
    rs.background = desc.background;
    rs.transparentBackground = desc.transparent;
    rs.creaseDegrees = desc.creaseDegrees;
    rs.shadowSoftness = desc.shadowSoftness;
    // EXR frames and motion blur (averaged in linear light) need the linear planes.
    rs.linearPlanes = desc.format == RenderDesc::Format::Exr || desc.motionBlur;
    rs.lights = desc.lights;
    rs.environment = environmentOf(desc);
    rs.backend = backend;
    return rs;
}

namespace {

/// <out>/gln.csv: per frame rendered, the closest approach, the seed method's GLN at each
/// tolerance and the exact one.
void writeGlnCsv(const SceneDesc& scene, const std::vector<FrameRow>& rows) {
    std::string csv = "frame,distance";
    for (Real t : scene.gln.seedTolerances) csv += ",gln_seed_tol" + tolName(t);
    csv += ",gln_exact\n";
    for (const FrameRow& r : rows) {
        csv += std::to_string(r.frame) + "," + number(r.distance);
        for (Real v : r.seed) csv += "," + number(v);
        csv += "," + (std::isfinite(r.exact) ? std::to_string(static_cast<long long>(r.exact)) : std::string("nan")) +
               "\n";
    }
    writeTextAtomically(fs::path(scene.output.dir) / "gln.csv", csv);

}

/// <out>/gln_distance.png, gln_frame.png and gln_vs_distance.png: the figures of the frames rendered.
void writeGlnPlots(const SceneDesc& scene, const std::vector<FrameRow>& rows) {
    const Vec3 exactColour(0.0, 0.45, 0.74);
    const Vec3 seedColours[] = {Vec3(0.85, 0.33, 0.10), Vec3(0.30, 0.62, 0.15), Vec3(0.49, 0.18, 0.56)};
    std::vector<double> frames, dist, exact;
    for (const FrameRow& r : rows) {
        frames.push_back(r.frame);
        dist.push_back(r.distance);
        exact.push_back(r.exact);
    }
    auto glnSeries = [&](const std::vector<double>& x, bool lines, bool markers) {
        // The exact values first, so that seed values equal to them are drawn on top.
        std::vector<PlotSeries> out;
        PlotSeries e;
        e.label = "exact (certified)";
        e.x = x;
        e.y = exact;
        e.color = exactColour;
        e.width = 6;  // wide, under the seed values: visible where they agree
        e.lines = lines;
        e.markers = markers;
        out.push_back(std::move(e));
        for (std::size_t k = 0; k < scene.gln.seedTolerances.size(); ++k) {
            PlotSeries s;
            s.label = "seed, tolerance " + tolName(scene.gln.seedTolerances[k]);
            s.x = x;
            for (const FrameRow& r : rows) s.y.push_back(r.seed[k]);
            s.color = seedColours[k % 3];
            s.lines = lines;
            s.markers = markers;
            out.push_back(std::move(s));
        }
        return out;
    };
    // The coarse seed values can spike far from any integer (near-singular chord pairs): keep
    // the y range on the integers the exact values take, ±1.5, and say so in the title.
    auto clipGln = [&](PlotSpec& p) {
        double lo = 0, hi = 0;
        for (Real e : exact)
            if (std::isfinite(e)) lo = std::min(lo, e), hi = std::max(hi, e);
        bool clipped = false;
        for (const PlotSeries& s : p.series)
            for (double y : s.y)
                if (std::isfinite(y) && (y < lo - 1.5 || y > hi + 1.5)) clipped = true;
        if (!clipped) return;
        p.yMin = lo - 1.5;
        p.yMax = hi + 1.5;
        p.title += " (values beyond the axes clipped)";
    };
    PlotSpec pd;
    pd.title = "Closest approach vs frame";
    pd.xLabel = "frame";
    pd.yLabel = "distance of closest approach";
    PlotSeries ds;
    ds.label = "distance";
    ds.x = frames;
    ds.y = dist;
    ds.color = exactColour;
    pd.series = {ds};
    PngWriteOptions plotPng;
    writePng(fs::path(scene.output.dir) / "gln_distance.png", drawPlot(pd), plotPng);

    PlotSpec pf;
    pf.title = "Gauss linking number vs frame";
    pf.xLabel = "frame";
    pf.yLabel = "GLN";
    pf.series = glnSeries(frames, true, true);
    clipGln(pf);
    writePng(fs::path(scene.output.dir) / "gln_frame.png", drawPlot(pf), plotPng);

    PlotSpec pv;
    pv.title = "Gauss linking number vs closest approach";
    pv.xLabel = "distance of closest approach";
    pv.yLabel = "GLN";
    pv.series = glnSeries(dist, false, true);
    clipGln(pv);
    writePng(fs::path(scene.output.dir) / "gln_vs_distance.png", drawPlot(pv), plotPng);

}

}  // namespace

int renderCurveScene(const SceneDesc& scene, const RenderSettings& settings, int first, int last) {
    // Everything that can fail on input fails before anything is written.
    std::vector<std::vector<Vec3>> rest;
    for (const CurveDesc& c : scene.curves) rest.push_back(curveAtRest(c));
    if (scene.camera.type != CameraType::LookAt)
        throw InputError(scene.path, "camera.type", "a scene with curves needs a look_at camera");

    Renderer renderer(settings);
    const std::string glName = renderer.glRenderer();
    Camera cam;
    cam.eye = scene.camera.eye;
    cam.target = scene.camera.target;
    cam.up = scene.camera.up;
    cam.fovYDegrees = scene.camera.vertical(Real(settings.width) / Real(settings.height));

    ensureDirectory(scene.output.dir);
    PngWriteOptions png;
    png.bitDepth = scene.render.bitDepth;
    png.alpha = scene.render.transparent;

    logInfo("rendering frames " + std::to_string(first) + "-" + std::to_string(last) + " of '" + scene.name +
            "' (2 curves) into " + scene.output.dir + " (" + glName + ")");
    std::vector<FrameRow> rows;
    Progress progress("render", last - first + 1, "frames");
    FrameScene frameScene;
    frameScene.groundPlane = scene.render.ground;
    for (int frame = first; frame <= last; ++frame) {
        if (cancelRequested()) break;
        std::vector<std::vector<Vec3>> now(rest.size());
        frameScene.meshes.clear();
        for (std::size_t i = 0; i < rest.size(); ++i) {
            const Vec3 off = scene.curves[i].offsetAt(frame);
            for (const Vec3& p : rest[i]) now[i].push_back(p + off);
            const TriangleMesh tube = makeTube(now[i], scene.curves[i].tubeRadius, 16);
            DrawMesh dm;
            dm.positions = tube.vertices;
            dm.triangles = tube.triangles;
            dm.colour = scene.curves[i].color;
            frameScene.meshes.push_back(std::move(dm));
        }
        FrameRow row;
        row.frame = frame;
        row.distance = curveDistance(now[0], now[1]);
        for (Real tol : scene.gln.seedTolerances) row.seed.push_back(glnSeed(now[0], now[1], tol).gln);
        const GlnResult r = linkingNumber(now[0], now[1]);
        row.exact =
            r.status == GlnStatus::Certified ? static_cast<Real>(r.linking) : std::numeric_limits<Real>::quiet_NaN();
        if (r.status == GlnStatus::Intersect)
            logInfo("frame " + std::to_string(frame) +
                    ": the curves intersect; the exact GLN is undefined (nan in gln.csv)");
        else if (r.status == GlnStatus::Uncertain)
            logWarning("frame " + std::to_string(frame) + ": the exact GLN could not be certified (nan in gln.csv)");
        rows.push_back(row);

        Image image = renderer.render(frameScene, cam);
        char num[32];
        std::snprintf(num, sizeof num, "%04d", frame);
        const std::string path = (fs::path(scene.output.dir) / (scene.name + "." + num + ".png")).string();
        png.text = {{"Software", std::string("dgv ") + DGV_VERSION_STRING},
                    {"Source", glName},
                    {"dgv:scene", fs::path(scene.path).filename().string()},
                    {"dgv:frame", std::to_string(frame)}};
        writePng(path, image, png);
        progress.step(path);
    }
    progress.finish();

    // gln.csv and the plots cover the frames rendered.
    writeGlnCsv(scene, rows);
    writeGlnPlots(scene, rows);

    if (cancelRequested()) {
        std::fprintf(stderr, "dgv: interrupted; the frames written are complete\n");
        return kExitInterrupted;
    }
    logInfo("wrote " + std::to_string(rows.size()) + " frames: " + scene.output.dir + "/" + scene.name +
            ".####.png, gln.csv, gln_distance.png, gln_frame.png, gln_vs_distance.png");
    return kExitOk;
}

}  // namespace dgv::app
