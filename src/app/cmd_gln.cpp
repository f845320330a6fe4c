// dgv gln: the Gauss linking number of two closed curves (curve files, io/curve_file.hpp).
//   exact (default): certified integer (collide/gln_farfield.hpp): exit 0 when certified, 1 when
//                    the curves intersect (the linking number is undefined) or come closer than
//                    double precision resolves; the raw sum and its bound are printed either way.
//   seed:            the notes' listing (collide/gln_seed.hpp) with --tolerance; prints the raw
//                    value and its nearest integer (not certified); exit 0.
#include "app/commands.hpp"
#include "base/errors.hpp"
#include "collide/gln_farfield.hpp"
#include "collide/gln_seed.hpp"
#include "io/curve_file.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>

namespace dgv::app {

int runGln(const GlnOptions& options) {
    const ClosedCurve a = readCurveFile(options.curveA);
    const ClosedCurve b = readCurveFile(options.curveB);
    const auto t0 = std::chrono::steady_clock::now();
    auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };

    if (options.method == "seed") {
        const SeedGln s = glnSeed(a, b, options.tolerance);
        const double t = seconds();
        std::printf("gln: %lld\n", static_cast<long long>(std::llround(s.gln)));
        std::printf("raw: %.17g\n", s.gln);
        std::printf("method: seed (tolerance %g: %lld x %lld chords, %lld samples per chord pair; not certified)\n",
                    options.tolerance, static_cast<long long>(s.chordsA), static_cast<long long>(s.chordsB),
                    static_cast<long long>(s.samples));
        std::printf("segments: %zu %zu\n", a.size(), b.size());
        std::printf("pairs: %lld\n", static_cast<long long>(s.chordsA * s.chordsB));
        std::printf("time: %.6f s\n", t);
        return kExitOk;
    }

    const GlnResult r = linkingNumber(a, b);
    const double t = seconds();
    if (r.status == GlnStatus::Certified)
        std::printf("gln: %lld\n", r.linking);
    else if (r.status == GlnStatus::Intersect)
        std::printf("gln: undefined (curves intersect)\n");
    else
        std::printf("gln: uncertain\n");
    std::printf("raw: %.17g\n", r.raw);
    std::printf("bound: %.3g\n", r.bound);
    std::printf("method: exact, %s%s\n", r.method.c_str(),
                r.culled ? "" : (r.avx2 ? ", avx2 kernel" : ", scalar kernel"));
    std::printf("segments: %lld %lld\n", static_cast<long long>(r.segmentsA), static_cast<long long>(r.segmentsB));
    std::printf("pairs: %lld exact, %lld far-field node pairs, %d pass%s\n", static_cast<long long>(r.pairsExact),
                static_cast<long long>(r.farPairs), r.passes, r.passes == 1 ? "" : "es");
    std::printf("time: %.6f s\n", t);
    std::fflush(stdout);
    if (r.status == GlnStatus::Intersect) {
        std::fprintf(stderr,
                     "dgv gln: curves intersect (%lld touching segment pair%s); the linking number is undefined\n",
                     static_cast<long long>(r.intersections), r.intersections == 1 ? "" : "s");
        return kExitFailure;
    }
    if (r.status == GlnStatus::Uncertain) {
        std::fprintf(stderr,
                     "dgv gln: the curves come closer than double precision resolves; the linking number "
                     "cannot be certified (raw %.6g, bound %.3g)\n",
                     r.raw, r.bound);
        return kExitFailure;
    }
    return kExitOk;
}

}  // namespace dgv::app
