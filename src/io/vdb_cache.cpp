// Per-frame OpenVDB caches (vdb_cache.hpp, docs/vdb.md).
//
// Resampling. Each lattice cell is the trilinear image x(s), s in [0,1]^3, of its 8 corners.
// A world voxel (centre p, size vs) takes from cell c the coverage
//     cov_c(p) = prod_a  max(0, min(vs/2, d0_a) + min(vs/2, d1_a)) / vs,
// where s = x^-1(p) (Newton from the cell's affine approximation) and d0_a = s_a / |grad s_a|,
// d1_a = (1 - s_a) / |grad s_a| are the first-order distances from p to the cell's two faces
// across axis a: the separable box filter of the cell, exact for an undeformed cell. Cells do
// not overlap, so the voxel's coverage of the object is the SUM over cells (clamped to 1); on a
// face shared by two cells the two overlaps add up to one voxel, hence no seams, and the
// integral of density equals the object's volume up to second-order terms. vel, rest and
// contact are the coverage-weighted means of the cells' trilinear interpolants.
// Parallel over 8^3 blocks (OpenVDB leaves): each block reads the cells overlapping it in
// increasing cell order and owns its voxels, so the result does not depend on the thread count.

#include "io/vdb_cache.hpp"

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "io/atomic_file.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/ValueTransformer.h>

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <memory>
#include <utility>

#ifndef DGV_VERSION_STRING
#define DGV_VERSION_STRING "unknown"
#endif

