// Tests of the exact cell volumes and the volume projection (src/deform/volume.hpp).
#include <catch2/catch.hpp>

#include "deform/volume.hpp"
#include "deform_test_util.hpp"

#include <Eigen/LU>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

using namespace dgv;
using namespace dgv::test;

namespace {

std::array<Vec3, 8> unitCube(Real h, const Vec3& o = Vec3::Zero()) {
    std::array<Vec3, 8> x;
    for (int k = 0; k < 8; ++k) x[static_cast<std::size_t>(k)] = o + h * Vec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    return x;
}

/// Independent reference: n-point Gauss-Legendre (n = 5) of det J of the trilinear map.
Real volumeByQuadrature(const std::array<Vec3, 8>& x) {
    const Real node[5] = {-0.9061798459386640, -0.5384693101056831, 0, 0.5384693101056831, 0.9061798459386640};
    const Real weight[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665, 0.2369268850561891};
    Real v = 0;
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j)
            for (int k = 0; k < 5; ++k) {
                const Real s[3] = {0.5 * (node[i] + 1), 0.5 * (node[j] + 1), 0.5 * (node[k] + 1)};
                Mat3 J = Mat3::Zero();
                for (int c = 0; c < 8; ++c) {
                    const int o[3] = {c & 1, (c >> 1) & 1, (c >> 2) & 1};
                    for (int a = 0; a < 3; ++a) {
                        Real d = 1;
                        for (int b = 0; b < 3; ++b) {
                            if (b == a) d *= o[b] ? 1 : -1;
                            else d *= o[b] ? s[b] : 1 - s[b];
                        }
                        J.col(a) += d * x[static_cast<std::size_t>(c)];
                    }
                }
                v += weight[i] * weight[j] * weight[k] / 8 * J.determinant();
            }
    return v;
}

}  // namespace

TEST_CASE("volume: rest cells, affine maps, totals", "[deform]") {
    const Real h = 0.37;
    CHECK(hexVolume(unitCube(h, Vec3(100, -50, 20))) == Approx(h * h * h).epsilon(1e-14));
    const Lattice lat = sphereLattice(5.5);
    const LatticeCells cells = buildCells(lat);
    REQUIRE(cells.size() > 0);
    for (Index c = 0; c < cells.size(); ++c)
        for (int k = 0; k < 8; ++k)
            REQUIRE(lat.coords[cells.corners[c][k]] == cells.lowest[c] + Vec3i(k & 1, (k >> 1) & 1, (k >> 2) & 1));
    const std::vector<Vec3> x0 = restPositions(lat);
    for (Real v : cellVolumes(cells, x0)) REQUIRE(v == Approx(1).epsilon(1e-15));
    Mat3 A;
    A << 1.3, 0.4, -0.2, 0.1, 0.8, 0.5, -0.3, 0.2, 1.1;
    std::vector<Vec3> x(x0.size());
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = A * x0[i] + Vec3(3, -7, 11);
    const std::vector<Real> v = cellVolumes(cells, x);
    Real sum = 0;
    for (Real vc : v) {
        REQUIRE(vc == Approx(A.determinant()).epsilon(1e-13));
        sum += vc;
    }
    CHECK(totalVolume(cells, x) == Approx(sum).epsilon(1e-14));
    CHECK(totalVolume(cells, x) == Approx(A.determinant() * cells.size()).epsilon(1e-13));
}

TEST_CASE("volume: exact for a nonlinear trilinear cell; gradient", "[deform]") {
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<Real> u(-0.3, 0.3);
    for (int t = 0; t < 50; ++t) {
        std::array<Vec3, 8> x = unitCube(1.0, Vec3(5, 5, 5));
        for (Vec3& p : x) p += Vec3(u(rng), u(rng), u(rng));
        const Real v = hexVolume(x);
        REQUIRE(v == Approx(volumeByQuadrature(x)).epsilon(1e-13));
        std::array<Vec3, 8> g;
        REQUIRE(hexVolumeGradient(x, g) == Approx(v).epsilon(1e-15));
        for (int k = 0; k < 8; ++k)
            for (int a = 0; a < 3; ++a) {
                std::array<Vec3, 8> xp = x, xm = x;
                xp[k][a] += 1e-6;
                xm[k][a] -= 1e-6;
                REQUIRE(std::abs((hexVolume(xp) - hexVolume(xm)) / 2e-6 - g[k][a]) < 1e-8);
            }
    }
    // A known nonlinear deformation of a lattice: twisted cells against the quadrature.
    const Lattice lat = boxLattice(Vec3i(6, 4, 4), 1, 1);
    const LatticeCells cells = buildCells(lat);
    const std::vector<Vec3> X = mapPoints(restPositions(lat), twistMap(0.2, Vec3(3, 2, 2)));
    const std::vector<Real> v = cellVolumes(cells, X);
    for (Index c = 0; c < cells.size(); ++c) {
        std::array<Vec3, 8> x;
        for (int k = 0; k < 8; ++k) x[k] = X[cells.corners[c][k]];
        REQUIRE(v[c] == Approx(volumeByQuadrature(x)).epsilon(1e-13));
    }
}

