// `dgv bench reparametrise`: the cost of re-parametrising a goo ball (docs/math.md,
// "Re-parametrisation"), against the cost of its steps. A ball of radius 16 and 32 voxels (16 with
// --quick) in the step benchmark's gentle vortex takes 8 steps (so that it moves and has
// deformed), then is re-voxelised `repeats` times from that state: the new lattice and state
// (dynamics/reparametrise), the new body built on it (its reconstruction's solver and tree), and
// its surface from the volume (the lattice's outer faces as an OpenVDB level set, meshed,
// smoothed and embedded, as sim/simulation does). Minimum over the repeats; the steps' mean.
// Table: docs/benchmarks.md.
#include "bench/bench.hpp"

#include "dynamics/reparametrise.hpp"
#include "dynamics/stepper.hpp"
#include "geom/embedding.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"
#include "io/vdb_mesh.hpp"
#include "io/vdb_read.hpp"
#include "sim/body_contact.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <string>

namespace dgv::bench {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

void reparametrise(std::ostream& out, const BenchOptions& options) {
    std::vector<Real> radii = {16};
    if (!options.quick) radii.push_back(32);
    const int repeats = std::max(1, options.repeats);
    for (Real r : radii) {
        const Real h = 0.5 / r;
        const Lattice lat = withoutLoosePoints(ballLattice(r, h));
        DynamicsSettings settings;  // goo
        DeformableBody body(lat, restPositions(lat), settings);
        const ForceField f = gentleVortex();
        const Real dt = 1.0 / 48;
        double stepSeconds = 0;
        constexpr int kSteps = 8;
        for (int s = 0; s < kSteps; ++s) stepSeconds += body.step(f, 1, dt, {}).totalSeconds;
        stepSeconds /= kSteps;
        double best = std::numeric_limits<double>::infinity(), bestLattice = 0, bestBody = 0, bestSurface = 0;
        Index points = 0, triangles = 0;
        Real dilation = 1;
        for (int k = 0; k < repeats; ++k) {
            const auto t0 = Clock::now();
            Reparametrisation rp = dgv::reparametrise(body);
            const double latticeSeconds = since(t0);
            const auto t1 = Clock::now();
            auto next = std::make_unique<DeformableBody>(rp.lattice, restPositions(rp.lattice), settings);
            next->restoreState(rp.state);
            const double bodySeconds = since(t1);
            const auto t2 = Clock::now();
            SdfGrid g = meshLevelSet(latticeSurface(lat, body.positions()), h, 3, "bench");
            for (float& v : g.values) v -= static_cast<float>(h / 2);
            TriangleMesh m = levelSetMesh(g);
            smoothTaubin(m, 10);
            MeshEmbedding e = embedVertices(rp.lattice, m.vertices);
            const double surfaceSeconds = since(t2);
            const double total = latticeSeconds + bodySeconds + surfaceSeconds;
            if (total < best) {
                best = total;
                bestLattice = latticeSeconds;
                bestBody = bodySeconds;
                bestSurface = surfaceSeconds;
            }
            points = rp.lattice.size();
            triangles = static_cast<Index>(m.triangles.size());
            dilation = rp.dilation;
        }
        const std::string tag = "reparametrise_r" + std::to_string(static_cast<int>(r));
        out << tag << "_points: " << lat.size() << " -> " << points << " (spacing x " << dilation << ")\n";
        out << tag << "_seconds: " << best << " s (min of " << repeats << ")\n";
        out << tag << "_lattice_and_state: " << bestLattice << " s\n";
        out << tag << "_new_body: " << bestBody << " s (its solver and tree)\n";
        out << tag << "_surface: " << bestSurface << " s (" << triangles << " triangles from the volume, embedded)\n";
        out << tag << "_step_seconds_mean: " << stepSeconds << " s (" << kSteps << " steps of goo in a vortex)\n";
        out << tag << "_in_steps: " << best / stepSeconds << " steps\n";
    }
}

}  // namespace dgv::bench
