#include "geom/voxelise.hpp"

#include "base/errors.hpp"
#include "base/parallel.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <utility>

// The algorithm and its guarantees: docs/math.md ("Voxelisation").

namespace dgv {

namespace {

constexpr Real kPi = 3.14159265358979323846;
constexpr int kMaxResolution = 2048;
/// Largest grid extent along one axis: keeps the fixed-point edge functions inside int64.
constexpr Index kMaxAxisPoints = 16384;
/// Fixed-point steps per lattice step for the exact 2-D predicates (2^14).
constexpr std::int64_t kFixedScale = 1 << 14;
/// Boundary components beyond which the ray counts are not trusted anywhere (section 4 of
/// docs/math.md ("Voxelisation")) and every grid point gets the winding number.
constexpr std::size_t kMaxHoles = 16;
/// Far-field opening criterion of the winding-number tree: a node is summarised by its dipole
/// when its distance exceeds kBeta times its radius.
constexpr Real kBetaVoxelise = 3.0;
constexpr Real kBetaAccurate = 12.0;

struct FieldProblem {
    std::string field, message;
};

std::string numberText(Real v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

std::vector<FieldProblem> settingProblems(const VoxeliseSettings& s) {
    std::vector<FieldProblem> out;
    if (!std::isfinite(s.voxelSize) || s.voxelSize < 0)
        out.push_back({"voxel_size",
                       "must be a positive finite number (or 0 to use resolution), got " + numberText(s.voxelSize)});
    if (s.resolution < 0 || s.resolution > kMaxResolution)
        out.push_back({"resolution", "must be between 1 and " + std::to_string(kMaxResolution) +
                                         " (or 0 to use voxel_size), got " + std::to_string(s.resolution)});
    if (out.empty()) {
        const bool hasSize = s.voxelSize > 0, hasResolution = s.resolution > 0;
        if (hasSize && hasResolution) out.push_back({"voxel_size", "give either voxel_size or resolution, not both"});
        if (!hasSize && !hasResolution) out.push_back({"voxel_size", "give voxel_size or resolution (both are 0)"});
    }
    if (!(std::isfinite(s.windingThreshold) && s.windingThreshold > 0 && s.windingThreshold <= 1))
        out.push_back({"winding_threshold", "must be in (0, 1], got " + numberText(s.windingThreshold)});
    return out;
}

std::string bytesText(double bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    int u = 0;
    while (bytes >= 1024 && u < 6) {
        bytes /= 1024;
        ++u;
    }
    std::ostringstream os;
    os << std::setprecision(bytes < 10 ? 2 : 3) << bytes << " " << units[u];
    return os.str();
}

/// A cgroup limit file's value in bytes, or 0 where it is absent or "max" (no limit).
std::size_t cgroupLimit(const char* path) {
    std::ifstream in(path);
    std::string text;
    if (!(in >> text) || text == "max") return 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
    // cgroup v1 writes "no limit" as a huge page-rounded number
    if (end == text.c_str() || *end != '\0' || v == 0 || v >= (1ull << 62)) return 0;
    return static_cast<std::size_t>(v);
}

}  // namespace

std::size_t memoryBudgetBytes() {
    const long pages = sysconf(_SC_PHYS_PAGES), pageSize = sysconf(_SC_PAGE_SIZE);
    std::size_t budget = pages > 0 && pageSize > 0
                             ? static_cast<std::size_t>(pages) / 4 * 3 * static_cast<std::size_t>(pageSize)
                             : std::size_t(8) << 30;
    // Less what the program takes besides its lattices. Measured with `dgv simulate` on 2 cores:
    // about 90 MB resident (libraries, allocator, the first frame's work), and 250-330 MB of address
    // space beyond its resident set (thread stacks and allocator arenas), which RLIMIT_AS counts.
    constexpr std::size_t kResidentBase = std::size_t(128) << 20, kAddressBase = std::size_t(320) << 20;
    auto less = [](std::size_t limit, std::size_t base) { return limit > 2 * base ? limit - base : limit / 2; };
    rlimit as{};
    if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY)
        budget = std::min(budget, less(static_cast<std::size_t>(as.rlim_cur), kAddressBase));
    for (const char* file : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"})
        if (const std::size_t limit = cgroupLimit(file); limit > 0)
            budget = std::min(budget, less(limit, kResidentBase));
    return budget;
}

namespace {

// ---------------------------------------------------------------------------------------------
// Solid angles and the winding-number tree (Barill et al. 2018, first-order far field).

/// Signed solid angle of triangle (a, b, c) seen from p (Van Oosterom & Strackee 1983);
/// positive when p sees the triangle counter-clockwise (p on the inner side of an outward face).
inline Real solidAngle(const Vec3& p, const Vec3& a0, const Vec3& b0, const Vec3& c0) {
    const Vec3 a = a0 - p, b = b0 - p, c = c0 - p;
    const Real la = a.norm(), lb = b.norm(), lc = c.norm();
    const Real num = a.dot(b.cross(c));
    const Real den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    return 2 * std::atan2(num, den);
}

class WindingTree {
public:
    explicit WindingTree(const TriangleMesh& mesh) : mMesh(mesh) {
        const std::size_t n = mesh.triangles.size();
        mOrder.resize(n);
        std::iota(mOrder.begin(), mOrder.end(), 0);
        mCentroid.resize(n);
        for (std::size_t t = 0; t < n; ++t) mCentroid[t] = (v(t, 0) + v(t, 1) + v(t, 2)) / 3;
        if (n > 0) {
            mNodes.reserve(2 * n / kLeafSize + 2);
            build(0, static_cast<int>(n));
        }
    }

