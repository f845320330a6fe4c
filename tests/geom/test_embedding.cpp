// Tests of the lattice deformer (src/geom/embedding.hpp).
#include <catch2/catch.hpp>

#include "geom/embedding.hpp"
#include "geom/geometric_state.hpp"
#include "geom/lattice.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

using namespace dgv;

namespace {

/// A ball of lattice points (voxel centres within radius) in world units.
Lattice ballLattice(Real h) {
    const Real radius = 1.0;
    const int n = static_cast<int>(std::ceil(2 * radius / h)) + 3;
    const Vec3 origin = Vec3::Constant(-h * (n - 1) / 2.0) + Vec3(0.013, -0.021, 0.007);
    std::vector<unsigned char> mask(static_cast<std::size_t>(n) * n * n, 0);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                mask[static_cast<std::size_t>(i + n * (j + n * k))] = (origin + h * Vec3(i, j, k)).norm() <= radius;
    return buildLattice(origin, h, Vec3i(n, n, n), mask);
}

/// Vertices of a sphere surface at radius r (Fibonacci points), plus a few inside.
std::vector<Vec3> sampleVertices(Real r, int count) {
    std::vector<Vec3> v;
    const Real golden = M_PI * (3 - std::sqrt(5.0));
    for (int i = 0; i < count; ++i) {
        const Real y = 1 - 2 * (i + 0.5) / count;
        const Real rr = std::sqrt(1 - y * y);
        v.push_back(r * Vec3(std::cos(golden * i) * rr, y, std::sin(golden * i) * rr));
    }
    for (int i = 0; i < 50; ++i) v.push_back(Vec3(0.01 * i - 0.25, 0.003 * i, -0.005 * i));
    return v;
}

Real maxError(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    REQUIRE(a.size() == b.size());
    Real e = 0;
    for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, (a[i] - b[i]).norm());
    return e;
}

}  // namespace

TEST_CASE("embedding: trilinear inside, nearest anchor outside", "[geom]") {
    const Lattice lat = ballLattice(0.1);
    // Surface at radius 1.0 and points up to two voxels beyond it.
    std::vector<Vec3> verts = sampleVertices(1.0, 400);
    const std::vector<Vec3> outside = sampleVertices(1.2, 200);
    verts.insert(verts.end(), outside.begin(), outside.end());
    const MeshEmbedding emb = embedVertices(lat, verts);
    REQUIRE(emb.size() == verts.size());
    std::size_t tri = 0, anchored = 0;
    for (std::size_t v = 0; v < verts.size(); ++v) {
        const Vec3 u = (verts[v] - lat.originWorld) / lat.spacing;
        if (emb.trilinear(v)) {
            ++tri;
            Real sum = 0;
            Vec3 at = Vec3::Zero();
            for (int k = 0; k < 8; ++k) {
                REQUIRE(emb.corners[v][k] != kNoPoint);
                REQUIRE(emb.weights[v][k] >= 0);
                sum += emb.weights[v][k];
                at += emb.weights[v][k] * lat.coords[emb.corners[v][k]].cast<Real>();
            }
            REQUIRE(sum == Approx(1).epsilon(1e-14));
            REQUIRE((at - u).norm() < 1e-12);
        } else {
            ++anchored;
        }
        // The anchor is the nearest material point (brute force).
        Real best = 1e300;
        for (Index p = 0; p < lat.size(); ++p) best = std::min(best, (lat.coords[p].cast<Real>() - u).squaredNorm());
        REQUIRE(emb.offset[v].squaredNorm() == Approx(best).epsilon(1e-12));
        REQUIRE((lat.coords[emb.anchor[v]].cast<Real>() + emb.offset[v] - u).norm() < 1e-12);
    }
    REQUIRE(tri > 50);        // the interior points
    REQUIRE(anchored > 500);  // the surface: most cells straddle it
}

