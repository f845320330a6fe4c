#pragma once
/// @file reparametrise.hpp
/// @brief Re-parametrisation of a flowing body (docs/math.md, "Re-parametrisation: a fresh lattice
/// for a body that flows"). The notes keep a body's material lattice fixed for all time, and a
/// fixed lattice cannot follow a flow that shears without bound: under a steady vortex every
/// material line winds into a spiral, Γ grows without bound and the lattice folds. Goo (no rest
/// shape to remember) is therefore re-voxelised in its current shape when its lattice has
/// distorted past a bound: the union of its deformed cells is sampled on a fresh world-aligned
/// grid of the same spacing, the new cells are those whose centres lie inside it, and the motion
/// carries over (centre and flex velocities exactly, the point velocities interpolated). The
/// notes' "network fixed for all time" holds between re-parametrisations. Putty's yielded rest
/// shape (Γ_p, P) goes with it, changed into the new lattice's coordinates; a jelly's cannot yet
/// (moved so at a lattice-scale crease, its rest connection winds its memory up: docs/math.md).
///
/// Volume. The new cells are the cubes the old shape covers most (27 samples a cell), as many as
/// bring their total closest to the body's rest volume; their spacing is then scaled (by
/// `dilation`, within kMaxRemapDilation of 1; measured 1e-3 and under) so that the total is the
/// rest volume exactly, and the new positions are their rest positions: every cell starts at its
/// rest volume (no pop) and the total is kept to round-off. A world point w of the old shape (a
/// surface vertex) maps to pivot + dilation (w − pivot).
///
/// Deterministic: serial sampling in a fixed order, then the same parallel passes as the step.

#include "base/types.hpp"
#include "dynamics/body_state.hpp"
#include "geom/lattice.hpp"

#include <string>

namespace dgv {

class DeformableBody;

/// How far a body's lattice has distorted, over its points (the step's Realisable stencils).
struct LatticeDistortion {
    Real maxGamma = 0;     ///< max_p |Γ_p| (Frobenius over the 27 components), per lattice step
    Real maxAspect = 1;    ///< max_p σ_max / σ_min of the frame F = [x_1 x_2 x_3]
    Real minFrameDet = 1;  ///< min_p det F / h³ (1 at rest; ≤ 0: a frame turned over)
};
LatticeDistortion latticeDistortion(const DeformableBody& body);

/// When a body's lattice no longer follows it (docs/math.md, "Re-parametrisation", gives the
/// evidence): its connection past maxGamma per lattice step at some point, or a frame whose
/// determinant falls under minFrameDet. The aspect of the frames is not a bound: a landing
/// squashes a body flat with Γ = 0 (an affine squash), and remapping it there made landings fail
/// sooner.
struct ReparametriseBound {
    Real maxGamma = 0.5;
    Real minFrameDet = 0.25;
    bool exceeded(const LatticeDistortion& d) const {
        return !(d.maxGamma <= maxGamma) || !(d.minFrameDet >= minFrameDet);
    }
};

/// The largest change of the cell spacing a remap may make (|dilation − 1|): beyond it the new
/// cubes cannot hold the shape's volume (parts under a voxel thick) and the remap is refused.
inline constexpr Real kMaxRemapDilation = 0.02;
/// The most of a body's volume a remap may leave more than a cell away from the new cells
/// (Reparametrisation::mismatch).
inline constexpr Real kMaxRemapMismatch = 0.05;
/// The least share of a body's volume the samples of the old shape must see (Reparametrisation::sampled).
inline constexpr Real kMinRemapSampled = 0.9;

/// The largest grid a remap samples on (about 130 bytes a cell: 1 GB): a body whose parts have
/// flown far apart is refused rather than sampled on a grid spanning the space between them.
inline constexpr long kMaxRemapGridCells = 8'000'000;

/// A body re-voxelised in its current shape.
struct Reparametrisation {
    Lattice lattice;            ///< the new material lattice (spacing h · dilation)
    DeformableBodyState state;  ///< the body's state on it: construct a DeformableBody on `lattice`
                                ///< at restPositions(lattice) with the same settings, then restoreState
    Vec3 pivot = Vec3::Zero();  ///< world points of the old shape map to pivot + dilation (w − pivot)
    Real dilation = 1;
    Real mismatch = 0;    ///< the old shape's volume more than a cell from every new cell / the volume
    Real sampled = 0;     ///< the old shape's volume the samples see / the volume
    std::string refused;  ///< why the body cannot be re-parametrised (then nothing else is set)
};

/// Re-voxelises `body` in its current shape (file comment). Refused (with the reason) for a body
/// with pins, for a jelly (stiffness without yield), for a shape no new cell fits, and past the
/// bounds above.
Reparametrisation reparametrise(const DeformableBody& body);

}  // namespace dgv
