#pragma once
/// @file voxelise.hpp
/// @brief Voxel parametrisation (seed section 2): the material points of a mesh are the lattice
/// points whose voxel centre is inside it. Inside means generalised winding number w(x) >= 0.5
/// (Jacobson et al. 2013), which is exact (0 or 1) for closed meshes and degrades gracefully on
/// small holes, self-intersections and non-manifold input. See docs/math.md ("Voxelisation") for the
/// algorithm (exact signed ray-crossing counts, the winding number only near holes), the lattice
/// placement and the guarantees.

#include "base/types.hpp"
#include "geom/lattice.hpp"
#include "geom/triangle_mesh.hpp"

#include <string>
#include <vector>

namespace dgv {

/// Bytes per material point of a lattice with its geometric state (estimateLatticeBytes).
constexpr double kLatticeBytesPerPoint = 1024;

/// The memory a command may plan to use: the smallest of 3/4 of physical memory, the soft
/// address-space limit (RLIMIT_AS, `ulimit -v`) and the cgroup's memory limit (v2 memory.max,
/// v1 memory.limit_in_bytes), the last two where they are set.
std::size_t memoryBudgetBytes();

struct VoxeliseSettings {
    Real voxelSize = 0;           ///< h in world units; or 0 to derive it from `resolution`
    int resolution = 0;           ///< lattice points along the longest side of the bounds, padding
                                  ///< excluded (1..2048): h = longest side / resolution; or 0 to
                                  ///< use `voxelSize`
    Real windingThreshold = 0.5;  ///< inside when w >= threshold
    /// Memory the lattice may take with what the command keeps per point; 0 means
    /// memoryBudgetBytes() (the smallest of 3/4 of physical memory and the process's limits).
    std::size_t memoryBudgetBytes = 0;
    /// What is kept per material point: the lattice and its geometric state (1 KiB), or more
    /// for a body that is simulated (io/scene_build: buildObjects).
    double bytesPerPoint = kLatticeBytesPerPoint;

    /// Problems by field name ("voxel_size: must be positive, got -1"); empty when valid.
    std::vector<std::string> validate() const;
};

struct VoxeliseReport {
    Real spacing = 0;  ///< h used
    Vec3i dims = Vec3i::Zero();
    Index points = 0;            ///< material points (voxels inside)
    Real voxelVolume = 0;        ///< points * h^3
    int components = 0;          ///< 6-connected pieces
    Index exactEvaluations = 0;  ///< winding-number queries evaluated (the rest were filled)
    double seconds = 0;
};

/// Spacing the settings give for a mesh with these bounds.
Real latticeSpacing(const Box3& bounds, const VoxeliseSettings& settings);

/// Bytes a lattice over `gridCells` cells with `points` material points needs, geometric state
/// included, or `bytesPerPoint` a point (what voxelise() checks against the memory budget
/// before allocating).
std::size_t estimateLatticeBytes(Index gridCells, Index points, double bytesPerPoint = kLatticeBytesPerPoint);

/// Voxelises `mesh`. Throws InputError (input empty, where "voxel_size"/"resolution") when the
/// settings are invalid or the lattice would not fit the memory budget (message gives the
/// estimate), before allocating anything large; InputError (where empty) for a mesh with no
/// triangles, an out-of-range index or a non-finite vertex.
///
/// Placement: along each axis n = ceil(extent / h) voxels (at least 1) are centred on the mesh
/// bounds, and one empty point of padding is added on each side, so dims = n + 2 and
/// originWorld = bounds.centre() - h (dims - 1) / 2; point u sits at originWorld + h u.
/// The result is identical for any thread count.
Lattice voxelise(const TriangleMesh& mesh, const VoxeliseSettings& settings, VoxeliseReport* report = nullptr);

/// How windingNumbers() evaluates the sum of solid angles.
enum class WindingEvaluation {
    Accelerated,  ///< tree with a dipole far field (Barill et al. 2018): exact near the surface,
                  ///< ~1e-4 absolute error far from it; O(log T) per query
    Exact,        ///< direct sum over all triangles: rounding error only; O(T) per query
};

/// Generalised winding number of the mesh at each query point: the sum of the triangles' signed
/// solid angles / 4pi (1 inside and 0 outside a closed outward mesh, fractional near holes).
/// For tests and diagnostics; deterministic for any thread count.
std::vector<Real> windingNumbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries,
                                 WindingEvaluation evaluation = WindingEvaluation::Accelerated);

}  // namespace dgv
