#pragma once
/// @file load_modes.hpp
/// @brief The load a pinned body's pins refuse, as three smooth volume-keeping deformation modes
/// (beyond the notes; docs/math.md, "A pinned body under a uniform load").
///
/// The notes' step moves a body by its centre (eqs 66-67), its affine flex (eq 68) and its twist
/// (eq 76, driven by the force's Hessian). Pins hold the centre and the flex, and a uniform field
/// has no Hessian, so a pinned body under gravity did not move at all. Here the refused load gets
/// a shape to act on: for each world axis i, the mode w_i is the incompressible (Stokes) response
/// of the body held at its pins to a unit load along e_i with the points' masses as density,
///     minimise  Σ_edges |w(q) − w(p)|² / 2 − Σ_p (m_p / m̄) e_i · w(p)
///     subject to  J w = 0 (every cell's volume unchanged to first order), w = 0 at the pins,
/// with the lattice graph Laplacian L as the Dirichlet energy and J the cells' volume gradients
/// at rest (deform/volume.hpp). It is solved as w = w0 − L⁻¹ Jᵀ p, w0 = L⁻¹ f, with the cell
/// pressures p from conjugate gradients on the Schur complement J L⁻¹ Jᵀ p = J w0 (one Poisson
/// solve per iteration, solve/sparse_solve.hpp) to 1e-2, then polished: w ← (x₊ − x₋) / 2ε with
/// x± the volume projection of rest ± ε w (the trilinear cells' checkerboard pressures, which
/// the CG resolves slowest, left to the projection; J w per unit amplitude then 1e-6 .. 1e-10 of
/// a cell's volume). The minimum-norm volume projection of w0 alone (the first attempt) is rough
/// where the pins end and folded bodies loaded in compression; the Stokes mode is as smooth as
/// the Poisson response away from the pins' rim. Cost, once per body: 17k points 2 s, 137k
/// points 17 s (2 cores), most of it the polish's six projections.
/// Each mode is scaled so that its largest point displacement is 1 m per unit amplitude; points
/// in a component without a pin have w = 0 (such a component moves by its centre and flex).

#include "base/types.hpp"
#include "deform/volume.hpp"
#include "geom/lattice.hpp"

#include <array>
#include <vector>

namespace dgv {

class PoissonSolver;

struct LoadModes {
    std::array<std::vector<Vec3>, 3> w;  ///< #P each, world units per unit amplitude (empty: none)
    Mat3 mass = Mat3::Zero();            ///< M_q = Σ_p m_p w_i(p) · w_j(p), kg
    Vec3 strain = Vec3::Zero();          ///< per mode: the largest cell strain per unit amplitude, 1/m
    /// Per mode, what an affine load a + K X̃ (X̃ = rest position about the centre of mass) puts on
    /// it: Σ_p m_p w_i(p) · (a + K X̃_p) = a · massSum[i] + K : firstMoment[i].
    std::array<Vec3, 3> massSum{};      ///< Σ_p m_p w_i(p), kg
    std::array<Mat3, 3> firstMoment{};  ///< Σ_p m_p w_i(p) X̃_pᵀ, kg m
    bool empty() const { return w[0].empty(); }
};

/// The three load modes of a body at rest (positions `rest`, #P) held at the points with
/// pinned[p] != 0. `solver` is the body's Poisson solver (its fixed set: the pins, plus one point
/// in each component without a pin). Empty when no point is pinned or no point is free.
LoadModes computeLoadModes(const Lattice& lat, const std::vector<Vec3>& rest, const std::vector<unsigned char>& pinned,
                           const LatticeCells& cells, const std::vector<Real>& restVolumes,
                           const std::vector<Real>& mass, const PoissonSolver& solver);

}  // namespace dgv