TEST_CASE("embedding: a vertex far outside the grid still finds its anchor", "[geom]") {
    const Lattice lat = ballLattice(0.25);
    const std::vector<Vec3> verts = {Vec3(5, 0, 0), Vec3(-3, -3, 4), Vec3(0, 0, 0)};
    const MeshEmbedding emb = embedVertices(lat, verts);
    for (std::size_t v = 0; v < verts.size(); ++v) {
        Real best = 1e300;
        Index arg = kNoPoint;
        for (Index p = 0; p < lat.size(); ++p) {
            const Real d = (lat.restPosition(p) - verts[v]).squaredNorm();
            if (d < best) best = d, arg = p;
        }
        REQUIRE(emb.anchor[v] == arg);
    }
}

TEST_CASE("embedding: rest positions reproduced, affine motions and rotations exact", "[geom]") {
    const Lattice lat = ballLattice(0.1);
    std::vector<Vec3> verts = sampleVertices(1.0, 500);
    const std::vector<Vec3> outside = sampleVertices(1.18, 300);
    verts.insert(verts.end(), outside.begin(), outside.end());
    const MeshEmbedding emb = embedVertices(lat, verts);
    const std::vector<Vec3> rest = restPositions(lat);

    GeometricState st;
    std::vector<Vec3> moved;
    SECTION("rest") {
        computeGeometricState(lat, rest, st);
        deformVertices(emb, st, moved);
        REQUIRE(maxError(moved, verts) < 1e-12);
    }
    SECTION("affine, and rotation + translation") {
        std::mt19937_64 rng(4242);
        std::uniform_real_distribution<Real> d(-0.5, 0.5);
        std::vector<std::pair<Mat3, Vec3>> motions;
        for (int t = 0; t < 3; ++t) {
            Mat3 a = Mat3::Identity();
            for (int i = 0; i < 9; ++i) a(i / 3, i % 3) += d(rng);
            if (a.determinant() <= 0.2) continue;
            motions.push_back({a, Vec3(d(rng), d(rng), d(rng)) * 10});
        }
        motions.push_back(
            {Eigen::AngleAxis<Real>(2.2, Vec3(-1, 3, 1).normalized()).toRotationMatrix(), Vec3(4, -2, 1)});
        REQUIRE(motions.size() >= 3);
        for (const auto& [a, b] : motions) {
            std::vector<Vec3> x(rest.size());
            for (std::size_t p = 0; p < x.size(); ++p) x[p] = a * rest[p] + b;
            computeGeometricState(lat, x, st);
            for (bool second : {true, false}) {
                MeshEmbedding e = emb;
                e.secondOrder = second;
                deformVertices(e, st, moved);
                std::vector<Vec3> expected(verts.size());
                for (std::size_t v = 0; v < verts.size(); ++v) expected[v] = a * verts[v] + b;
                Real eTri = 0, eAnchor = 0;
                for (std::size_t v = 0; v < verts.size(); ++v) {
                    Real& e2 = emb.trilinear(v) ? eTri : eAnchor;
                    e2 = std::max(e2, (moved[v] - expected[v]).norm());
                }
                INFO("trilinear error " << eTri << ", anchored error " << eAnchor);
                REQUIRE(eTri < 1e-12);
                REQUIRE(eAnchor < 1e-12);
            }
        }
    }
}

