// `dgv bench contact`: what contact between bodies costs (docs/gln.md, "Objects colliding").
//  - pair: two jelly balls of 16 voxels' radius (0.3 m) thrown at each other at 0.6 m/s each, no
//    gravity, no restitution: from the frame they meet, the mean substep over the frames they
//    stay in contact (at most 12 × repeats), against the same frames of the same two balls with
//    collision.objects off (stepped alone, each passing through the other); with
//    collision.distance grid (the default) and exact. The ratio is the figure to hold to
//    (target ≤ 1.5). With --quick, balls of 8 voxels' radius.
//  - row: N jelly balls (8 voxels' radius, 0.15 m) in a row, the outer ones thrown inwards the
//    same way, for N = 2, 4, 8 (2 and 4 with --quick), collision.distance exact: the mean
//    substep per body over the frames with contact, so that its growth with N shows.
// The figures are the simulation's own substep times (FrameStats::stepMs), from 4 substeps
// (adaptive). Table: docs/benchmarks.md.
#include "app/bench.hpp"

#include "app/scene_build.hpp"
#include "io/scene_json.hpp"
#include "io/vdb_read.hpp"
#include "sim/simulation.hpp"

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

namespace dgv::bench {

namespace {

struct Timing {
    double substepMs = 0;  ///< mean substep, ms, over the frames timed
    int frames = 0;        ///< frames timed
    Index contacts = 0;    ///< contact points summed over them
};

// n balls of `resolution` voxels across and radius r along x, `gap` apart surface to surface; the
// outer ones (x ≠ 0) move inwards at 0.6 m/s.
std::string rowScene(int n, Real r, int resolution, Real gap, bool objects, const char* distance) {
    std::ostringstream s;
    s << R"({ "name": "bench_contact", "frames": { "start": 1, "end": 400, "fps": 24 }, "substeps": 4, "objects": [)";
    const Real pitch = 2 * r + gap;
    for (int i = 0; i < n; ++i) {
        const Real x = (i - (n - 1) / 2.0) * pitch;
        const Real v = x < 0 ? 0.6 : x > 0 ? -0.6 : 0.0;
        s << (i ? "," : "") << R"({ "name": "b)" << i << R"(", "primitive": { "type": "sphere", "radius": )" << r
          << R"( }, "resolution": )" << resolution << R"(, "transform": { "translate": [)" << x
          << R"(, 0, 0] }, "material": { "damping": 4, "stiffness": 300 }, "velocity": [)" << v << R"(, 0, 0] })";
    }
    s << R"(], "collision": { "objects": )" << (objects ? "true" : "false") << R"(, "distance": ")" << distance
      << R"(", "friction": 0.5 } })";
    return s.str();
}

// Simulates to `first` − 1 (found as the first frame with contact when first = 0, at most 60),
// then times up to `most` frames; with `whileTouching`, stops at the first frame without contact.
Timing run(const std::string& text, int& first, int most, bool whileTouching) {
    SceneDesc scene = parseScene(text, "bench_contact.json");
    std::vector<app::BuiltObject> objects;
    for (int i = 0; i < static_cast<int>(scene.objects.size()); ++i) objects.push_back(app::buildObject(scene, i));
    std::vector<const Lattice*> lattices;
    for (const app::BuiltObject& o : objects) lattices.push_back(&o.lattice);
    Simulation sim(scene, lattices);
    sim.setSurfaceDistance([](const TriangleMesh& mesh, Real voxel, int band) {
        return meshLevelSet(mesh, voxel, band, "bench contact");
    });
    int frame = 1;  // the last frame simulated
    Timing t;
    auto timed = [&](const FrameStats& s) {
        t.substepMs += s.stepMs;
        t.contacts += s.contacts;
        ++t.frames;
    };
    if (first == 0) {
        while (frame < 60) {
            const FrameStats s = sim.advanceTo(++frame);
            if (s.contacts > 0) {
                first = frame;
                timed(s);
                break;
            }
        }
        if (first == 0) return t;  // they never met
    } else {
        while (frame < first - 1) sim.advanceTo(++frame);
    }
    while (t.frames < most) {
        const FrameStats s = sim.advanceTo(++frame);
        if (whileTouching && s.contacts == 0) break;
        timed(s);
    }
    t.substepMs /= std::max(1, t.frames);
    return t;
}

}  // namespace

void contact(std::ostream& out, const BenchOptions& options) {
    const int most = 12 * std::max(1, options.repeats);
    {
        // --quick: balls of 8 voxels' radius (the test that runs every benchmark).
        const int across = options.quick ? 16 : 32;
        const std::string pair = "contact_pair_r" + std::to_string(across / 2);
        int first = 0;
        const Timing grid = run(rowScene(2, 0.3, across, 0.05, true, "grid"), first, most, true);
        int firstExact = 0;
        const Timing exact = run(rowScene(2, 0.3, across, 0.05, true, "exact"), firstExact, most, true);
        // The balls alone over the same frames as the grid's contact.
        const Timing alone = run(rowScene(2, 0.3, across, 0.05, false, "grid"), first, grid.frames, false);
        out << pair << "_first_contact_frame: " << first << " (grid), " << firstExact << " (exact)\n";
        out << pair << "_substep_ms: " << grid.substepMs << " ms (grid; " << grid.frames << " frames in contact, "
            << grid.contacts << " contact points)\n";
        out << pair << "_exact_substep_ms: " << exact.substepMs << " ms (exact; " << exact.frames
            << " frames in contact, " << exact.contacts << " contact points)\n";
        out << pair << "_alone_substep_ms: " << alone.substepMs << " ms (collision.objects off)\n";
        out << pair << "_ratio: " << grid.substepMs / alone.substepMs << " (grid; target <= 1.5)\n";
        out << pair << "_exact_ratio: " << exact.substepMs / alone.substepMs << " (exact)\n";
    }
    std::vector<int> counts = {2, 4};
    if (!options.quick) counts.push_back(8);
    for (int n : counts) {
        int first = 0;
        const Timing t = run(rowScene(n, 0.15, 16, 0.02, true, "exact"), first, most, true);
        const std::string tag = "contact_row" + std::to_string(n);
        out << tag << "_substep_ms: " << t.substepMs << " ms (" << n
            << " balls of r 8 voxels, exact, first contact at frame " << first << ", " << t.frames
            << " frames in contact)\n";
        out << tag << "_per_body_ms: " << t.substepMs / n << " ms\n";
    }
}

}  // namespace dgv::bench
