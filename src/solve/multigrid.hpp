#pragma once
/// @file multigrid.hpp
/// @brief Smoothed-aggregation algebraic multigrid on lattice-indexed unknowns, and the
/// conjugate-gradient solver it preconditions (docs/math.md, "The production solver").
///
/// For symmetric positive definite sparse matrices whose rows are lattice sites (points or cells
/// of geom/lattice.hpp) with a Laplacian-like structure: the lattice graph Laplacian of the
/// position solve (sparse_solve.hpp) and the cell normal matrix of the volume projection
/// (deform/volume.hpp). Setup, once per matrix:
///  - aggregates: the rows whose lattice coordinates fall in the same 3x3x3 block (coarse
///    coordinate = coordinate / 3), numbered in order of their first row (deterministic);
///  - tentative prolongation: 1 on the row's aggregate (it carries the constants, the
///    Laplacian's near null space); smoothed: P = (1 - (4/3) / rho D^-1 A) P_tent
///    (Vanek, Mandel, Brezina 1996), rho = spectral radius of D^-1 A (power iteration, capped
///    by the Gershgorin bound);
///  - coarse matrix A_c = P^T A P (Galerkin), recursively until <= `coarsestRows` rows, which
///    are solved by a dense Cholesky (LDL^T) factorisation.
/// One application of the preconditioner is a V-cycle with a Chebyshev polynomial smoother of
/// D^-1 A on [rho / eigenRatio, 1.1 rho] before and after the coarse correction: a symmetric
/// positive definite operator, so conjugate gradients stay valid. Everything runs in parallel
/// with fixed-block reductions: results are bit-identical for any thread count.

#include "base/types.hpp"
#include "solve/solve_report.hpp"

#include <memory>
#include <vector>

namespace dgv {

/// A square sparse matrix by compressed rows (both triangles stored).
struct SparseRows {
    Index rows = 0;
    std::vector<int> start;   ///< rows + 1 offsets into column/value
    std::vector<int> column;  ///< column of each entry, increasing within a row
    std::vector<Real> value;
};

/// y = A x for `cols` interleaved columns (x, y: rows x cols, row-major), in parallel.
void multiply(const SparseRows& A, const Real* x, Real* y, int cols);

struct MultigridSettings {
    int aggregateSize = 3;     ///< aggregate edge, in lattice sites of the level below
    Index coarsestRows = 800;  ///< solve directly at or below this many rows
    int maxLevels = 12;
    int smootherDegree = 2;  ///< Chebyshev degree, before and after the coarse correction
    Real eigenRatio = 10;    ///< the smoother damps D^-1 A eigenvalues in [rho/ratio, 1.1 rho]
    /// Aggregate each parity class (i mod 2, j mod 2, k mod 2) of the sites separately: an
    /// aggregate is the sites of one class in a block of (2 aggregateSize)^3, so the coarse space
    /// carries every sign pattern (-1)^(i+j), (-1)^(i+j+k), ... times a smooth envelope. For
    /// matrices whose near-null space includes such checkerboards (the cell normal matrix of
    /// deform/volume.hpp); coarse site = 2 block + parity, so the classes persist on every level.
    bool parityAggregates = false;
    /// Run the V-cycle in single precision (the matrices, D^-1, P and R rounded to float; the
    /// coarsest solve stays double): half the memory traffic of the cycle. The preconditioner
    /// is then B^-1 up to float rounding (relative ~1e-7), which conjugate gradients tolerate
    /// down to tolerances far below that (their residual is computed in double).
    bool floatCycle = false;
};

struct CgWorkspace;

class AggregationMultigrid {
public:
    /// Builds the hierarchy of `A` (SPD; copied) whose row i is the lattice site coords[i]
    /// (non-negative). Rows with no entry must not occur.
    AggregationMultigrid(const SparseRows& A, const std::vector<Vec3i>& coords, const MultigridSettings& settings = {});
    ~AggregationMultigrid();
    AggregationMultigrid(const AggregationMultigrid&) = delete;
    AggregationMultigrid& operator=(const AggregationMultigrid&) = delete;

    /// z = B^-1 r for `cols` interleaved columns (one V-cycle from z = 0). r, z: rows x cols.
    void apply(const Real* r, Real* z, int cols) const;

    const SparseRows& matrix() const;
    int levels() const;
    Index rowsAt(int level) const;
    double setupSeconds() const;

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
    friend SolveReport conjugateGradients(const SparseRows&, const AggregationMultigrid*, const std::vector<Real>&,
                                          std::vector<Real>&, int, Real, Real, int, CgWorkspace*);
};

/// Conjugate gradients on A X = B for `cols` interleaved columns (independent CG recurrences,
/// one matrix product for all), preconditioned by `mg` (nullptr: Jacobi). X (rows x cols) is
/// the initial guess and the result. Residual: |B - A X|_F / scale (scale <= 0: |B|_F);
/// converged when it is <= tolerance; stops after maxIterations.
/// Work arrays of conjugateGradients, kept by a caller that solves repeatedly (no page faults
/// on large lattices).
struct CgWorkspace {
    std::vector<Real> r, z, p, q;
};

SolveReport conjugateGradients(const SparseRows& A, const AggregationMultigrid* mg, const std::vector<Real>& B,
                               std::vector<Real>& X, int cols, Real tolerance, Real scale, int maxIterations,
                               CgWorkspace* workspace = nullptr);

}  // namespace dgv