    /// 4 pi times the winding number at p.
    Real solidAngleSum(const Vec3& p, Real beta) const {
        if (mNodes.empty()) return 0;
        Real sum = 0;
        std::array<int, 128> stack;
        int top = 0;
        stack[static_cast<std::size_t>(top++)] = 0;
        const Real beta2 = beta * beta;
        constexpr Real kTiny = 1e-200;  // keeps dist^3 away from underflow (degenerate nodes)
        while (top > 0) {
            const Node& node = mNodes[static_cast<std::size_t>(stack[static_cast<std::size_t>(--top)])];
            const Vec3 d = node.centre - p;
            const Real dist2 = d.squaredNorm();
            if (dist2 > beta2 * node.radius * node.radius && dist2 > kTiny) {
                sum += node.dipole.dot(d) / (dist2 * std::sqrt(dist2));
            } else if (node.left < 0) {
                for (int i = node.first; i < node.first + node.count; ++i) {
                    const std::size_t t = static_cast<std::size_t>(mOrder[static_cast<std::size_t>(i)]);
                    sum += solidAngle(p, v(t, 0), v(t, 1), v(t, 2));
                }
            } else {
                stack[static_cast<std::size_t>(top++)] = node.right;
                stack[static_cast<std::size_t>(top++)] = node.left;
            }
        }
        return sum;
    }

private:
    static constexpr int kLeafSize = 8;
    struct Node {
        Vec3 centre;  ///< area-weighted centroid
        Vec3 dipole;  ///< sum of area vectors
        Real radius;  ///< bounds every vertex: |x - centre| <= radius
        int left = -1, right = -1;
        int first = 0, count = 0;
    };

    const Vec3& v(std::size_t t, int k) const {
        return mMesh.vertices[static_cast<std::size_t>(mMesh.triangles[t][static_cast<std::size_t>(k)])];
    }

