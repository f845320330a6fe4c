#pragma once
/// @file lattice.hpp
/// @brief The material lattice (seed section 2): the integer points u = (i,j,k) of a regular
/// grid whose voxel centre lies inside the object, with their 6-neighbour network.
///
/// Rest position of lattice point u: x(u) = originWorld + spacing * u (world units).
/// Index space: 0 <= u < dims. Linear grid index: i + dims.x * (j + dims.y * k) (i fastest).
/// Material points are numbered 0..size()-1 in increasing linear grid index.

#include "base/types.hpp"

#include <array>
#include <vector>

namespace dgv {

/// Neighbour slots, in this order: -i, +i, -j, +j, -k, +k.
enum NeighbourSlot : int { kMinusI = 0, kPlusI, kMinusJ, kPlusJ, kMinusK, kPlusK };
inline constexpr Index kNoPoint = -1;

struct Lattice {
    Vec3 originWorld = Vec3::Zero();  ///< world position of u = (0,0,0)
    Real spacing = 1;                 ///< h, world units per lattice step
    Vec3i dims = Vec3i::Zero();       ///< grid size in points along i, j, k

    std::vector<Vec3i> coords;                     ///< #P material coordinates u
    std::vector<Index> pointOfCell;                ///< dims.prod() entries: point id or kNoPoint
    std::vector<std::array<Index, 6>> neighbours;  ///< #P, by NeighbourSlot; kNoPoint if absent
    std::vector<int> component;                    ///< #P connected-component id, 0..components-1
    int components = 0;                            ///< number of 6-connected components

    Index size() const { return static_cast<Index>(coords.size()); }
    Index linearIndex(const Vec3i& u) const { return u.x() + Index(dims.x()) * (u.y() + Index(dims.y()) * u.z()); }
    bool inGrid(const Vec3i& u) const { return (u.array() >= 0).all() && (u.array() < dims.array()).all(); }
    /// Point id at u, or kNoPoint if u is outside the grid or not a material point.
    Index pointAt(const Vec3i& u) const {
        return inGrid(u) ? pointOfCell[static_cast<std::size_t>(linearIndex(u))] : kNoPoint;
    }
    Vec3 restPosition(Index p) const {
        return originWorld + spacing * coords[static_cast<std::size_t>(p)].cast<Real>();
    }
};

/// Builds the lattice from an occupancy mask over the grid (mask[linearIndex(u)] != 0 means u is
/// a material point): numbers the points, links neighbours and labels 6-connected components.
Lattice buildLattice(const Vec3& originWorld, Real spacing, const Vec3i& dims, const std::vector<unsigned char>& mask);

/// Rest positions of all points, in point order.
std::vector<Vec3> restPositions(const Lattice& lat);

/// True when point p lacks at least one of its six neighbours: it lies on the object's surface.
bool isBoundaryPoint(const Lattice& lat, Index p);

/// The boundary points (isBoundaryPoint), in increasing point order.
std::vector<Index> boundaryPoints(const Lattice& lat);

/// How many complete cells point p is a corner of (0..8).
int completeCellsAt(const Lattice& lat, Index p);

/// The lattice without its loose points: points that are a corner of no complete cell. Such a
/// point (a voxel ball's pole tips, a one-voxel fin on a thick body, a fragment of a leg the
/// lattice resolves only in pieces) carries no mass and no cell volume, and its frame is a
/// one-sided or extrapolated guess; in the dynamics it was free to collapse (docs/math.md,
/// "Loose points leave the material lattice"). Only a lattice with no complete cell anywhere (a
/// one-voxel-thin sheet or rod alone) is kept whole. Same grid, origin and spacing; the kept
/// points keep their order.
/// @param removed  optional out: how many points were dropped
Lattice withoutLoosePoints(const Lattice& lat, Index* removed = nullptr);

/// Whether the lattice cell with lowest corner u has all 8 corners material (a complete cell:
/// the cells the volume is kept on).
bool isCompleteCell(const Lattice& lat, const Vec3i& u);

}  // namespace dgv
