#pragma once
/// @file gather.hpp
/// @brief The seed's whole-volume "gather" iterations (eqs 20-34) for frames and positions:
/// Jacobi (eq 26), SOR (eqs 27-30) and the adaptive-gain method the seed calls CG (eqs 31-34).
///
/// Each point p gathers from its lattice neighbours q the value they imply for it:
///   frames     F(p) <- F(q) T_qp              (T_qp = frameTransport(q -> p), eqs 21-22)
///   positions  x(p) <- x(q) - D_pq            (D_pq = positionStep(p -> q), frames fixed)
/// and the fixed point is Σ_q [implied_q(p) - y(p)] = 0 at every free point.
///
/// Update rules (J(p) = (1/n_p) Σ_q implied_q(p), n_p = number of neighbours present):
///  - Jacobi:        y_m = J(y_{m-1}). This is eq 26 averaged over the neighbours present; the
///                   literal sum of eq 26 (JacobiSummed, y_m = n_p J) multiplies by ~n_p per
///                   sweep and diverges (kept to show it; stops at residual 1e30, no overflow).
///  - Sor:           red-black ordering (colour (i+j+k) mod 2; same-colour points are never
///                   neighbours, so each half sweep is parallel and order-free). Standard form:
///                   y(p) <- (1-w) y(p) + w J_latest(p). Seed form (eqs 28-30):
///                   y(p) <- J_old(p) + w (J_latest(p) - J_old(p)) (w = 0 Jacobi, w = 1 G-S).
///  - AdaptiveGain:  eqs 31-34: J_old everywhere, the correction C = J_latest - J_old (non-zero
///                   on the second colour only), the gain w_+ = -Σ (J_old - y_{m-1})·C / Σ C·C
///                   (eq 33), then y = J_old + w_+ C (eq 34).
/// Fixed points (mask) are never updated. A wall (positions only) is called on every free point
/// after each sweep (after each colour for SOR: projected SOR) and may move it; points it moved
/// are left out of the residual (they carry the constraint's reaction).
///
/// Residual (checked every `checkEvery` sweeps and at the end):
///   |r| / scale, r_p = Σ_q [implied_q(p) - y(p)] over free points not held by the wall;
///   scale: frames sqrt(Σ_p n_p^2 |F_p|^2); positions sqrt(Σ_p n_p Σ_q |D_pq|^2) (the edge data,
///   so the figure is independent of translations). Converged when residual <= tolerance.

#include "base/types.hpp"
#include "geom/lattice.hpp"
#include "solve/holonomy.hpp"
#include "solve/solve_report.hpp"

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace dgv {

enum class GatherMethod { Jacobi, JacobiSummed, Sor, AdaptiveGain };
enum class SorForm { Standard, Seed };

/// A wall-type constraint on positions: called with a free point and its position after each
/// sweep; corrects the position in place and returns true when it moved it. Must be
/// thread-safe and depend only on its arguments (it runs in parallel).
using WallConstraint = std::function<bool(Index point, Vec3& position)>;

struct GatherSettings {
    GatherMethod method = GatherMethod::Sor;
    Real gain = 1.9;  ///< w of eq 30 (Sor); unused by AdaptiveGain (eq 33 does
                      ///< not depend on the precursor gain w_-)
    SorForm sorForm = SorForm::Standard;
    Real tolerance = 1e-8;  ///< relative residual
    int maxIterations = 1000000;
    double maxSeconds = std::numeric_limits<double>::infinity();
    int checkEvery = 10;  ///< sweeps between residual checks (>= 1)
    WallConstraint wall;  ///< positions only; empty: none

    /// Problems by field name ("gain: must be in (0, 2)"); empty when valid.
    std::vector<std::string> validate() const;
};

/// Gather iterations on frames (#P, columns x_a, world units per lattice step) with the
/// transports `e`. `fixed` (#P, non-zero = pinned) marks points never updated; `frames` holds
/// the initial guess and the result.
SolveReport gatherFrames(const Lattice& lat, const EdgeTransports& e, const std::vector<unsigned char>& fixed,
                         const GatherSettings& settings, std::vector<Mat3>& frames);

/// Gather iterations on positions (#P, world units) given frames (#P).
SolveReport gatherPositions(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                            const std::vector<unsigned char>& fixed, const GatherSettings& settings,
                            std::vector<Vec3>& positions);

/// The position residual defined above (no wall exclusion), for any method's result.
Real positionResidual(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                      const std::vector<unsigned char>& fixed, const std::vector<Vec3>& positions);

/// The frame residual defined above, for any method's result.
Real frameResidual(const Lattice& lat, const EdgeTransports& e, const std::vector<unsigned char>& fixed,
                   const std::vector<Mat3>& frames);

}  // namespace dgv