namespace dgv {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr int kLeafDim = 8;  // OpenVDB leaf edge (FloatTree / Vec3STree: 8^3 voxels)
constexpr int kLeafVoxels = kLeafDim * kLeafDim * kLeafDim;

/// The trilinear map of one cell in monomial form,
/// x(s) = a0 + a1 s0 + a2 s1 + a3 s2 + a4 s0 s1 + a5 s0 s2 + a6 s1 s2 + a7 s0 s1 s2.
template <typename T>
std::array<T, 8> monomials(const std::array<T, 8>& X) {
    return {X[0],
            X[1] - X[0],
            X[2] - X[0],
            X[4] - X[0],
            X[3] - X[1] - X[2] + X[0],
            X[5] - X[1] - X[4] + X[0],
            X[6] - X[2] - X[4] + X[0],
            X[7] - X[6] - X[5] - X[3] + X[4] + X[2] + X[1] - X[0]};
}

/// evalMonomials for vectors, in scalars.
inline Vec3 evalVec(const std::array<Vec3, 8>& a, const Vec3& s) {
    const Real s0 = s[0], s1 = s[1], s2 = s[2], s01 = s0 * s1, s02 = s0 * s2, s12 = s1 * s2, s012 = s01 * s2;
    Vec3 r;
    for (int q = 0; q < 3; ++q)
        r[q] = a[0][q] + a[1][q] * s0 + a[2][q] * s1 + a[3][q] * s2 + a[4][q] * s01 + a[5][q] * s02 + a[6][q] * s12 + a[7][q] * s012;
    return r;
}

template <typename T>
T evalMonomials(const std::array<T, 8>& a, const Vec3& s) {
    return a[0] + a[1] * s[0] + a[2] * s[1] + a[3] * s[2] + a[4] * (s[0] * s[1]) +
           a[5] * (s[0] * s[2]) + a[6] * (s[1] * s[2]) + a[7] * (s[0] * s[1] * s[2]);
}

Mat3 jacobian(const std::array<Vec3, 8>& a, const Vec3& s) {
    Mat3 J;
    J.col(0) = a[1] + a[4] * s[1] + a[5] * s[2] + a[7] * (s[1] * s[2]);
    J.col(1) = a[2] + a[4] * s[0] + a[6] * s[2] + a[7] * (s[0] * s[2]);
    J.col(2) = a[3] + a[5] * s[0] + a[6] * s[1] + a[7] * (s[0] * s[1]);
    return J;
}

/// Inverse of J when det J > tiny * scale^3 (a right-handed, non-degenerate cell); false else.
bool invertPositive(const Mat3& J, Real scale, Mat3& inv) {
    const Vec3 c0 = J.col(1).cross(J.col(2)), c1 = J.col(2).cross(J.col(0)), c2 = J.col(0).cross(J.col(1));
    const Real det = J.col(0).dot(c0);
    if (!(det > 1e-12 * scale * scale * scale)) return false;
    inv.row(0) = c0.transpose() / det;
    inv.row(1) = c1.transpose() / det;
    inv.row(2) = c2.transpose() / det;
    return true;
}

struct CellMap {
    std::array<Vec3, 8> x;   // position monomials
    std::array<Vec3, 8> v;   // velocity monomials
    std::array<Real, 8> k;   // contact monomials
    Mat3 centreInverse;      // J(1/2)^-1
    Vec3 centre;             // x(1/2)
    Vec3 restLowest;         // rest position of the lowest corner
    Real h = 1;              // lattice spacing
    Vec3 margin;             // prefilter margin per axis, in s units
    Eigen::Vector3i lo, hi;  // world voxel index range to visit (inclusive)
    bool valid = false;      // centre Jacobian invertible and positive
    Real acceptStep = 0;     // Newton stops after a step this small (s units), see solveCell
    Real kNewton = 0;        // 4 |J(1/2)^-1| |nonlinear part|: bounds second-order errors in s
    Vec3 reach;              // per axis: bound on g_a hv (coverage > 0 needs -reach < s_a < 1 + reach)
};

/// A solved voxel: s = x^-1(p) and J^-1 at (the last Newton iterate before) s.
struct InverseSolve {
    Vec3 s;
    Mat3 inv;
    Vec3 p;
    Vec3 g2;  // |grad s_a|^2 = |row a of J^-1|^2
    /// First-order guess for the solution at q: s + J^-1 (q - p).
    Vec3 predict(const Vec3& q) const { return s + inv * (q - p); }
};

/// Newton's method for x(s) = p from sol.s (the prediction), written out in scalars: each step
/// evaluates x and J together and inverts J by cofactors. Quadratic convergence: after a step
/// of size d the error is about K d^2, K = |J^-1| |second derivatives of x| (the cell's
/// `acceptStep` is 1e-6 / sqrt(K) capped at 1e-4), so stopping after a step below acceptStep
/// leaves an error below ~1e-12 in s. Returns false for a Jacobian with det <= detMin (inverted or
/// degenerate cell) or no convergence in 12 steps. s is kept within [-1, 2]^3.
inline bool solveCell(const CellMap& m, const Vec3& p, Real detMin, InverseSolve& sol) {
    const std::array<Vec3, 8>& a = m.x;
    Real s0 = sol.s[0], s1 = sol.s[1], s2 = sol.s[2];
    sol.p = p;
    for (int it = 0; it < 12; ++it) {
        const Real s01 = s0 * s1, s02 = s0 * s2, s12 = s1 * s2, s012 = s01 * s2;
        Real r[3], c0[3], c1[3], c2[3];  // residual x(s) - p; Jacobian columns
        for (int q = 0; q < 3; ++q) {
            r[q] = a[0][q] + a[1][q] * s0 + a[2][q] * s1 + a[3][q] * s2 + a[4][q] * s01 + a[5][q] * s02 +
                   a[6][q] * s12 + a[7][q] * s012 - p[q];
            c0[q] = a[1][q] + a[4][q] * s1 + a[5][q] * s2 + a[7][q] * s12;
            c1[q] = a[2][q] + a[4][q] * s0 + a[6][q] * s2 + a[7][q] * s02;
            c2[q] = a[3][q] + a[5][q] * s0 + a[6][q] * s1 + a[7][q] * s01;
        }
        // rows of J^-1: (c1 x c2, c2 x c0, c0 x c1) / det
        const Real r0x = c1[1] * c2[2] - c1[2] * c2[1], r0y = c1[2] * c2[0] - c1[0] * c2[2], r0z = c1[0] * c2[1] - c1[1] * c2[0];
        const Real det = c0[0] * r0x + c0[1] * r0y + c0[2] * r0z;
        if (!(det > detMin)) return false;
        const Real r1x = c2[1] * c0[2] - c2[2] * c0[1], r1y = c2[2] * c0[0] - c2[0] * c0[2], r1z = c2[0] * c0[1] - c2[1] * c0[0];
        const Real r2x = c0[1] * c1[2] - c0[2] * c1[1], r2y = c0[2] * c1[0] - c0[0] * c1[2], r2z = c0[0] * c1[1] - c0[1] * c1[0];
        const Real id = 1 / det;
        const Real d0 = (r0x * r[0] + r0y * r[1] + r0z * r[2]) * id;
        const Real d1 = (r1x * r[0] + r1y * r[1] + r1z * r[2]) * id;
        const Real d2 = (r2x * r[0] + r2y * r[1] + r2z * r[2]) * id;
        s0 = std::min(Real(2), std::max(Real(-1), s0 - d0));
        s1 = std::min(Real(2), std::max(Real(-1), s1 - d1));
        s2 = std::min(Real(2), std::max(Real(-1), s2 - d2));
        if (std::max(std::abs(d0), std::max(std::abs(d1), std::abs(d2))) < m.acceptStep) {
            sol.s = Vec3(s0, s1, s2);
            sol.inv << r0x * id, r0y * id, r0z * id, r1x * id, r1y * id, r1z * id, r2x * id, r2y * id, r2z * id;
            sol.g2 = Vec3(r0x * r0x + r0y * r0y + r0z * r0z, r1x * r1x + r1y * r1y + r1z * r1z,
                          r2x * r2x + r2y * r2y + r2z * r2z) * (id * id);
            return true;
        }
    }
    return false;
}

struct ObjectRefs {
    const VdbObjectFrame* frame;
    Index firstCell;  // global cell id of its cell 0
};

std::string sanitise(const std::string& s) {
    std::string out;
    for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_') ? c : '_';
    return out.empty() ? std::string("object") : out;
}

void validate(const std::vector<VdbObjectFrame>& objects, const VdbFrameInfo& info,
              const VdbWriteSettings& settings) {
    auto bad = [](const std::string& where, const std::string& what) { throw InputError("", where, what); };
    if (objects.empty()) bad("vdb", "no object to write");
    for (std::size_t o = 0; o < objects.size(); ++o) {
        const VdbObjectFrame& f = objects[o];
        const std::string w = "vdb: object " + std::to_string(o) + " (" + f.name + ")";
        if (!f.lattice || !f.cells || !f.positions || !f.restVolumes) bad(w, "lattice, cells, positions and rest volumes are required");
        const std::size_t P = static_cast<std::size_t>(f.lattice->size());
        const std::size_t C = static_cast<std::size_t>(f.cells->size());
        if (!(f.lattice->spacing > 0) || !std::isfinite(f.lattice->spacing)) bad(w, "lattice spacing must be positive");
        if (f.positions->size() != P) bad(w, "positions: expected " + std::to_string(P) + " entries, got " + std::to_string(f.positions->size()));
        if (f.velocities && f.velocities->size() != P) bad(w, "velocities: expected " + std::to_string(P) + " entries, got " + std::to_string(f.velocities->size()));
        if (f.contact && f.contact->size() != P) bad(w, "contact: expected " + std::to_string(P) + " entries, got " + std::to_string(f.contact->size()));
        if (f.restVolumes->size() != C) bad(w, "rest volumes: expected " + std::to_string(C) + " entries, got " + std::to_string(f.restVolumes->size()));
        for (Real v0 : *f.restVolumes)
            if (!(v0 > 0) || !std::isfinite(v0)) bad(w, "rest volumes must be positive");
        for (const Vec3& x : *f.positions)
            if (!allFiniteNoTrap(x)) bad(w, "positions must be finite");
        if (f.velocities)
            for (const Vec3& x : *f.velocities)
                if (!allFiniteNoTrap(x)) bad(w, "velocities must be finite");
    }
    if (!(settings.worldVoxelSize >= 0) || !std::isfinite(settings.worldVoxelSize)) bad("vdb: voxel_size", "must be positive (or 0 for the lattice spacing)");
    if (!(settings.surfaceHalfWidth >= 1) || !std::isfinite(settings.surfaceHalfWidth)) bad("vdb: surface half width", "must be at least 1 voxel");
    if (!std::isfinite(info.time) || !(info.fps > 0) || !std::isfinite(info.fps)) bad("vdb", "time must be finite and fps positive");
}

openvdb::math::Transform::Ptr latticeTransform(Real h, const Vec3& origin) {
    auto t = openvdb::math::Transform::createLinearTransform(h);
    t->postTranslate(openvdb::Vec3d(origin.x(), origin.y(), origin.z()));
    return t;
}

/// The world grids: density, vel, rest, contact.
struct WorldGrids {
    openvdb::FloatGrid::Ptr density, contact;
    openvdb::Vec3SGrid::Ptr vel, rest;
    Index activeVoxels = 0;
    Real densitySum = 0;
    Index unresolved = 0;
};

WorldGrids resample(const std::vector<VdbObjectFrame>& objects, Real vs, const Vec3& origin,
                    const openvdb::math::Transform::Ptr& xform, VdbStageSeconds& stages) {
    auto t = Clock::now();
    // ---- per-cell maps --------------------------------------------------------------------
    std::vector<ObjectRefs> refs;
    Index totalCells = 0;
    for (const VdbObjectFrame& f : objects) {
        refs.push_back({&f, totalCells});
        totalCells += f.cells->size();
    }
    std::vector<CellMap> maps(static_cast<std::size_t>(totalCells));
    std::vector<Index> objectOfCell(static_cast<std::size_t>(totalCells));
    for (std::size_t o = 0; o < refs.size(); ++o) {
        const VdbObjectFrame& f = *refs[o].frame;
        const Index first = refs[o].firstCell;
        parallelFor(f.cells->size(), [&](Index c) {
            CellMap& m = maps[static_cast<std::size_t>(first + c)];
            objectOfCell[static_cast<std::size_t>(first + c)] = static_cast<Index>(o);
            const auto& corners = f.cells->corners[static_cast<std::size_t>(c)];
            std::array<Vec3, 8> X, V;
            std::array<Real, 8> K;
            Vec3 bmin = Vec3::Constant(std::numeric_limits<Real>::max()), bmax = -bmin;
            for (int q = 0; q < 8; ++q) {
                const std::size_t p = static_cast<std::size_t>(corners[static_cast<std::size_t>(q)]);
                X[static_cast<std::size_t>(q)] = (*f.positions)[p];
                V[static_cast<std::size_t>(q)] = f.velocities ? (*f.velocities)[p] : Vec3::Zero();
                K[static_cast<std::size_t>(q)] = (f.contact && (*f.contact)[p]) ? 1.0 : 0.0;
                bmin = bmin.cwiseMin((*f.positions)[p]);
                bmax = bmax.cwiseMax((*f.positions)[p]);
            }
            m.x = monomials(X);
            m.v = monomials(V);
            m.k = monomials(K);
            m.h = f.lattice->spacing;
            m.restLowest = f.lattice->originWorld + m.h * f.cells->lowest[static_cast<std::size_t>(c)].cast<Real>();
            const Vec3 half = Vec3::Constant(0.5);
            m.centre = evalMonomials(m.x, half);
            const Real scale = (bmax - bmin).maxCoeff();
            m.valid = scale > 0 && invertPositive(jacobian(m.x, half), scale, m.centreInverse);
            if (!m.valid) {
                m.lo = Eigen::Vector3i::Zero();
                m.hi = Eigen::Vector3i::Constant(-1);
                return;
            }
            // Deviation of x from its linearisation at the centre over the visited region,
            // |s - 1/2| <= 1/2 + mu, is at most (|a4|+|a5|+|a6|)(1/2+mu)^2 + |a7| 3 (1/2+mu)^2 ...;
            // the prefilter only needs a bound, Newton decides.
            const Real nonlinear = m.x[4].norm() + m.x[5].norm() + m.x[6].norm() + 2 * m.x[7].norm();
            for (int a = 0; a < 3; ++a) {
                const Real g = m.centreInverse.row(a).norm();
                m.margin[a] = g * (0.5 * vs) * 1.5 + g * nonlinear * 2.25 + 1e-9;
            }
            m.kNewton = 4 * m.centreInverse.norm() * nonlinear;  // see solveCell
            // g_a = |row a of J^-1| changes over the cell (|s - 1/2| < 1 + margin) by a factor
            // below 1 + kNewton (first order in the nonlinear part; generous) while kNewton <= 1;
            // more distorted cells are not pre-screened
            for (int a = 0; a < 3; ++a)
                m.reach[a] = m.kNewton <= 1 ? m.centreInverse.row(a).norm() * (0.5 * vs) * (1 + m.kNewton) : Real(1e30);
            m.acceptStep = m.kNewton > 1e-4 ? 1e-6 / std::sqrt(m.kNewton) : Real(1e-4);
            // world box: the hull of the corners contains the cell; pad by the margin region
            const Real pad = vs + 2.25 * nonlinear;
            for (int a = 0; a < 3; ++a) {
                m.lo[a] = static_cast<int>(std::ceil((bmin[a] - pad - origin[a]) / vs));
                m.hi[a] = static_cast<int>(std::floor((bmax[a] + pad - origin[a]) / vs));
            }
        }, 256);
    }

    stages.cells = since(t);
    t = Clock::now();

    // ---- bin cells by leaf block ------------------------------------------------------------
    auto floorDiv = [](int a) { return a >= 0 ? a / kLeafDim : -((-a + kLeafDim - 1) / kLeafDim); };
    constexpr std::int64_t kOff = std::int64_t(1) << 20;
    auto key = [&](int bx, int by, int bz) {
        return (std::uint64_t(bz + kOff) << 42) | (std::uint64_t(by + kOff) << 21) | std::uint64_t(bx + kOff);
    };
    std::vector<Index> counts(static_cast<std::size_t>(totalCells) + 1, 0);
    parallelFor(totalCells, [&](Index c) {
        const CellMap& m = maps[static_cast<std::size_t>(c)];
        if (!m.valid) return;
        Index n = 1;
        for (int a = 0; a < 3; ++a) n *= floorDiv(m.hi[a]) - floorDiv(m.lo[a]) + 1;
        counts[static_cast<std::size_t>(c) + 1] = n;
    }, 1024);
    for (std::size_t i = 1; i < counts.size(); ++i) counts[i] += counts[i - 1];
    std::vector<std::pair<std::uint64_t, Index>> pairs(static_cast<std::size_t>(counts.back()));
    parallelFor(totalCells, [&](Index c) {
        const CellMap& m = maps[static_cast<std::size_t>(c)];
        if (!m.valid) return;
        std::size_t at = static_cast<std::size_t>(counts[static_cast<std::size_t>(c)]);
        for (int bz = floorDiv(m.lo[2]); bz <= floorDiv(m.hi[2]); ++bz)
            for (int by = floorDiv(m.lo[1]); by <= floorDiv(m.hi[1]); ++by)
                for (int bx = floorDiv(m.lo[0]); bx <= floorDiv(m.hi[0]); ++bx) pairs[at++] = {key(bx, by, bz), c};
    }, 1024);
    tbb::parallel_sort(pairs.begin(), pairs.end());  // (key, cell) pairs are unique: deterministic
    std::vector<std::size_t> blockStart;
    for (std::size_t i = 0; i < pairs.size(); ++i)
        if (i == 0 || pairs[i].first != pairs[i - 1].first) blockStart.push_back(i);
    const Index blocks = static_cast<Index>(blockStart.size());
    blockStart.push_back(pairs.size());

    stages.bins = since(t);
    t = Clock::now();

    // ---- per-block resampling ------------------------------------------------------------------
    using FloatLeaf = openvdb::FloatTree::LeafNodeType;
    using VecLeaf = openvdb::Vec3STree::LeafNodeType;
    struct BlockOut {
        std::unique_ptr<FloatLeaf> density, contact;
        std::unique_ptr<VecLeaf> vel, rest;
        Index active = 0;
        Real densitySum = 0;
        Index unresolved = 0;
    };
    std::vector<BlockOut> out(static_cast<std::size_t>(blocks));
    const Real hv = 0.5 * vs;
    parallelFor(blocks, [&](Index b) {
        const std::size_t begin = blockStart[static_cast<std::size_t>(b)], end = blockStart[static_cast<std::size_t>(b) + 1];
        const std::uint64_t k = pairs[begin].first;
        const int bx = int(std::int64_t(k & ((1u << 21) - 1)) - kOff);
        const int by = int(std::int64_t((k >> 21) & ((1u << 21) - 1)) - kOff);
        const int bz = int(std::int64_t(k >> 42) - kOff);
        const Eigen::Vector3i base(bx * kLeafDim, by * kLeafDim, bz * kLeafDim);
        std::array<Real, kLeafVoxels> cov{};
        std::array<Vec3, kLeafVoxels> vel, rest;
        std::array<Real, kLeafVoxels> con{};
        for (auto& x : vel) x.setZero();
        for (auto& x : rest) x.setZero();
        Index unresolved = 0;
        for (std::size_t e = begin; e < end; ++e) {
            const CellMap& m = maps[static_cast<std::size_t>(pairs[e].second)];
            Eigen::Vector3i lo = m.lo.cwiseMax(base), hi = m.hi.cwiseMin(base + Eigen::Vector3i::Constant(kLeafDim - 1));
            if ((lo.array() > hi.array()).any()) continue;
            const Vec3 step = m.centreInverse.col(0) * vs;  // ds per +1 in i
            Vec3 invStep = Vec3::Zero();  // used where |step| > 1e-300
            for (int a = 0; a < 3; ++a)
                if (std::abs(step[a]) > 1e-300) invStep[a] = 1 / step[a];
            const Real detMin = 1e-12 * m.h * m.h * m.h;
            // Continuation: the first voxel of a row starts from the first solved voxel of the
            // previous row (or the affine guess), the others from their left neighbour, each
            // moved by J^-1 (p - p_anchor); Newton then needs about one step.
            bool haveRowAnchor = false;
            InverseSolve rowAnchor;
            for (int kz = lo[2]; kz <= hi[2]; ++kz)
                for (int jy = lo[1]; jy <= hi[1]; ++jy) {
                    // affine guess along the row: s(i) = s_lo + (i - lo) step; keep the i with
                    // -margin <= s_a(i) <= 1 + margin for every axis
                    const Vec3 p0 = origin + vs * Vec3(lo[0], jy, kz);
                    const Vec3 s0 = Vec3::Constant(0.5) + m.centreInverse * (p0 - m.centre);
                    Real tmin = 0, tmax = hi[0] - lo[0];
                    for (int a = 0; a < 3; ++a) {
                        const Real l = -m.margin[a] - s0[a], u = 1 + m.margin[a] - s0[a];
                        if (step[a] > 1e-300) {
                            tmin = std::max(tmin, l * invStep[a]);
                            tmax = std::min(tmax, u * invStep[a]);
                        } else if (step[a] < -1e-300) {
                            tmin = std::max(tmin, u * invStep[a]);
                            tmax = std::min(tmax, l * invStep[a]);
                        } else if (l > 0 || u < 0) {
                            tmax = -1;
                        }
                    }
                    if (tmin > tmax) continue;
                    const int i0 = lo[0] + static_cast<int>(std::ceil(tmin)), i1 = lo[0] + static_cast<int>(std::floor(tmax));
                    bool havePrev = false;
                    InverseSolve prev;
                    for (int ix = i0; ix <= i1; ++ix) {
                        const Vec3 p = origin + vs * Vec3(ix, jy, kz);
                        InverseSolve sol;
                        if (havePrev || haveRowAnchor) {
                            // predicted from a solved voxel: skip the voxel when the prediction
                            // lies clearly outside the region where the coverage is > 0,
                            // s_a in (-g_a hv, 1 + g_a hv) (the error of the prediction is below
                            // kNewton |ds|^2; g changes by a factor below 1 + kNewton |ds|)
                            const InverseSolve& an = havePrev ? prev : rowAnchor;
                            const Vec3 ds = an.inv * (p - an.p);
                            sol.s = an.s + ds;
                            const Real err = m.kNewton * ds.squaredNorm() + 1e-3;
                            bool outside = false;
                            for (int a = 0; a < 3; ++a) {
                                const Real r = m.reach[a] + err;
                                outside = outside || sol.s[a] < -r || sol.s[a] > 1 + r;
                            }
                            if (outside) continue;
                        } else {
                            sol.s = s0 + Real(ix - lo[0]) * step;
                        }
                        if (!solveCell(m, p, detMin, sol)) {
                            ++unresolved;
                            havePrev = false;
                            continue;
                        }
                        if (!havePrev) {
                            rowAnchor = sol;
                            haveRowAnchor = true;
                        }
                        prev = sol;
                        havePrev = true;
                        const Vec3& s = sol.s;
                        // coverage: separable box filter with first-order face distances
                        // (|grad s_a| = |row a of J^-1|)
                        // (in s units: t = g hv, overlap min(t, s) + min(t, 1 - s), over 2 t)
                        Real c = 1;
                        for (int a = 0; a < 3 && c > 0; ++a) {
                            const Real t2 = sol.g2[a] * hv * hv, u = std::min(s[a], 1 - s[a]);
                            if (u >= 0 && u * u >= t2) continue;  // a whole voxel's width
                            const Real tg = std::sqrt(t2);
                            const Real ov = std::min(tg, s[a]) + std::min(tg, 1 - s[a]);
                            c = ov <= 0 ? 0 : c * std::min(Real(1), ov / (2 * tg));
                        }
                        if (!(c > 1e-9)) continue;
                        const std::size_t at = static_cast<std::size_t>((ix - base[0]) * kLeafDim * kLeafDim + (jy - base[1]) * kLeafDim + (kz - base[2]));
                        const Vec3 sc = s.cwiseMax(Vec3::Zero()).cwiseMin(Vec3::Ones());  // keeps contact in 0..1
                        cov[at] += c;
                        vel[at] += c * evalVec(m.v, s);  // extrapolated by < 1/2 voxel outside
                        rest[at] += c * (m.restLowest + m.h * s);
                        con[at] += c * evalMonomials(m.k, sc);
                    }
                }
        }
        BlockOut& o = out[static_cast<std::size_t>(b)];
        o.unresolved = unresolved;
        const openvdb::Coord origin3(base[0], base[1], base[2]);
        for (std::size_t at = 0; at < static_cast<std::size_t>(kLeafVoxels); ++at) {
            if (!(cov[at] > 0)) continue;
            if (!o.density) {
                o.density = std::make_unique<FloatLeaf>(origin3, 0.f, false);
                o.contact = std::make_unique<FloatLeaf>(origin3, 0.f, false);
                o.vel = std::make_unique<VecLeaf>(origin3, openvdb::Vec3s(0.f), false);
                o.rest = std::make_unique<VecLeaf>(origin3, openvdb::Vec3s(0.f), false);
            }
            const Real w = 1 / cov[at];
            const Vec3 v = vel[at] * w, r = rest[at] * w;
            const Real d = std::min(Real(1), cov[at]);
            const openvdb::Index off = static_cast<openvdb::Index>(at);
            o.density->setValueOn(off, static_cast<float>(d));
            o.contact->setValueOn(off, static_cast<float>(std::min(Real(1), con[at] * w)));
            o.vel->setValueOn(off, openvdb::Vec3s(float(v.x()), float(v.y()), float(v.z())));
            o.rest->setValueOn(off, openvdb::Vec3s(float(r.x()), float(r.y()), float(r.z())));
            ++o.active;
            o.densitySum += d;
        }
    }, 1);

    stages.voxels = since(t);
    t = Clock::now();
    WorldGrids g;
    g.density = openvdb::FloatGrid::create(0.f);
    g.contact = openvdb::FloatGrid::create(0.f);
    g.vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
    g.rest = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
    for (BlockOut& o : out) {  // in block order
        g.unresolved += o.unresolved;
        if (!o.density) continue;
        g.activeVoxels += o.active;
        g.densitySum += o.densitySum;
        g.density->tree().addLeaf(o.density.release());
        g.contact->tree().addLeaf(o.contact.release());
        g.vel->tree().addLeaf(o.vel.release());
        g.rest->tree().addLeaf(o.rest.release());
    }
    g.density->setTransform(xform);
    g.contact->setTransform(xform);
    g.vel->setTransform(xform);
    g.rest->setTransform(xform);
    stages.trees = since(t);
    return g;
}

template <typename GridT>
void stamp(GridT& grid, const std::string& name, openvdb::GridClass cls, const VdbFrameInfo& info) {
    grid.setName(name);
    grid.setGridClass(cls);
    grid.setCreator("dgv");
    grid.insertMeta("dgv_frame", openvdb::Int32Metadata(info.frame));
    grid.insertMeta("dgv_time", openvdb::DoubleMetadata(info.time));
}

/// io::File::write ignores the state of its std::ofstream (on a full disk it returns normally and
/// leaves a truncated file); this does the same writing (Archive::write, seekable, so the grid
/// offsets for partial reads are recorded) on a stream whose state we check.
/// (Serialising the grids in parallel, each as a one-grid file in memory spliced into one file,
/// was tried: no faster on 2 cores, see docs/vdb.md.)
class CheckedArchive : public openvdb::io::Archive {
public:
    void writeFile(const fs::path& file, const openvdb::GridCPtrVec& grids, const openvdb::MetaMap& meta,
                   VdbStageSeconds& stages) const {
        const auto t = Clock::now();
        std::ofstream os(file, std::ios_base::out | std::ios_base::binary | std::ios_base::trunc);
        if (!os) throw RuntimeError("cannot open " + file.string() + " for writing");
        openvdb::io::Archive::write(os, grids, /*seekable=*/true, meta);
        os.flush();
        const bool ok = os.good();
        const std::streamoff end = ok ? std::streamoff(os.tellp()) : -1;
        os.close();
        if (!ok || os.fail()) throw RuntimeError("the write failed (disk full?)");
        std::error_code ec;
        const std::uintmax_t size = fs::file_size(file, ec);
        if (ec || end < 0 || size != std::uintmax_t(end))
            throw RuntimeError("the written file has " + std::to_string(size) + " bytes, expected " + std::to_string(end));
        stages.file = since(t);
    }
};

/// Re-opens a written file and reads every grid's metadata and the file metadata: catches the
/// truncated files io::File::write leaves on a full disk.
void verifyWritten(const fs::path& file, const std::vector<std::string>& names) {
    try {
        openvdb::io::File v(file.string());
        v.open(false);
        auto meta = v.getMetadata();
        auto grids = v.readAllGridMetadata();
        std::vector<std::string> got;
        for (const auto& g : *grids) got.push_back(g->getName());
        v.close();
        std::vector<std::string> want = names;
        std::sort(got.begin(), got.end());
        std::sort(want.begin(), want.end());
        if (got != want) throw RuntimeError("the written file lists other grids than were written");
        if (!meta || !(*meta)["dgv_frame"]) throw RuntimeError("the written file lost its metadata");
    } catch (const RuntimeError& e) {
        throw RuntimeError(std::string("the written file does not read back (disk full?): ") + e.what());
    } catch (const std::exception& e) {
        throw RuntimeError(std::string("the written file does not read back (disk full?): ") + e.what());
    }
}

}  // namespace

