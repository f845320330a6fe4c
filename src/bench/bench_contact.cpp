// `dgv bench contact`: what contact between bodies costs (docs/gln.md, "Objects colliding").
//  - pair: two jelly balls of 16 voxels' radius (0.3 m) thrown at each other at 0.6 m/s each, no
//    gravity, no restitution: from the frame they meet, the mean substep over the frames they
//    stay in contact (at most 12 × repeats), against the same frames of the same two balls with
//    collision.objects off (stepped alone, each passing through the other); with
//    collision.distance exact (the default) and grid. The ratio is the figure to hold to
//    (target ≤ 1.5). With --quick, balls of 8 voxels' radius.
//  - row: N jelly balls (8 voxels' radius, 0.15 m) in a row, the outer ones thrown inwards the
//    same way, for N = 2, 4, 8 (2 and 4 with --quick), collision.distance exact: the mean
//    substep per body over the frames with contact, so that its growth with N shows.
//  - pile: N jelly balls (0.12 m, 12 across) dropped in two rings of N/2 onto the ground, the
//    upper on the gaps of the lower (for N = 2 one on the other), for N = 2, 4, 8 (2 and 4 with --quick),
//    collision.distance exact, the default material, gravity: the mean substep per body over frames 3-14 (landing on
//    each other and spreading over the ground; the 8 roll apart by frame 20), against the same balls with
//    collision.objects off (each on the ground alone), so that the cost of the contacts between bodies and its growth
//    with N show.
// The figures are the simulation's own substep times (FrameStats::stepMs), from 4 substeps
// (adaptive). Table: docs/benchmarks.md.
#include "bench/bench.hpp"

#include "io/scene_build.hpp"
#include "io/scene_json.hpp"
#include "sim/simulation.hpp"

#include <algorithm>
#include <cmath>
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

// n balls of radius r (`resolution` across) in two layers of n/2 on a ring, the upper ring on
// the gaps of the lower, dropped from 2 cm above the ground (one ball on another, 0.3 r off its
// top, for n = 2): every upper ball lands on two lower ones and pushes them apart.
std::string pileScene(int n, Real r, int resolution, bool objects) {
    std::ostringstream s;
    s << R"({ "name": "bench_pile", "frames": { "start": 1, "end": 400, "fps": 24 }, "substeps": 4, "objects": [)";
    const int ring = std::max(1, n / 2);
    const Real pi = std::acos(Real(-1));
    const Real radius = ring == 1 ? 0 : 1.05 * r / std::sin(pi / ring);  // neighbours 0.1 r apart
    for (int i = 0; i < n; ++i) {
        const int layer = i < ring ? 0 : 1, k = i % ring;
        const Real angle = 2 * pi * (k + 0.5 * layer) / ring;
        const Real rho = ring == 1 ? 0.3 * r * layer : radius;
        const Real x = rho * std::cos(angle), z = rho * std::sin(angle);
        const Real y = r + 0.02 + layer * 2.1 * r;
        s << (i ? "," : "") << R"({ "name": "b)" << i << R"(", "primitive": { "type": "sphere", "radius": )" << r
          << R"( }, "resolution": )" << resolution << R"(, "transform": { "translate": [)" << x << ", " << y << ", "
          << z << R"(] } })";  // the default material (the jelly preset)
    }
    s << R"(], "forces": [{ "type": "gravity" }], "colliders": [{ "type": "ground", "height": 0, "friction": 0.5 }],
      "collision": { "objects": )"
      << (objects ? "true" : "false") << R"(, "distance": "exact", "friction": 0.5 } })";
    return s.str();
}

// Simulates to `first` − 1 (found as the first frame with contact when first = 0, at most 60),
// then times up to `most` frames; with `whileTouching`, stops at the first frame without contact.
Timing run(const std::string& text, int& first, int most, bool whileTouching) {
    SceneDesc scene = parseScene(text, "bench_contact.json");
    std::vector<BuiltObject> objects;
    for (int i = 0; i < static_cast<int>(scene.objects.size()); ++i) objects.push_back(buildObject(scene, i));
    std::vector<const Lattice*> lattices;
    for (const BuiltObject& o : objects) lattices.push_back(&o.lattice);
    Simulation sim(scene, lattices);
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
    const int pileFrames = 12;
    {
        // --quick: balls of 8 voxels' radius (the test that runs every benchmark).
        const int across = options.quick ? 16 : 32;
        const std::string pair = "contact_pair_r" + std::to_string(across / 2);
        int first = 0;
        const Timing exact = run(rowScene(2, 0.3, across, 0.05, true, "exact"), first, most, true);
        int firstGrid = 0;
        const Timing grid = run(rowScene(2, 0.3, across, 0.05, true, "grid"), firstGrid, most, true);
        // The balls alone over the same frames as the exact distance's contact.
        const Timing alone = run(rowScene(2, 0.3, across, 0.05, false, "exact"), first, exact.frames, false);
        out << pair << "_first_contact_frame: " << first << " (exact), " << firstGrid << " (grid)\n";
        out << pair << "_substep_ms: " << exact.substepMs << " ms (exact; " << exact.frames << " frames in contact, "
            << exact.contacts << " contact points)\n";
        out << pair << "_grid_substep_ms: " << grid.substepMs << " ms (grid; " << grid.frames << " frames in contact, "
            << grid.contacts << " contact points)\n";
        out << pair << "_alone_substep_ms: " << alone.substepMs << " ms (collision.objects off)\n";
        out << pair << "_ratio: " << exact.substepMs / alone.substepMs << " (exact; target <= 1.5)\n";
        out << pair << "_grid_ratio: " << grid.substepMs / alone.substepMs << " (grid)\n";
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
    for (int n : counts) {
        int first = 3;  // the pile lands at frame 3 and spreads over the next dozen
        const Timing t = run(pileScene(n, 0.12, 12, true), first, pileFrames, false);
        const Timing alone = run(pileScene(n, 0.12, 12, false), first, pileFrames, false);
        const std::string tag = "contact_pile" + std::to_string(n);
        out << tag << "_per_body_ms: " << t.substepMs / n << " ms (" << n << " balls of 12 voxels across, exact, "
            << t.frames << " frames from " << first << ", " << t.contacts << " contact points)\n";
        out << tag << "_alone_per_body_ms: " << alone.substepMs / n << " ms (collision.objects off)\n";
        out << tag << "_ratio: " << t.substepMs / alone.substepMs << " (target <= 1.5)\n";
    }
}

}  // namespace dgv::bench
