// Measurements behind docs/math.md "Force fields" (hidden: run with
//   build-geom/tests/dgv_tests "[.forces-bench]"
// ). Prints the cost of bulk evaluation per field and order, and analytic vs Eigen AutoDiff for
// the attractor; asserts only that the two derivatives agree (no timing assertions).
#include <catch2/catch.hpp>

#include "dynamics/forces.hpp"

#include <tbb/global_control.h>
#include <unsupported/Eigen/AutoDiff>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <random>
#include <vector>

using namespace dgv;

namespace {

/// CPU time of the calling thread, ms: what a loop costs, whatever else the machine runs.
double threadCpuMs() {
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

using AD1 = Eigen::AutoDiffScalar<Eigen::Vector3d>;
using AD2 = Eigen::AutoDiffScalar<Eigen::Matrix<AD1, 3, 1>>;

/// The attractor by nested forward-mode AutoDiff (Eigen's pow does not nest: exp/log instead).
ForceSample attractorAutoDiff(const ForceTerm& t, const Vec3& x) {
    const Real m = 0.5 * (t.falloff + 1), c = t.strength.at(0) * std::pow(t.radius, t.falloff);
    AD2 d[3];
    for (int j = 0; j < 3; ++j) {
        d[j].value() = AD1(x[j] - t.centre[j], 3, j);
        d[j].derivatives().resize(3);
        for (int k = 0; k < 3; ++k) d[j].derivatives()[k] = AD1(j == k ? 1.0 : 0.0, Eigen::Vector3d::Zero());
    }
    const AD2 q = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + t.softening * t.softening;
    const AD2 f = -c * exp(-m * log(q));
    ForceSample s;
    for (int i = 0; i < 3; ++i) {
        const AD2 Fi = f * d[i];
        s.value[i] = Fi.value().value();
        for (int j = 0; j < 3; ++j) {
            s.gradient(i, j) = Fi.value().derivatives()[j];
            for (int k = 0; k < 3; ++k) s.hessian[i](j, k) = Fi.derivatives()[j].derivatives()[k];
        }
    }
    return s;
}

}  // namespace

TEST_CASE("forces bench: bulk cost per field and analytic vs AutoDiff", "[.forces-bench]") {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    std::vector<Vec3> pts;  // a sphere of radius 32 voxels in a unit ball
    for (int k = -32; k <= 32; ++k)
        for (int j = -32; j <= 32; ++j)
            for (int i = -32; i <= 32; ++i)
                if (i * i + j * j + k * k <= 32 * 32) pts.push_back(Vec3(i, j, k) / 32.0);
    std::printf("%zu points, one thread, CPU time, best of 5\n", pts.size());
    const char* names[] = {"gravity", "attractor", "vortex", "burst", "wind (32 modes)"};
    const ForceKind kinds[] = {ForceKind::Gravity, ForceKind::Attractor, ForceKind::Vortex, ForceKind::Burst,
                               ForceKind::Wind};
    for (int n = 0; n < 5; ++n) {
        ForceTerm t;
        t.kind = kinds[n];
        t.turbulence = 0.5;
        t.scale = 0.3;
        t.radius = 0.5;
        t.softening = 0.1;
        t.falloff = n == 2 ? 1 : 2;
        ForceField f;
        f.add(t);
        ForceSamples out;
        double best[3] = {1e30, 1e30, 1e30};
        for (int rep = 0; rep < 5; ++rep)
            for (int o = 0; o < 3; ++o) {
                const double t0 = threadCpuMs();
                f.sample(pts, 1, static_cast<ForceOrder>(o), out);
                best[o] = std::min(best[o], threadCpuMs() - t0);
            }
        std::printf("  %-16s value %7.2f ms   + gradient %7.2f ms   + Hessian %7.2f ms\n", names[n], best[0], best[1],
                    best[2]);
    }

    ForceTerm a;
    a.kind = ForceKind::Attractor;
    a.centre = Vec3(0.3, -0.2, 0.5);
    a.radius = 1.5;
    a.softening = 0.2;
    a.strength = Keyframes::constant(3);
    ForceField f;
    f.add(a);
    Real sink = 0, maxDiff = 0;
    double t0 = threadCpuMs();
    for (const Vec3& x : pts) sink += f.sample(x, 0).hessian[1](0, 2);
    const double analytic = threadCpuMs() - t0;
    t0 = threadCpuMs();
    for (const Vec3& x : pts) sink += attractorAutoDiff(a, x).hessian[1](0, 2);
    const double autodiff = threadCpuMs() - t0;
    for (std::size_t p = 0; p < pts.size(); p += 101) {
        const ForceSample s = f.sample(pts[p], 0), d = attractorAutoDiff(a, pts[p]);
        maxDiff = std::max(maxDiff, (s.value - d.value).cwiseAbs().maxCoeff());
        maxDiff = std::max(maxDiff, (s.gradient - d.gradient).cwiseAbs().maxCoeff());
        for (int i = 0; i < 3; ++i) maxDiff = std::max(maxDiff, (s.hessian[i] - d.hessian[i]).cwiseAbs().maxCoeff());
    }
    std::printf(
        "attractor value+gradient+Hessian per point: analytic %.0f ns, nested AutoDiff %.0f ns; max |diff| %.2e (%g)\n",
        analytic * 1e6 / pts.size(), autodiff * 1e6 / pts.size(), maxDiff, sink);
    CHECK(maxDiff < 1e-11);
}