fs::path vdbFramePath(const fs::path& dir, const std::string& scene, int frame) {
    char digits[32];
    std::snprintf(digits, sizeof digits, "%04d", frame);
    return dir / (scene + "." + digits + ".vdb");
}

VdbWriteReport writeVdbFrame(const fs::path& path, const std::vector<VdbObjectFrame>& objects,
                             const VdbFrameInfo& info, const VdbWriteSettings& settings) {
    const auto t0 = Clock::now();
    validate(objects, info, settings);
    openvdb::initialize();  // idempotent and thread-safe

    Real vs = settings.worldVoxelSize;
    if (vs == 0) {
        vs = objects[0].lattice->spacing;
        for (const VdbObjectFrame& f : objects) vs = std::min(vs, f.lattice->spacing);
    }
    // World grid extent check before allocating: the bounds of all positions in voxels.
    Box3 bounds;
    for (const VdbObjectFrame& f : objects)
        for (const Vec3& x : *f.positions) bounds.extend(x);
    const Vec3 origin = objects[0].lattice->originWorld;
    if (!bounds.empty()) {
        const Vec3 ext = bounds.size() / vs;
        if (ext.maxCoeff() > 16384 || (bounds.min - origin).cwiseAbs().maxCoeff() / vs > 1e6 ||
            (bounds.max - origin).cwiseAbs().maxCoeff() / vs > 1e6)
            throw InputError("", "vdb: voxel_size", "the world grid would span more than 16384 voxels (voxel size " + std::to_string(vs) + ")");
    }

    VdbWriteReport report;
    openvdb::math::Transform::Ptr xform = latticeTransform(vs, origin);
    WorldGrids world = resample(objects, vs, origin, xform, report.stages);
    report.activeVoxels = world.activeVoxels;
    report.densityVolume = world.densitySum * vs * vs * vs;
    report.unresolved = world.unresolved;

    openvdb::GridPtrVec grids;
    stamp(*world.density, "density", openvdb::GRID_FOG_VOLUME, info);
    stamp(*world.vel, "vel", openvdb::GRID_UNKNOWN, info);
    world.vel->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
    world.vel->insertMeta("dgv_velocity_unit", openvdb::StringMetadata("world units per second"));
    stamp(*world.rest, "rest", openvdb::GRID_UNKNOWN, info);
    world.rest->setVectorType(openvdb::VEC_INVARIANT);
    stamp(*world.contact, "contact", openvdb::GRID_FOG_VOLUME, info);
    if (settings.halfFloat) {
        world.density->setSaveFloatAsHalf(true);
        world.vel->setSaveFloatAsHalf(true);
        world.contact->setSaveFloatAsHalf(true);
    }
    grids.push_back(world.density);
    grids.push_back(world.vel);
    grids.push_back(world.rest);
    grids.push_back(world.contact);

    // ---- surface ---------------------------------------------------------------------------
    auto ts = Clock::now();
    if (settings.surface) {
        openvdb::FloatGrid::Ptr surface;
        for (const VdbObjectFrame& f : objects) {
            if (!f.surface || f.surface->triangles.empty()) continue;
            std::vector<openvdb::Vec3s> pts;
            pts.reserve(f.surface->vertices.size());
            for (const Vec3& x : f.surface->vertices) {
                if (!allFiniteNoTrap(x)) throw InputError("", "vdb: object " + f.name, "surface vertices must be finite");
                pts.emplace_back(float((x.x() - origin.x()) / vs), float((x.y() - origin.y()) / vs), float((x.z() - origin.z()) / vs));
            }
            std::vector<openvdb::Vec3I> tris;
            tris.reserve(f.surface->triangles.size());
            for (const auto& t : f.surface->triangles) {
                for (int q : t)
                    if (q < 0 || std::size_t(q) >= pts.size()) throw InputError("", "vdb: object " + f.name, "surface triangle index out of range");
                tris.emplace_back(openvdb::Index32(t[0]), openvdb::Index32(t[1]), openvdb::Index32(t[2]));
            }
            // points in index space; the transform is attached afterwards
            openvdb::math::Transform::Ptr unit = openvdb::math::Transform::createLinearTransform(1.0);
            openvdb::FloatGrid::Ptr ls = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*unit, pts, tris, float(settings.surfaceHalfWidth));
            if (!surface) {
                surface = ls;
            } else {
                openvdb::tools::csgUnion(*surface, *ls);
            }
        }
        if (surface) {
            // meshToLevelSet in index space gives distances in voxels: scale to world units
            const float scale = float(vs);
            openvdb::tools::foreach(surface->beginValueAll(), [scale](const openvdb::FloatGrid::ValueAllIter& it) { it.setValue(*it * scale); });
            surface->tree().root().setBackground(float(settings.surfaceHalfWidth * vs), false);
            surface->setTransform(xform);
            stamp(*surface, "surface", openvdb::GRID_LEVEL_SET, info);
            grids.push_back(surface);
        }
    }

    report.stages.surface = since(ts);

    // ---- lattice grids ---------------------------------------------------------------------
    ts = Clock::now();
    for (const VdbObjectFrame& f : objects) {
        const std::string suffix = objects.size() == 1 ? "" : "_" + sanitise(f.name);
        const Lattice& lat = *f.lattice;
        auto lx = latticeTransform(lat.spacing, lat.originWorld);
        openvdb::Vec3SGrid::Ptr pos = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
        {
            auto acc = pos->getAccessor();
            for (Index p = 0; p < lat.size(); ++p) {
                const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
                const Vec3& x = (*f.positions)[static_cast<std::size_t>(p)];
                acc.setValue(openvdb::Coord(u.x(), u.y(), u.z()), openvdb::Vec3s(float(x.x()), float(x.y()), float(x.z())));
            }
        }
        pos->setTransform(lx);
        stamp(*pos, "position" + suffix, openvdb::GRID_UNKNOWN, info);
        pos->setVectorType(openvdb::VEC_CONTRAVARIANT_ABSOLUTE);
        pos->insertMeta("dgv_object", openvdb::StringMetadata(f.name));

        const std::vector<Real> vols = cellVolumes(*f.cells, *f.positions);
        report.objectVolume += std::accumulate(vols.begin(), vols.end(), Real(0));
        openvdb::FloatGrid::Ptr ratio = openvdb::FloatGrid::create(0.f);
        {
            auto acc = ratio->getAccessor();
            for (Index c = 0; c < f.cells->size(); ++c) {
                const Vec3i& u = f.cells->lowest[static_cast<std::size_t>(c)];
                acc.setValue(openvdb::Coord(u.x(), u.y(), u.z()),
                             float(vols[static_cast<std::size_t>(c)] / (*f.restVolumes)[static_cast<std::size_t>(c)]));
            }
        }
        ratio->setTransform(lx->copy());
        stamp(*ratio, "volume_ratio" + suffix, openvdb::GRID_UNKNOWN, info);
        ratio->insertMeta("dgv_object", openvdb::StringMetadata(f.name));
        ratio->insertMeta("dgv_cell_at", openvdb::StringMetadata("lowest corner"));
        grids.push_back(pos);
        grids.push_back(ratio);
    }
    report.stages.lattice = since(ts);
    report.resampleSeconds = since(t0);

    // ---- write, check, rename --------------------------------------------------------------
    openvdb::MetaMap meta;
    meta.insertMeta("creator", openvdb::StringMetadata(std::string("dgv ") + DGV_VERSION_STRING));
    meta.insertMeta("dgv_version", openvdb::StringMetadata(DGV_VERSION_STRING));
    meta.insertMeta("dgv_scene", openvdb::StringMetadata(info.scene));
    meta.insertMeta("dgv_frame", openvdb::Int32Metadata(info.frame));
    meta.insertMeta("dgv_time", openvdb::DoubleMetadata(info.time));
    meta.insertMeta("dgv_fps", openvdb::DoubleMetadata(info.fps));
    meta.insertMeta("dgv_up_axis", openvdb::StringMetadata(info.upAxis));
    meta.insertMeta("dgv_units", openvdb::StringMetadata("m"));
    std::vector<std::string> names;
    for (const auto& g : grids) names.push_back(g->getName());

    const auto t1 = Clock::now();
    writeFileAtomically(path, [&](const fs::path& tmp) {
        CheckedArchive archive;
        archive.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
        openvdb::GridCPtrVec constGrids(grids.begin(), grids.end());
        archive.writeFile(tmp, constGrids, meta, report.stages);
        verifyWritten(tmp, names);
    });
    report.writeSeconds = since(t1);
    report.stages.verify = report.writeSeconds - report.stages.file;
    std::error_code ec;
    report.bytes = fs::file_size(path, ec);
    report.seconds = since(t0);
    return report;
}

}  // namespace dgv