TEST_CASE("embedding: fitted outside the cells, rest and affine motions stay exact and the fit is smooth", "[geom]") {
    // fitOutside (the one-solve step's bodies): every vertex outside the cells follows its
    // neighbourhood's affine fit, which reproduces any affine motion exactly, and a rough boundary
    // layer (its points jittered by a tenth of a voxel) moves the fitted vertices less than the
    // anchors' frames move them.
    const Lattice lat = ballLattice(0.1);
    std::vector<Vec3> verts = sampleVertices(1.0, 400);
    const MeshEmbedding fit = embedVertices(lat, verts, true);
    const MeshEmbedding frames = embedVertices(lat, verts);
    std::size_t outside = 0;
    for (std::size_t v = 0; v < fit.size(); ++v) outside += fit.trilinear(v) ? 0 : 1;
    REQUIRE(outside > 100);
    const std::vector<Vec3> rest = restPositions(lat);
    GeometricState st;
    std::vector<Vec3> moved;
    computeGeometricState(lat, rest, st);
    deformVertices(fit, st, moved);
    CHECK(maxError(moved, verts) < 1e-12);
    const Mat3 a = (Mat3() << 1.3, 0.2, -0.1, 0.1, 0.8, 0.3, -0.2, 0.1, 1.1).finished();
    const Vec3 b(0.3, -1, 2);
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = a * rest[p] + b;
    computeGeometricState(lat, x, st);
    deformVertices(fit, st, moved);
    std::vector<Vec3> expected(verts.size());
    for (std::size_t v = 0; v < verts.size(); ++v) expected[v] = a * verts[v] + b;
    CHECK(maxError(moved, expected) < 1e-12);
    // jitter: every point moved by up to a tenth of a voxel
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<Real> d(-0.1, 0.1);
    for (Vec3& p : x) p = p + lat.spacing * Vec3(d(rng), d(rng), d(rng));
    computeGeometricState(lat, x, st);
    std::vector<Vec3> byFit, byFrames;
    deformVertices(fit, st, byFit);
    deformVertices(frames, st, byFrames);
    Real worstFit = 0, worstFrames = 0;
    for (std::size_t v = 0; v < verts.size(); ++v) {
        if (fit.trilinear(v)) continue;
        worstFit = std::max(worstFit, (byFit[v] - expected[v]).norm());
        worstFrames = std::max(worstFrames, (byFrames[v] - expected[v]).norm());
    }
    INFO("worst displacement by the jitter: fit " << worstFit << ", frames " << worstFrames);
    CHECK(worstFit < 0.2 * lat.spacing);
    CHECK(worstFit < 0.5 * worstFrames);
}

TEST_CASE("embedding: a fitted surface is continuous where its vertices' anchors change", "[geom]") {
    // A dense arc of vertices 1.5 voxels outside a ball (a part thinner than the lattice, as on a
    // spider's leg), over a rough lattice: a bend plus a tenth of a voxel of jitter. Neighbouring
    // vertices change anchor along the arc; their fits, centred on each vertex, must move them
    // as a continuous surface: no step between neighbours beyond the deformation's own stretch.
    const Lattice lat = ballLattice(0.1);
    const Real r = 1.0 + 0.15;
    std::vector<Vec3> verts;
    for (int i = 0; i <= 2000; ++i) {
        const Real t = 0.2 + 2.0 * i / 2000.0;  // radians; neighbours 0.001 r (0.01 voxel) apart
        verts.push_back(r * Vec3(std::cos(t), std::sin(t) * 0.8, std::sin(t) * 0.6));
    }
    const MeshEmbedding emb = embedVertices(lat, verts, true);
    Index anchorChanges = 0;
    for (std::size_t v = 0; v < verts.size(); ++v) {
        REQUIRE(emb.fitBlend[v] == 1);
        if (v > 0 && emb.anchor[v] != emb.anchor[v - 1]) ++anchorChanges;
        // the fit's derivative reproduces the identity: sum 0, sum grad_j u_jᵀ = 1
        Vec3 sum = Vec3::Zero();
        Mat3 id = Mat3::Zero();
        for (Index j = emb.fitStart[v]; j < emb.fitStart[v + 1]; ++j) {
            sum += emb.fitGradient[at(j)];
            id += emb.fitGradient[at(j)] * lat.coords[at(emb.fitPoint[at(j)])].cast<Real>().transpose();
        }
        REQUIRE(sum.norm() < 1e-12);
        REQUIRE((id - Mat3::Identity()).norm() < 1e-10);
    }
    REQUIRE(anchorChanges > 10);
    const std::vector<Vec3> rest = restPositions(lat);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<Real> jitter(-0.1, 0.1);
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) {
        const Vec3& q = rest[p];
        x[p] = Vec3(q.x() + 0.2 * q.y() * q.y(), q.y() + 0.1 * std::sin(2 * q.x()), q.z()) +
               lat.spacing * Vec3(jitter(rng), jitter(rng), jitter(rng));
    }
    GeometricState st;
    computeGeometricState(lat, x, st);
    std::vector<Vec3> moved;
    deformVertices(emb, st, moved);
    Real worst = 0;
    for (std::size_t v = 1; v < verts.size(); ++v)
        worst = std::max(worst, (moved[v] - moved[v - 1]).norm() / (verts[v] - verts[v - 1]).norm());
    INFO("anchor changes " << anchorChanges << "; worst neighbour stretch " << worst);
    if (std::getenv("DGV_TEST_VERBOSE")) std::printf("anchor changes %ld, worst neighbour stretch %.3f\n", long(anchorChanges), worst);
    // the bend stretches by at most 1.5; a jump of a hundredth of the jitter would read as 2
    REQUIRE(worst < 2);
}

