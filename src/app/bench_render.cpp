// `dgv bench render`: one turntable frame of a displaced sphere (~200k triangles) at 1920x1080
// with 2x2 supersampling, key-light shadows and the ground, PNG-encoded to memory (8-bit).
// Quick: 320x180 and ~20k triangles. Prints min and median over the repeats (llvmpipe timings
// vary with machine load; see docs/rendering.md).
#include "app/bench.hpp"

#include "io/png.hpp"
#include "render/renderer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace dgv::bench {

namespace {

/// A UV sphere of radius ~1 with a smooth bumpy displacement: 2 * rings * segments triangles
/// (minus the pole caps' degenerate halves).
DrawMesh bumpySphere(int rings, int segments) {
    DrawMesh m;
    const Real pi = 3.14159265358979323846;
    for (int i = 0; i <= rings; ++i) {
        const Real theta = pi * i / rings;
        for (int j = 0; j < segments; ++j) {
            const Real phi = 2 * pi * j / segments;
            const Vec3 dir(std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi));
            const Real bump = 1.0 + 0.06 * std::sin(7 * theta) * std::cos(5 * phi) + 0.03 * std::sin(13 * phi);
            m.positions.push_back(bump * dir);
        }
    }
    auto id = [&](int i, int j) { return i * segments + (j % segments); };
    for (int i = 0; i < rings; ++i) {
        for (int j = 0; j < segments; ++j) {
            const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            if (i != 0) m.triangles.push_back({a, b, d});
            if (i != rings - 1) m.triangles.push_back({d, b, c});
        }
    }
    m.colour = Vec3(0.7, 0.3, 0.2);
    return m;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

void render(std::ostream& out, const BenchOptions& options) {
    RenderSettings settings;
    settings.width = options.quick ? 320 : 1920;
    settings.height = options.quick ? 180 : 1080;
    settings.supersample = 2;
    FrameScene scene;
    scene.meshes.push_back(options.quick ? bumpySphere(71, 142) : bumpySphere(224, 448));
    scene.groundPlane = true;
    Box3 bounds;
    for (const Vec3& p : scene.meshes[0].positions) bounds.extend(p);

    Renderer renderer(settings);
    const int frames = std::max(options.repeats, 1) + 1;  // the first frame (uploads, JIT) is not timed
    std::vector<double> prepare, draw, readback, encode, total;
    std::size_t pngBytes = 0;
    for (int f = 0; f < frames; ++f) {
        const Camera cam = turntableCamera(bounds, 15.0 * f, 20, 35, Real(settings.width) / settings.height);
        const Image img = renderer.render(scene, cam);
        const auto t0 = std::chrono::steady_clock::now();
        pngBytes = encodePng(img).size();
        const double encodeMs =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        if (f == 0) continue;
        const Renderer::Timings t = renderer.lastTimings();
        prepare.push_back(t.prepareMs);
        draw.push_back(t.drawMs);
        readback.push_back(t.readbackMs);
        encode.push_back(encodeMs);
        total.push_back(t.prepareMs + t.drawMs + t.readbackMs + encodeMs);
    }
    out << "render.gl_renderer: " << renderer.glRenderer() << "\n";
    out << "render.size: " << settings.width << "x" << settings.height << " x" << settings.supersample
        << "x" << settings.supersample << " supersampled, " << scene.meshes[0].triangles.size() << " triangles\n";
    out << "render.prepare_ms_median: " << median(prepare) << " ms\n";
    out << "render.draw_ms_min: " << *std::min_element(draw.begin(), draw.end()) << " ms\n";
    out << "render.draw_ms_median: " << median(draw) << " ms\n";
    out << "render.readback_ms: " << median(readback) << " ms\n";
    out << "render.encode_ms: " << median(encode) << " ms (" << pngBytes << " bytes, 8-bit)\n";
    out << "render.fps: " << 1000.0 / median(total) << " frames/s\n";
    out.flush();
}

}  // namespace dgv::bench