    int build(int first, int last) {
        const int id = static_cast<int>(mNodes.size());
        mNodes.emplace_back();
        Vec3 areaSum = Vec3::Zero(), weighted = Vec3::Zero(), plain = Vec3::Zero();
        Real area = 0;
        Box3 cbox;
        for (int i = first; i < last; ++i) {
            const std::size_t t = static_cast<std::size_t>(mOrder[static_cast<std::size_t>(i)]);
            const Vec3 n = 0.5 * (v(t, 1) - v(t, 0)).cross(v(t, 2) - v(t, 0));
            const Real a = n.norm();
            areaSum += n;
            weighted += a * mCentroid[t];
            plain += mCentroid[t];
            area += a;
            cbox.extend(mCentroid[t]);
        }
        const Vec3 centre = area > 0 ? Vec3(weighted / area) : Vec3(plain / (last - first));
        Real radius = 0;
        for (int i = first; i < last; ++i) {
            const std::size_t t = static_cast<std::size_t>(mOrder[static_cast<std::size_t>(i)]);
            for (int k = 0; k < 3; ++k) radius = std::max(radius, (v(t, k) - centre).norm());
        }
        Node node;
        node.centre = centre;
        node.dipole = areaSum;
        node.radius = radius;
        node.first = first;
        node.count = last - first;
        if (last - first > kLeafSize) {
            int axis = 0;
            cbox.size().maxCoeff(&axis);
            const int mid = first + (last - first) / 2;
            std::nth_element(mOrder.begin() + first, mOrder.begin() + mid, mOrder.begin() + last, [&](int a, int b) {
                const Real ca = mCentroid[static_cast<std::size_t>(a)][axis];
                const Real cb = mCentroid[static_cast<std::size_t>(b)][axis];
                return ca < cb || (ca == cb && a < b);
            });
            node.left = build(first, mid);
            node.right = build(mid, last);
        }
        mNodes[static_cast<std::size_t>(id)] = node;
        return id;
    }

