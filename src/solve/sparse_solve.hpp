#pragma once
/// @file sparse_solve.hpp
/// @brief The production position solve (docs/math.md, "The production solver"): positions that
/// best satisfy every edge step, min Σ_edges |x(q) - x(p) - D_pq|^2 with the fixed points held,
/// i.e. the lattice graph Laplacian L x = b on the free points (b_p = Σ_{q fixed} x(q) - Σ_q D_pq,
/// D_pq = positionStep of holonomy.hpp). The fixed point of every gather iteration of gather.hpp
/// is the same x.
///
/// L depends only on the lattice and on which points are fixed, never on the connection, so its
/// multigrid hierarchy (multigrid.hpp: smoothed aggregation, 3x3x3 aggregates) is built ONCE per
/// lattice and fixed set and reused for every step; each solve is conjugate gradients (in double)
/// on the three world axes together, preconditioned by one V-cycle per iteration (in float:
/// MultigridSettings::floatCycle) and warm-started from the positions passed in (the previous
/// step's, or the path integration's).
/// Residual: the position residual of gather.hpp, |b - L x| / sqrt(Σ_p n_p Σ_q |D_pq|^2).

#include "base/types.hpp"
#include "geom/lattice.hpp"
#include "solve/holonomy.hpp"
#include "solve/solve_report.hpp"

#include <array>
#include <memory>
#include <vector>

namespace dgv {

class PoissonSolver {
public:
    /// Builds L on the free points (fixed[p] == 0) of `lat` and its multigrid hierarchy. Every
    /// 6-connected component needs at least one fixed point, else L is singular and ok() is
    /// false (solve() then reports not converged and leaves the positions alone).
    PoissonSolver(const Lattice& lat, const std::vector<unsigned char>& fixed);
    ~PoissonSolver();
    PoissonSolver(const PoissonSolver&) = delete;
    PoissonSolver& operator=(const PoissonSolver&) = delete;

    bool ok() const;
    double setupSeconds() const;  ///< wall-clock time of building L and the hierarchy
    Index freeCount() const;
    int levels() const;  ///< multigrid levels (1 = direct solve only)
    /// Whether this solver was made for a lattice of this size and this fixed mask.
    bool matches(const Lattice& lat, const std::vector<unsigned char>& fixed) const;

    /// Solves for the free positions given frames (#P) and the edge transports, starting from
    /// the values in `positions` (#P, in/out; fixed points keep theirs). converged = residual
    /// <= tolerance within maxIterations conjugate-gradient iterations (each one V-cycle).
    /// Keeps its work arrays between calls: not for concurrent calls on one solver.
    /// fromPath: start from pathPositions() instead (the fixed points must hold their values),
    /// sharing the edge steps with it; the same result as pathPositions() then solve().
    SolveReport solve(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                      std::vector<Vec3>& positions, Real tolerance = Real(1e-8), int maxIterations = 200,
                      bool fromPath = false) const;

    /// The same least-squares solve with the edge steps given directly: forward[a][p] is the
    /// step x(p + e_a) - x(p) along axis a from point p (entries of points without a +a
    /// neighbour are ignored). The dynamics solves for a displacement this way, from the
    /// difference of the steps of two connections (dynamics/stepper.hpp).
    SolveReport solveSteps(const Lattice& lat, const std::array<std::vector<Vec3>, 3>& forward,
                           std::vector<Vec3>& positions, Real tolerance = Real(1e-8), int maxIterations = 200) const;

    /// L x = f on the free points, the fixed points holding the values in `positions`: the
    /// lattice's discrete Poisson problem with the load f (#P, one vector per point; entries of
    /// fixed points are ignored), e.g. the static response of a membrane-like body held at its
    /// fixed points (dynamics/load_modes.hpp). Residual relative to |f| over the free points.
    SolveReport solveLoad(const Lattice& lat, const std::vector<Vec3>& load, std::vector<Vec3>& positions,
                          Real tolerance = Real(1e-8), int maxIterations = 200) const;

    /// The Path positions (reconstruct.hpp) from the fixed points, which must already hold
    /// their values in `positions` (#P, in/out): x(q) = x(parent) + D_parent,q along the
    /// breadth-first tree from the fixed points (point order, slot order), the tree cached at
    /// construction and integrated one BFS layer at a time in parallel. Identical to
    /// integratePositionsAlongTree with the same fixed set. Computes every edge's step first, into
    /// the solver's work arrays (not for concurrent calls on one solver, like solve()).
    void pathPositions(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                       std::vector<Vec3>& positions) const;

    struct Impl;  ///< (public so that the .cpp's helpers can take it)

private:
    std::unique_ptr<Impl> mImpl;
};

}  // namespace dgv
