// `dgv bench step`: one full dynamics step (forces, body and flex, twist, reconstruction,
// colliders, volume projection, state) of a ball of material points in a gentle vortex, as the
// scenes run it (dynamics/stepper.hpp), with the time of each stage; balls of radius 8, 16 and
// 32 voxels (2.1k, 17k, 137k points; radius 8 and 16 with --quick), and the fitted growth of the
// step time with the number of points. Each ball first takes 4 steps (the volume projection's
// multigrid and the warm starts settle), then `repeats` timed steps (their minimum and median,
// with the stages of the fastest), and the mean step over a run of 24 (the repeats and more).
// Table: docs/benchmarks.md.
#include "bench/bench.hpp"

#include "dynamics/stepper.hpp"
#include "geom/lattice.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

namespace dgv::bench {

namespace {
constexpr int kRunSteps = 24;  ///< the run whose mean step time is reported
}  // namespace

void step(std::ostream& out, const BenchOptions& options) {
    std::vector<Real> radii = {8, 16};
    if (!options.quick) radii.push_back(32);
    const int repeats = std::max(1, options.repeats);
    std::vector<double> logN, logT;
    for (Real r : radii) {
        const Real h = 0.5 / r;                                     // a ball of radius 0.5 m
        const Lattice lat = withoutLoosePoints(ballLattice(r, h));  // as a scene's object (scene_build)
        DynamicsSettings settings;
        settings.frameSweepsAfter = 0;  // the frame sweeps from the first step, as in a body long in free flight
        DeformableBody body(lat, restPositions(lat), settings);
        const ForceField f = gentleVortex();
        const Real dt = 1.0 / 48;
        for (int s = 0; s < 4; ++s) (void)body.step(f, 1, dt, {});
        std::vector<StepReport> reports;
        for (int s = 0; s < repeats; ++s) reports.push_back(body.step(f, 1, dt, {}));
        std::sort(reports.begin(), reports.end(),
                  [](const StepReport& a, const StepReport& b) { return a.totalSeconds < b.totalSeconds; });
        const StepReport& best = reports.front();
        const StepReport& med = reports[reports.size() / 2];
        // The mean over a longer run as well: the minimum flatters (the volume projection's
        // prediction settles some steps without a solve), and the cost of a step grows with the
        // winding (docs/history/benchmarks.md, "step after the volume-keeping gauge ...").
        double runSeconds = 0;
        for (const StepReport& rep : reports) runSeconds += rep.totalSeconds;
        const int runSteps = std::max(kRunSteps, repeats);
        for (int s = repeats; s < runSteps; ++s) runSeconds += body.step(f, 1, dt, {}).totalSeconds;
        const std::string tag = "step_r" + std::to_string(static_cast<int>(r));
        out << tag << "_points: " << lat.size() << "\n";
        out << tag << "_seconds_min: " << best.totalSeconds << " s\n";
        out << tag << "_seconds_median: " << med.totalSeconds << " s\n";
        out << tag << "_seconds_mean_run: " << runSeconds / runSteps << " s (" << runSteps
            << " steps after the 4 settling ones)\n";
        out << tag << "_forces: " << best.forcesSeconds << " s\n";
        out << tag << "_body_flex: " << best.bodyFlexSeconds << " s\n";
        out << tag << "_twist: " << best.twistSeconds << " s\n";
        out << tag << "_reconstruct: " << best.reconstructSeconds << " s (" << best.reconstructIterations
            << " CG iterations)\n";
        out << tag << "_reconstruct_edges: " << best.reconstructEdgeSeconds
            << " s (both connections' edge transports)\n";
        out << tag << "_reconstruct_frames: " << best.reconstructFrameSeconds
            << " s (along the tree, then the sweeps)\n";
        out << tag << "_reconstruct_solve: " << best.reconstructSolveSeconds << " s (least squares)\n";
        out << tag << "_collide: " << best.collideSeconds << " s\n";
        out << tag << "_volume: " << best.volumeSeconds << " s (" << best.volumeIterations
            << " Gauss-Newton iterations)\n";
        out << tag << "_state: " << best.stateSeconds << " s\n";
        out << tag << "_max_cell_volume_error: " << best.maxCellVolumeError << "\n";
        logN.push_back(std::log(static_cast<double>(lat.size())));
        logT.push_back(std::log(best.totalSeconds));
    }
    if (logN.size() >= 2) {
        const double slope = (logT.back() - logT.front()) / (logN.back() - logN.front());
        out << "step_time_growth_exponent: " << slope << " (step time ~ points^exponent, smallest to largest ball)\n";
    }
    out << "step_target: one step of the radius-32 ball (137k points) in < 0.05 s on 2 cores\n";
}

}  // namespace dgv::bench