    const TriangleMesh& mMesh;
    std::vector<int> mOrder;
    std::vector<Vec3> mCentroid;
    std::vector<Node> mNodes;
};

// ---------------------------------------------------------------------------------------------
// Topology: vertices welded by position, and the edges whose uses do not cancel.

struct Topology {
    std::vector<int> weld;  ///< #V: id of the first vertex at the same position
    /// Unbalanced edges (welded ids): a -> b used `net` more times than b -> a.
    std::vector<std::array<int, 3>> openEdges;
};

Topology analyseTopology(const TriangleMesh& mesh) {
    Topology topo;
    topo.weld = samePositionRepresentatives(mesh.vertices);
    std::vector<std::array<int, 3>> uses;  // (lo, hi, +1 for lo->hi / -1 for hi->lo)
    uses.reserve(mesh.triangles.size() * 3);
    for (const auto& t : mesh.triangles) {
        for (int k = 0; k < 3; ++k) {
            const int a = topo.weld[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])];
            const int b = topo.weld[static_cast<std::size_t>(t[static_cast<std::size_t>((k + 1) % 3)])];
            if (a == b) continue;
            uses.push_back(a < b ? std::array<int, 3>{a, b, 1} : std::array<int, 3>{b, a, -1});
        }
    }
    std::sort(uses.begin(), uses.end());
    for (std::size_t i = 0; i < uses.size();) {
        std::size_t j = i;
        int net = 0;
        while (j < uses.size() && uses[j][0] == uses[i][0] && uses[j][1] == uses[i][1]) net += uses[j++][2];
        if (net > 0) topo.openEdges.push_back({uses[i][0], uses[i][1], net});
        if (net < 0) topo.openEdges.push_back({uses[i][1], uses[i][0], -net});
        i = j;
    }
    return topo;
}

/// Bounding boxes (world) of the connected pieces of the open edges: the mesh's holes.
std::vector<Box3> holeBoxes(const TriangleMesh& mesh, const Topology& topo) {
    std::vector<int> parent(mesh.vertices.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
        while (parent[static_cast<std::size_t>(x)] != x) {
            parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
            x = parent[static_cast<std::size_t>(x)];
        }
        return x;
    };
    for (const auto& e : topo.openEdges) {
        int a = find(e[0]), b = find(e[1]);
        if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
    }
    std::vector<int> boxOfRoot(mesh.vertices.size(), -1);
    std::vector<Box3> boxes;
    for (const auto& e : topo.openEdges) {
        const int r = find(e[0]);
        int& b = boxOfRoot[static_cast<std::size_t>(r)];
        if (b < 0) {
            b = static_cast<int>(boxes.size());
            boxes.emplace_back();
        }
        boxes[static_cast<std::size_t>(b)].extend(mesh.vertices[static_cast<std::size_t>(e[0])]);
        boxes[static_cast<std::size_t>(b)].extend(mesh.vertices[static_cast<std::size_t>(e[1])]);
    }
    return boxes;
}

// ---------------------------------------------------------------------------------------------
// Exact signed crossing counts along +k rays through every grid column (i, j).

/// Twice the signed area of (a, b, p), exact: all inputs are fixed-point integers < 2^28.
inline std::int64_t orient(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by, std::int64_t px,
                           std::int64_t py) {
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

/// Which side of the directed edge a -> b the column sample p lies on (+1 left, -1 right), with
/// ties broken by simulation of simplicity: p is perturbed by (eps, eps^2), and the edge is
/// evaluated in its canonical direction (lexicographically smaller end first) so that the two
/// triangles sharing an edge always see the same side.
inline int edgeSide(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by, std::int64_t px,
                    std::int64_t py) {
    int flip = 1;
    if (bx < ax || (bx == ax && by < ay)) {
        std::swap(ax, bx);
        std::swap(ay, by);
        flip = -1;
    }
    const std::int64_t e = orient(ax, ay, bx, by, px, py);
    int s;
    if (e != 0)
        s = e > 0 ? 1 : -1;
    else if (by != ay)
        s = by > ay ? -1 : 1;  // e(p + (eps, eps^2)) = dx eps^2 - dy eps
    else
        s = bx > ax ? 1 : -1;  // dy == 0 and, canonically, dx > 0
    return flip * s;
}

struct RayCounts {
    /// Per cell: the signed crossing count from the cell's point up to +infinity along k.
    std::vector<std::int32_t> up;
    /// Per column (i + nx j): the signed count along the whole line (0 for a closed mesh).
    std::vector<std::int32_t> total;
};

RayCounts countCrossings(const TriangleMesh& mesh, const Vec3& origin, Real h, const Vec3i& dims) {
    const Index nx = dims.x(), ny = dims.y(), nz = dims.z();
    const Index cells = nx * ny * nz;
    const std::size_t nv = mesh.vertices.size();
    // Lattice coordinates; (i, j) in fixed point so the 2-D predicates are exact.
    std::vector<std::int64_t> qx(nv), qy(nv);
    std::vector<Real> qz(nv);
    for (std::size_t v = 0; v < nv; ++v) {
        const Vec3 q = (mesh.vertices[v] - origin) / h;
        qx[v] = std::llround(q.x() * Real(kFixedScale));
        qy[v] = std::llround(q.y() * Real(kFixedScale));
        qz[v] = q.z();
    }

    std::vector<std::atomic<std::int32_t>> diff(static_cast<std::size_t>(cells));
    std::vector<std::atomic<std::int32_t>> total(static_cast<std::size_t>(nx * ny));
    const Index nt = static_cast<Index>(mesh.triangles.size());
    parallelForBlocks(
        nt,
        [&](Index begin, Index end) {
            for (Index t = begin; t < end; ++t) {
                const auto& tri = mesh.triangles[static_cast<std::size_t>(t)];
                const std::size_t v0 = static_cast<std::size_t>(tri[0]), v1 = static_cast<std::size_t>(tri[1]),
                                  v2 = static_cast<std::size_t>(tri[2]);
                const std::int64_t area = orient(qx[v0], qy[v0], qx[v1], qy[v1], qx[v2], qy[v2]);
                if (area == 0) continue;  // parallel to the rays: crossed by no perturbed ray
                const std::int64_t xlo = std::min({qx[v0], qx[v1], qx[v2]});
                const std::int64_t xhi = std::max({qx[v0], qx[v1], qx[v2]});
                const std::int64_t ylo = std::min({qy[v0], qy[v1], qy[v2]});
                const std::int64_t yhi = std::max({qy[v0], qy[v1], qy[v2]});
                // Columns whose sample may lie in the triangle (ceil/floor of the fixed-point box).
                const Index i0 = std::max<Index>(0, (xlo + kFixedScale - 1) / kFixedScale);
                const Index i1 = std::min<Index>(nx - 1, xhi / kFixedScale);
                const Index j0 = std::max<Index>(0, (ylo + kFixedScale - 1) / kFixedScale);
                const Index j1 = std::min<Index>(ny - 1, yhi / kFixedScale);
                for (Index j = j0; j <= j1; ++j) {
                    const std::int64_t py = j * kFixedScale;
                    for (Index i = i0; i <= i1; ++i) {
                        const std::int64_t px = i * kFixedScale;
                        const int s0 = edgeSide(qx[v0], qy[v0], qx[v1], qy[v1], px, py);
                        const int s1 = edgeSide(qx[v1], qy[v1], qx[v2], qy[v2], px, py);
                        if (s1 != s0) continue;
                        const int s2 = edgeSide(qx[v2], qy[v2], qx[v0], qy[v0], px, py);
                        if (s2 != s0) continue;
                        // Crossing height by barycentric interpolation of k.
                        const Real w0 = Real(orient(qx[v1], qy[v1], qx[v2], qy[v2], px, py));
                        const Real w1 = Real(orient(qx[v2], qy[v2], qx[v0], qy[v0], px, py));
                        const Real w2 = Real(area) - w0 - w1;
                        const Real z = (w0 * qz[v0] + w1 * qz[v1] + w2 * qz[v2]) / Real(area);
                        // The crossing counts for the points k < z of this column.
                        const Real top = std::ceil(z) - 1;
                        const Index col = i + nx * j;
                        total[static_cast<std::size_t>(col)].fetch_add(s0, std::memory_order_relaxed);
                        if (top < 0) continue;
                        const Index k = top >= Real(nz - 1) ? nz - 1 : static_cast<Index>(top);
                        diff[static_cast<std::size_t>(col + nx * ny * k)].fetch_add(s0, std::memory_order_relaxed);
                    }
                }
            }
        },
        256);

    RayCounts rc;
    rc.up.assign(static_cast<std::size_t>(cells), 0);
    rc.total.resize(static_cast<std::size_t>(nx * ny));
    parallelFor(nx * ny, [&](Index col) {
        rc.total[static_cast<std::size_t>(col)] = total[static_cast<std::size_t>(col)].load();
        std::int32_t run = 0;
        for (Index k = nz - 1; k >= 0; --k) {
            const std::size_t c = static_cast<std::size_t>(col + nx * ny * k);
            run += diff[c].load(std::memory_order_relaxed);
            rc.up[c] = run;
        }
    });
    return rc;
}

struct Placement {
    Vec3 origin;
    Real h;
    Vec3i dims;
};

}  // namespace

std::vector<std::string> VoxeliseSettings::validate() const {
    std::vector<std::string> out;
    for (const FieldProblem& p : settingProblems(*this)) out.push_back(p.field + ": " + p.message);
    return out;
}

Real latticeSpacing(const Box3& bounds, const VoxeliseSettings& settings) {
    const auto problems = settingProblems(settings);
    if (!problems.empty()) throw InputError("", problems.front().field, problems.front().message);
    if (settings.voxelSize > 0) return settings.voxelSize;
    const Real longest = bounds.empty() ? 0 : bounds.size().maxCoeff();
    if (!(longest > 0))
        throw InputError("", "resolution", "the mesh has no extent, so resolution cannot set the voxel size");
    return longest / settings.resolution;
}

std::size_t estimateLatticeBytes(Index gridCells, Index points, double bytesPerPoint) {
    // Per point: coords 12, neighbours 48, component 4, position 24, 3 tangents 72, metric 72,
    // inverse metric 72, 3 duals 72, 6 second derivatives 144, Christoffel 3 Mat3 216, its last
    // change 216, previous tangents 72: 1024 bytes. Per cell: pointOfCell 8.
    constexpr double kPerCell = 8;
    const double bytes =
        bytesPerPoint * double(std::max<Index>(points, 0)) + kPerCell * double(std::max<Index>(gridCells, 0));
    if (bytes >= double(std::numeric_limits<std::size_t>::max())) return std::numeric_limits<std::size_t>::max();
    return static_cast<std::size_t>(bytes);
}

namespace {

/// A mesh voxelise can read: triangles whose vertices exist, every coordinate finite.
void checkMeshToVoxelise(const TriangleMesh& mesh) {
    if (mesh.triangles.empty()) throw InputError("", "", "the mesh has no triangles to voxelise");
    for (const auto& t : mesh.triangles)
        for (int v : t)
            if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size())
                throw InputError("", "",
                                 "a triangle refers to vertex " + std::to_string(v) + ", out of range (" +
                                     std::to_string(mesh.vertices.size()) + " vertices)");
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
        if (!allFiniteNoTrap(mesh.vertices[v]))
            throw InputError("", "", "vertex " + std::to_string(v) + " has a non-finite coordinate");

}

/// Step 2 of voxelise: each point inside by its exact signed crossing count, except where the
/// counts are not the winding number's verdict (near or behind a hole): those points are flagged
/// for an explicit winding-number evaluation and returned. Padding stays empty.
std::vector<Index> classifyByCounts(const TriangleMesh& mesh, const Topology& topo, const RayCounts& rc,
                                    const Vec3& origin, Real h, const Vec3i& dims, Real threshold,
                                    std::vector<unsigned char>& mask) {
    const Index nx = dims.x(), ny = dims.y(), nz = dims.z();
    std::vector<Index> flagged;
    const bool closedCycle = topo.openEdges.empty();
    const std::vector<Box3> holes = closedCycle ? std::vector<Box3>{} : holeBoxes(mesh, topo);
    const bool trustNothing = holes.size() > kMaxHoles;
    struct IndexBox {
        Real lo[3], hi[3];
    };
    std::vector<IndexBox> hole(holes.size());
    for (std::size_t b = 0; b < holes.size(); ++b) {
        const Real margin = 2 * holes[b].size().norm() + 2 * h;
        for (int a = 0; a < 3; ++a) {
            hole[b].lo[a] = (holes[b].min[a] - margin - origin[a]) / h;
            hole[b].hi[a] = (holes[b].max[a] + margin - origin[a]) / h;
        }
    }
    std::vector<std::vector<Index>> flaggedPerColumnBlock;
    const Index columns = nx * ny;
    const Index columnBlock = 256;
    const Index blocks = (columns + columnBlock - 1) / columnBlock;
    flaggedPerColumnBlock.resize(static_cast<std::size_t>(blocks));
    parallelFor(
        blocks,
        [&](Index b) {
            std::vector<Index>& mine = flaggedPerColumnBlock[static_cast<std::size_t>(b)];
            std::vector<const IndexBox*> covering;
            for (Index col = b * columnBlock; col < std::min(columns, (b + 1) * columnBlock); ++col) {
                const Index i = col % nx, j = col / nx;
                const bool border = i == 0 || j == 0 || i == nx - 1 || j == ny - 1;
                covering.clear();
                for (const IndexBox& hb : hole)
                    if (hb.lo[0] <= Real(i) && Real(i) <= hb.hi[0] && hb.lo[1] <= Real(j) && Real(j) <= hb.hi[1])
                        covering.push_back(&hb);
                const std::int32_t totalCount = rc.total[static_cast<std::size_t>(col)];
                for (Index k = 0; k < nz; ++k) {
                    const Index c = col + columns * k;
                    if (border || k == 0 || k == nz - 1) continue;  // padding stays empty
                    const std::int32_t up = rc.up[static_cast<std::size_t>(c)];
                    std::int32_t count = up;
                    bool exact = trustNothing;
                    if (!exact && !covering.empty()) {
                        bool upBlocked = false, downBlocked = false;
                        for (const IndexBox* hb : covering) {
                            const bool below = Real(k)<hb->lo[2], above = Real(k)> hb->hi[2];
                            if (!below && !above) exact = true;  // near a hole
                            if (!above) upBlocked = true;        // the +k ray meets the hole
                            if (!below) downBlocked = true;      // the -k ray meets the hole
                        }
                        if (!exact && upBlocked && downBlocked) exact = true;
                        if (!exact && upBlocked) count = up - totalCount;  // the -k ray's count
                    }
                    if (exact)
                        mine.push_back(c);
                    else
                        mask[static_cast<std::size_t>(c)] = Real(count) >= threshold;
                }
            }
        },
        1);
    for (auto& v : flaggedPerColumnBlock) flagged.insert(flagged.end(), v.begin(), v.end());
    flaggedPerColumnBlock.clear();

    return flagged;
}

/// Step 3 of voxelise: the generalised winding number at the flagged points.
void windingAtFlagged(const TriangleMesh& mesh, const std::vector<Index>& flagged, const Vec3& origin, Real h,
                      const Vec3i& dims, Real threshold, std::vector<unsigned char>& mask) {
    if (flagged.empty()) return;
    const Index nx = dims.x(), ny = dims.y();
    const Index columns = nx * ny;
    const WindingTree tree(mesh);
    parallelFor(
        static_cast<Index>(flagged.size()),
        [&](Index f) {
            const Index c = flagged[static_cast<std::size_t>(f)];
            const Vec3 u(Real(c % nx), Real((c / nx) % ny), Real(c / columns));
            const Real w = tree.solidAngleSum(origin + h * u, kBetaVoxelise) / (4 * kPi);
            mask[static_cast<std::size_t>(c)] = w >= threshold;
        },
        64);
}

}  // namespace