TEST_CASE("embedding: second-order anchors follow a bend better than first-order", "[geom]") {
    // Bend the ball about the z axis through (0, -4, 0): a smooth non-affine map.
    const Lattice lat = ballLattice(0.1);
    const std::vector<Vec3> verts = sampleVertices(1.05, 600);
    const MeshEmbedding emb = embedVertices(lat, verts);
    auto bend = [](const Vec3& p) {
        const Real radius = 4, angle = p.x() / radius, rr = radius + p.y();
        return Vec3(rr * std::sin(angle), rr * std::cos(angle) - radius, p.z());
    };
    const std::vector<Vec3> rest = restPositions(lat);
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) x[p] = bend(rest[p]);
    GeometricState st;
    computeGeometricState(lat, x, st);
    std::array<Real, 2> rms{}, worst{};
    for (int second = 0; second < 2; ++second) {
        MeshEmbedding e = emb;
        e.secondOrder = second == 1;
        std::vector<Vec3> moved;
        deformVertices(e, st, moved);
        int count = 0;
        for (std::size_t v = 0; v < verts.size(); ++v) {
            if (emb.trilinear(v)) continue;
            const Real d = (moved[v] - bend(verts[v])).norm();
            rms[second] += d * d;
            worst[second] = std::max(worst[second], d);
            ++count;
        }
        REQUIRE(count > 300);
        rms[second] = std::sqrt(rms[second] / count);
    }
    INFO("anchored vertices, first order: rms " << rms[0] << " max " << worst[0] << "; second order: rms " << rms[1]
                                                << " max " << worst[1]);
    REQUIRE(rms[1] < 0.2 * rms[0]);
    REQUIRE(worst[1] <= worst[0]);
    REQUIRE(worst[1] < 0.05 * lat.spacing);  // well below a voxel
}

