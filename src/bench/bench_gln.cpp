// dgv bench gln: the Gauss linking number (eq 83) of two closed curves, in one run by
//  - the direct exact kernel (collide/gln_exact.hpp), AVX2 and scalar: segment pairs per second;
//  - the certified driver (collide/gln_farfield.hpp: bounding boxes, far field with error bound,
//    refinement) on the two components of a (2, 2k) torus link with 100k segments each, and
//    with 1M segments each;
//  - the seed's listing (collide/gln_seed.hpp) at tolerance 10, 1 and 0.2 on the same curves.
// Targets (docs/benchmarks.md, "gln"): direct kernel >= 1.8e8 pairs/s on 2 cores; 100k + 100k certified in
// under 1 s; 1M + 1M in under 10 s. --quick: 1k-vertex direct tiles, 10k + 10k, no 1M run.

#include "bench/bench.hpp"

#include "collide/gln_exact.hpp"
#include "collide/gln_farfield.hpp"
#include "collide/gln_seed.hpp"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace dgv::bench {
namespace {

/// CPU seconds used by this process so far (all threads).
double cpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Component of the (2, 2k) torus link: the (1, k) curve on the torus (R, r), shifted by
/// `phase` around the tube; the components for phases 0 and π link k times.
ClosedCurve torusCurve(Real R, Real r, int k, Real phase, Index n) {
    ClosedCurve c(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i) {
        const Real t = 2 * M_PI * static_cast<Real>(i) / static_cast<Real>(n), p = k * t + phase;
        c[static_cast<std::size_t>(i)] =
            Vec3((R + r * std::cos(p)) * std::cos(t), (R + r * std::cos(p)) * std::sin(t), r * std::sin(p));
    }
    return c;
}

struct Timed {
    double best = 0, median = 0;
};

template <typename F>
Timed timeIt(int repeats, F&& f) {
    std::vector<double> s;
    for (int r = 0; r < std::max(1, repeats); ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        s.push_back(secondsSince(t0));
    }
    std::sort(s.begin(), s.end());
    return {s.front(), s[s.size() / 2]};
}

}  // namespace

void gln(std::ostream& out, const BenchOptions& options) {
    const int k = 7;  // linking number of the test link

    // ---- the direct kernel: all pairs of two curves, no culling, no far field --------------------
    {
        const Index n = options.quick ? 1024 : 8192;
        const ClosedCurve a = torusCurve(2, 0.7, k, 0, n), b = torusCurve(2, 0.7, k, M_PI, n + 7);
        const CurveSoA sa = toSoA(a), sb = toSoA(b);
        const double pairs = static_cast<double>(n) * static_cast<double>(n + 7);
        GlnSum sum;
        if (glnAvx2Available()) {
            const double cpu0 = cpuSeconds();
            const Timed t = timeIt(options.repeats, [&] { sum = glnDirectSum(sa, sb, GlnKernel::Avx2); });
            const double cpu = (cpuSeconds() - cpu0) / std::max(1, options.repeats);
            out << "gln.direct_pairs: " << pairs << " pairs\n";
            out << "gln.direct_avx2_min: " << t.best << " s\n";
            out << "gln.direct_avx2_pairs_per_second: " << pairs / t.best << " pairs/s (wall clock, all threads)\n";
            // Per core, from the CPU time actually received: on a machine shared with other jobs
            // the wall-clock figure measures the share, this one the kernel.
            out << "gln.direct_avx2_pairs_per_cpu_second: " << pairs / cpu << " pairs/s per core\n";
            out << "gln.direct_value: " << toLinkValue(sum).raw << " (expected +-" << k << ")\n";
        } else {
            out << "gln.direct_avx2: unavailable (CPU without AVX2)\n";
        }
        // The scalar build of the same kernel, on a quarter of the rows (it is slower).
        const CurveSoA sq = toSoA(ClosedCurve(a.begin(), a.begin() + n / 4));
        const Timed ts = timeIt(1, [&] { sum = glnDirectSum(sq, sb, GlnKernel::Scalar); });
        out << "gln.direct_scalar_pairs_per_second: " << static_cast<double>(sum.pairs) / ts.best << " pairs/s\n";
    }

    // ---- the certified driver on big links -----------------------------------------------------
    std::vector<Index> sizes = options.quick ? std::vector<Index>{10000} : std::vector<Index>{100000, 1000000};
    double rate = 0;  // measured direct rate, to project the direct time of the big runs
    {
        const ClosedCurve a = torusCurve(2, 0.7, k, 0, 2048), b = torusCurve(2, 0.7, k, M_PI, 2048);
        const CurveSoA sa = toSoA(a), sb = toSoA(b);
        const Timed t = timeIt(1, [&] { glnDirectSum(sa, sb); });
        rate = 2048.0 * 2048.0 / t.best;
    }
    // "apart": the components on opposite sides of the tube (closest approach 1.4, mostly far
    // field); "close": phases 0 and 0.05 (closest approach 0.035 all along: a near field
    // everywhere, the hard case). Both link k times.
    for (const Index n : sizes)
        for (const bool close : {false, true}) {
            const std::string tag = "gln." + std::to_string(n / 1000) + "k_" + (close ? "close" : "apart");
            const ClosedCurve a = torusCurve(2, 0.7, k, 0, n), b = torusCurve(2, 0.7, k, close ? 0.05 : M_PI, n);
            GlnResult r;
            const double cpu0 = cpuSeconds();
            const int reps = n >= 1000000 ? 1 : std::max(1, options.repeats);
            const Timed t = timeIt(reps, [&] { r = linkingNumber(a, b); });
            const double cpu = (cpuSeconds() - cpu0) / reps;
            out << tag << ".segments: " << n << " + " << n << " segments\n";
            out << tag << ".linking: "
                << (r.status == GlnStatus::Certified ? std::to_string(r.linking) : std::string("not certified"))
                << " (expected +-" << k << ")\n";
            out << tag << ".raw: " << r.raw << " bound " << r.bound << "\n";
            out << tag << ".method: " << r.method << ", " << r.passes << " pass(es), " << r.pairsExact
                << " exact pairs, " << r.farPairs << " far node pairs\n";
            out << tag << ".certified_min: " << t.best << " s\n";
            out << tag << ".certified_median: " << t.median << " s\n";
            out << tag << ".certified_cpu: " << cpu << " s (CPU time, all threads)\n";
            const double pairs = static_cast<double>(n) * static_cast<double>(n);
            out << tag << ".direct_projected: " << pairs / rate << " s (" << pairs
                << " pairs at the measured direct rate)\n";
            // The seed's listing on the same curves: its cost depends on the tolerance only.
            if (close) continue;
            for (const Real tol : {10.0, 1.0, 0.2}) {
                SeedGln s;
                const Timed ts = timeIt(1, [&] { s = glnSeed(a, b, tol); });
                char key[32];
                std::snprintf(key, sizeof key, "%g", tol);
                out << tag << ".seed_tol" << key << ": " << s.gln << " in " << ts.best << " s (" << s.chordsA << " x "
                    << s.chordsB << " chords)\n";
            }
        }
    out << "gln.peak_rss: " << peakRssMiB() << " MiB\n";
}

}  // namespace dgv::bench