Lattice voxelise(const TriangleMesh& mesh, const VoxeliseSettings& settings, VoxeliseReport* report) {
    const auto start = std::chrono::steady_clock::now();
    const auto problems = settingProblems(settings);
    if (!problems.empty()) throw InputError("", problems.front().field, problems.front().message);
    const std::string where = settings.voxelSize > 0 ? "voxel_size" : "resolution";

    checkMeshToVoxelise(mesh);

    // Placement: n voxels of size h centred on the bounds along each axis (n h >= extent), plus
    // one empty cell of padding on every side. Point u sits at origin + h u.
    const Box3 bounds = meshBounds(mesh);
    const Real h = latticeSpacing(bounds, settings);
    const Vec3 extent = bounds.size();
    Vec3i dims;
    for (int a = 0; a < 3; ++a) {
        const double n = std::max(1.0, std::ceil(extent[a] / h * (1 - 1e-12))) + 2;
        if (!(n <= double(kMaxAxisPoints))) {
            std::ostringstream os;
            os << "the lattice would have " << std::setprecision(3) << n << " points along "
               << "xyz"[a] << ", more than " << kMaxAxisPoints << "; use a larger voxel_size";
            throw InputError("", where, os.str());
        }
        dims[a] = static_cast<int>(n);
    }
    const Vec3 origin = bounds.centre() - 0.5 * (dims.cast<Real>() - Vec3::Ones()) * h;
    const Index nx = dims.x(), ny = dims.y(), nz = dims.z();
    const Index cells = nx * ny * nz;

    // Memory, before anything proportional to the grid is allocated: the lattice with its
    // geometric state, plus this function's own 5 bytes per cell (counts and mask).
    const std::size_t budget = settings.memoryBudgetBytes > 0 ? settings.memoryBudgetBytes : memoryBudgetBytes();
    const Topology topo = analyseTopology(mesh);
    const Index interior = Index(dims.x() - 2) * Index(dims.y() - 2) * Index(dims.z() - 2);
    Index pointGuess = interior;
    if (topo.openEdges.empty())
        pointGuess = std::min<Index>(interior, static_cast<Index>(std::abs(meshSignedVolume(mesh)) / (h * h * h)));
    auto refuse = [&](std::size_t need) {
        std::ostringstream os;
        // What it needs grows as the cube of the resolution (1/h³): a value that fits, with 2 % to spare.
        const double f = std::cbrt(double(budget) / double(need));
        os << "a lattice of " << dims.x() << "x" << dims.y() << "x" << dims.z() << " would need ~"
           << bytesText(double(need)) << ", more than the " << bytesText(double(budget)) << " budget; ";
        if (settings.voxelSize > 0)
            os << "voxel_size " << std::setprecision(3) << h / (0.98 * f) << " would fit";
        else
            os << "resolution " << std::max(1, static_cast<int>(std::floor(0.98 * f * settings.resolution)))
               << " would fit";
        throw InputError("", where, os.str());
    };
    {
        const double own = topo.openEdges.empty() ? 5.0 : 13.0;  // + flagged-point list
        const double need =
            double(estimateLatticeBytes(cells, pointGuess, settings.bytesPerPoint)) + own * double(cells);
        if (need > double(budget)) refuse(static_cast<std::size_t>(std::min(need, 1e19)));
    }

    // 1. Exact signed crossing counts along +k.
    RayCounts rc = countCrossings(mesh, origin, h, dims);

    // 2. Where the counts are not the winding number's verdict (near or behind a hole), the point
    //    is flagged for an explicit winding-number evaluation.
    std::vector<unsigned char> mask(static_cast<std::size_t>(cells), 0);
    const std::vector<Index> flagged =
        classifyByCounts(mesh, topo, rc, origin, h, dims, settings.windingThreshold, mask);
    rc = RayCounts{};

    // 3. The generalised winding number where the counts were not trusted.
    windingAtFlagged(mesh, flagged, origin, h, dims, settings.windingThreshold, mask);

    const Index points = std::count_if(mask.begin(), mask.end(), [](unsigned char m) { return m != 0; });
    {
        const double need = double(estimateLatticeBytes(cells, points, settings.bytesPerPoint)) + 1.0 * double(cells);
        if (need > double(budget)) refuse(static_cast<std::size_t>(need));
    }
    Lattice lat = buildLattice(origin, h, dims, mask);

    if (report) {
        report->spacing = h;
        report->dims = dims;
        report->points = lat.size();
        report->voxelVolume = Real(lat.size()) * h * h * h;
        report->components = lat.components;
        report->exactEvaluations = static_cast<Index>(flagged.size());
        report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return lat;
}

std::vector<Real> windingNumbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries,
                                 WindingEvaluation evaluation) {
    std::vector<Real> w(queries.size(), 0);
    if (evaluation == WindingEvaluation::Exact) {
        parallelFor(
            static_cast<Index>(queries.size()),
            [&](Index q) {
                const Vec3& p = queries[static_cast<std::size_t>(q)];
                Real sum = 0;
                for (const auto& t : mesh.triangles)
                    sum += solidAngle(p, mesh.vertices[static_cast<std::size_t>(t[0])],
                                      mesh.vertices[static_cast<std::size_t>(t[1])],
                                      mesh.vertices[static_cast<std::size_t>(t[2])]);
                w[static_cast<std::size_t>(q)] = sum / (4 * kPi);
            },
            16);
        return w;
    }
    const WindingTree tree(mesh);
    parallelFor(
        static_cast<Index>(queries.size()),
        [&](Index q) {
            w[static_cast<std::size_t>(q)] =
                tree.solidAngleSum(queries[static_cast<std::size_t>(q)], kBetaAccurate) / (4 * kPi);
        },
        64);
    return w;
}

}  // namespace dgv