TEST_CASE("embedding: vertices far from the lattice follow their neighbourhood's fit, not one frame", "[geom]") {
    // A leg of vertices 1-4 voxels beyond the ball (a part thinner than the lattice resolves).
    const Lattice lat = ballLattice(0.1);
    std::vector<Vec3> verts;
    for (int i = 0; i <= 80; ++i) verts.push_back(Vec3(0.3, -0.2, 0.9).normalized() * (1.0 + 0.005 * i));
    const MeshEmbedding emb = embedVertices(lat, verts);
    Index far = 0;
    for (std::size_t v = 0; v < verts.size(); ++v) {
        const Real d = emb.offset[v].norm();
        if (emb.trilinear(v)) continue;
        // No fit within kFitFrom voxels (the anchor rule alone), all fit from kFitFull.
        if (d <= kFitFrom) REQUIRE(emb.fitBlend[v] == 0);
        if (d >= kFitFull) REQUIRE(emb.fitBlend[v] == 1);
        if (emb.fitBlend[v] > 0) {
            ++far;
            Real sum = 0;
            Vec3 at = Vec3::Zero();
            for (Index j = emb.fitStart[v]; j < emb.fitStart[v + 1]; ++j) {
                sum += emb.fitWeight[j];
                at += emb.fitWeight[j] * lat.coords[emb.fitPoint[j]].cast<Real>();
            }
            REQUIRE(sum == Approx(1).epsilon(1e-12));
            REQUIRE((at - (verts[v] - lat.originWorld) / lat.spacing).norm() < 1e-10);
        }
    }
    REQUIRE(far > 40);
    REQUIRE(emb.fittedVertices() == far);

    // An affine motion with lattice-scale noise on the positions (the roughness of a goo body or
    // a creased contact layer): the second-order rule extrapolates one point's rough frame and
    // second derivatives over the offset, the fit averages them.
    const std::vector<Vec3> rest = restPositions(lat);
    Mat3 a;
    a << 1.2, 0.3, -0.1, 0.0, 0.9, 0.2, 0.1, -0.2, 1.1;
    const Vec3 b(0.5, -1, 2);
    std::mt19937_64 rng(77);
    std::uniform_real_distribution<Real> noise(-0.05, 0.05);
    std::vector<Vec3> x(rest.size());
    for (std::size_t p = 0; p < x.size(); ++p) {
        x[p] = a * rest[p] + b + lat.spacing * Vec3(noise(rng), noise(rng), noise(rng));
    }
    GeometricState st;
    computeGeometricState(lat, x, st);
    MeshEmbedding frameOnly = emb;
    std::fill(frameOnly.fitBlend.begin(), frameOnly.fitBlend.end(), Real(0));
    std::vector<Vec3> fitted, framed;
    deformVertices(emb, st, fitted);
    deformVertices(frameOnly, st, framed);
    Real eFit = 0, eFrame = 0;
    for (std::size_t v = 0; v < verts.size(); ++v) {
        if (emb.offset[v].norm() < kFitFull) continue;
        const Vec3 expected = a * verts[v] + b;
        eFit = std::max(eFit, (fitted[v] - expected).norm());
        eFrame = std::max(eFrame, (framed[v] - expected).norm());
    }
    INFO("worst error past kFitFull voxels, in voxels: fit " << eFit / lat.spacing << ", frame "
                                                             << eFrame / lat.spacing);
    if (std::getenv("DGV_TEST_VERBOSE")) {
        std::printf("far vertices %ld; worst error past %.1f voxels: fit %.4f, frame %.4f voxels\n", long(far),
                    kFitFull, eFit / lat.spacing, eFrame / lat.spacing);
    }
    REQUIRE(eFit < 0.1 * lat.spacing);  // the noise is 0.05 voxel a component
    REQUIRE(eFit < 0.25 * eFrame);
}

TEST_CASE("embedding: a one-voxel sheet keeps its anchors' frames (no fit spans it)", "[geom]") {
    // A sheet one voxel thick: every neighbourhood is flat, so the fit is undetermined off it.
    const Real h = 0.1;
    const Vec3i dims(10, 10, 3);
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 0);
    for (int j = 0; j < 10; ++j)
        for (int i = 0; i < 10; ++i) mask[static_cast<std::size_t>(i + 10 * (j + 10 * 1))] = 1;
    const Lattice lat = buildLattice(Vec3::Zero(), h, dims, mask);
    const std::vector<Vec3> verts = {Vec3(0.45, 0.45, 0.1 + 0.25), Vec3(0.45, 0.45, 0.1 - 0.3)};
    const MeshEmbedding emb = embedVertices(lat, verts);
    for (std::size_t v = 0; v < verts.size(); ++v) {
        REQUIRE(emb.offset[v].norm() > kFitFull);
        REQUIRE(emb.fitBlend[v] == 0);
    }
}