TEST_CASE("volume: projection restores every cell volume, respects pins, is deterministic",
          "[deform]") {
    struct Case { const char* name; Lattice lat; MapFn map; bool pin; };
    const Vec3 c0(8, 4, 4);
    Case cases[] = {
        {"twist box", boxLattice(Vec3i(16, 8, 8), 1, 1), twistMap(0.05, c0), false},
        {"stretch sphere", sphereLattice(8), stretchMap(0.02, Vec3::Zero(), 8.0), true},
    };
    for (Case& cs : cases) {
        const LatticeCells cells = buildCells(cs.lat);
        const std::vector<Vec3> x0 = restPositions(cs.lat);
        const std::vector<Real> v0 = cellVolumes(cells, x0);
        const std::vector<Vec3> start = mapPoints(x0, cs.map);
        std::vector<unsigned char> pinned;
        if (cs.pin) {
            pinned.assign(x0.size(), 0);
            for (Index p = 0; p < cs.lat.size(); ++p) pinned[p] = cs.lat.coords[p].z() <= 3;
        }
        std::vector<Vec3> x = start;
        const VolumeProjectionReport r = projectVolumes(cells, v0, pinned, x);
        if (verbose())
            std::printf("projection %s: %lld cells, before %.3e after %.3e, %d GN its, %d CG its, max move %.3e\n",
                        cs.name, (long long)cells.size(), r.maxErrorBefore, r.maxErrorAfter, r.iterations,
                        r.linearIterations, r.maxMove);
        INFO(cs.name);
        CHECK(r.converged);
        CHECK(r.iterations <= 4);
        CHECK(r.maxErrorAfter < 1e-12);
        CHECK(r.maxErrorBefore > 1e-4);
        // Every cell with a free corner is restored; cells with all 8 corners pinned cannot
        // be (nothing may move) and are counted, not corrected.
        const std::vector<Real> v = cellVolumes(cells, x);
        Index allPinned = 0;
        for (Index c = 0; c < cells.size(); ++c) {
            bool free = pinned.empty();
            for (int k = 0; k < 8 && !free; ++k) free = !pinned[cells.corners[c][k]];
            if (free) REQUIRE(std::abs(v[c] / v0[c] - 1) < 1e-12);
            else ++allPinned;
        }
        CHECK(r.unconstrainable == allPinned);
        if (cs.pin) {
            CHECK(allPinned > 0);
            for (Index p = 0; p < cs.lat.size(); ++p)
                if (pinned[p]) REQUIRE(x[p] == start[p]);
        }
        // The minimum-norm correction moves no point further than a feasible one: pushing the
        // excess volume along a column of length D (the extent) with relative error e moves
        // points by at most e D.
        Box3 box;
        for (const Vec3& p : start) box.extend(p);
        CHECK(r.maxMove < r.maxErrorBefore * box.size().maxCoeff());
        // one thread gives the same bytes
        std::vector<Vec3> y = start;
        {
            tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
            (void)projectVolumes(cells, v0, pinned, y);
        }
        for (std::size_t i = 0; i < x.size(); ++i) REQUIRE(x[i] == y[i]);
    }
}

TEST_CASE("volume: projection timing on a 137k-point sphere", "[.][deform-bench]") {
    const Lattice lat = sphereLattice(32);
    const LatticeCells cells = buildCells(lat);
    const std::vector<Vec3> x0 = restPositions(lat);
    const std::vector<Real> v0 = cellVolumes(cells, x0);
    for (Real amp : {0.002, 0.01, 0.03}) {
        std::vector<Vec3> x = mapPoints(mapPoints(x0, twistMap(0.01, Vec3::Zero())), stretchMap(amp, Vec3::Zero(), 16.0));
        const auto t0 = std::chrono::steady_clock::now();
        const VolumeProjectionReport r = projectVolumes(cells, v0, {}, x);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("sphere r=32: %lld points, %lld cells, amp %.3f: before %.3e after %.3e, %d GN, %d CG, move %.3e, %.3f s\n",
                    (long long)lat.size(), (long long)cells.size(), amp, r.maxErrorBefore, r.maxErrorAfter,
                    r.iterations, r.linearIterations, r.maxMove, s);
        CHECK(r.converged);
    }
}
