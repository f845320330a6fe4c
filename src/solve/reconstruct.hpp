#pragma once
/// @file reconstruct.hpp
/// @brief Frames and positions from a connection (seed eqs 53-59): the "displacement vector from
/// connection" of section 3, solved for the deformed frames F = [X_1 X_2 X_3] and positions X
/// directly (the seed's M and ε follow from them: X_a = Σ_c M_a^c x_c, eq 46; δx = X - x).
///
/// Given Γ̄ (e.g. Γ_rest + δΓ; as GeometricState::christoffel) turned into edge transports
/// (holonomy.hpp), and a reference (pins: points whose position and/or frame are given), the
/// methods are:
///  - Path:   frames and positions integrated along a breadth-first spanning tree grown from the
///            pins (slot order, so deterministic), eqs 57 and 59 edge by edge. O(N), exact when
///            the connection is exact and constant along each edge; otherwise the finite-
///            difference error accumulates along the tree (second order, measured).
///  - Jacobi, JacobiSummed, Sor, AdaptiveGain: the gather iterations of gather.hpp, frames first
///            then positions (cold start: values from the first pin unless the caller's arrays
///            already have #P entries, which are then used as the initial guess).
///  - LeastSquares (production, the default): frames by Path, positions by the least-squares
///            fit of every edge step (sparse_solve.hpp: lattice Laplacian, conjugate gradients
///            with a smoothed-aggregation multigrid V-cycle; the hierarchy is built once per
///            lattice and fixed set and reused through `solver`). Starts from the Path
///            positions, or (startFromPath = false) from the positions passed in when they have
///            #P entries (warm start from the last step). With a wall: the solve, then
///            projected SOR sweeps with the wall from there (warm start).
/// Every 6-connected component must hold a pinned frame and a pinned position (a bug otherwise;
/// checked). The gauge: Γ fixes the shape up to an affine map x -> A x + b; the pins fix A and b.

#include "base/types.hpp"
#include "geom/lattice.hpp"
#include "solve/gather.hpp"
#include "solve/holonomy.hpp"
#include "solve/solve_report.hpp"
#include "solve/sparse_solve.hpp"

#include <array>
#include <string>
#include <vector>

namespace dgv {

enum class ReconstructMethod { Path, Jacobi, JacobiSummed, Sor, AdaptiveGain, LeastSquares };

/// A reference point: its position and/or its frame are given and never change.
struct Pin {
    Index point = kNoPoint;
    Vec3 position = Vec3::Zero();   ///< world units
    Mat3 frame = Mat3::Identity();  ///< columns X_a, world units per lattice step
    bool fixPosition = true;
    bool fixFrame = true;
};

struct ReconstructSettings {
    ReconstructMethod method = ReconstructMethod::LeastSquares;
    Real tolerance = 1e-8;        ///< relative residual (gather.hpp) for iterative solves
    int maxIterations = 1000000;  ///< sweeps (gather) or CG iterations (LeastSquares, capped at 1000)
    double maxSeconds = 60;       ///< per call, iterative methods
    int checkEvery = 10;
    Real gain = 1.9;  ///< SOR gain w (eq 30)
    SorForm sorForm = SorForm::Standard;
    WallConstraint wall;  ///< optional, positions only
    /// LeastSquares: start from the Path positions (true; O(N), usually the better start) or
    /// from the positions passed in when they have #P entries (false: a warm start from the
    /// last step). Measured in docs/solvers.md.
    bool startFromPath = true;

    /// Problems by field name; empty when valid.
    std::vector<std::string> validate() const;
    /// The iterative settings these imply.
    GatherSettings gather() const;
};

/// Pins of a reference state: the point nearest the centroid of each 6-connected component,
/// fixed at the given positions and frames (#P each).
std::vector<Pin> centrePins(const Lattice& lat, const std::vector<Vec3>& positions, const std::vector<Mat3>& frames);

/// Frames (#P, in/out) from the transports and the pinned frames. Iterative methods report the
/// frame residual of gather.hpp; Path and LeastSquares report iterations 0, converged true and,
/// for information, the same residual of their result (it measures the path dependence,
/// O(h^2) for a connection computed from positions).
SolveReport reconstructFrames(const Lattice& lat, const EdgeTransports& e, const std::vector<Pin>& pins,
                              const ReconstructSettings& settings, std::vector<Mat3>& frames);

/// Positions (#P, in/out) from frames (#P) and the pinned positions. LeastSquares uses `solver`
/// when it matches the lattice and the fixed set, else builds one (its setup time is then inside
/// the report's seconds); keep one PoissonSolver per lattice and pin set across steps.
SolveReport reconstructPositions(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                                 const std::vector<Pin>& pins, const ReconstructSettings& settings,
                                 std::vector<Vec3>& positions, const PoissonSolver* solver = nullptr);

/// The fixed masks (#P, 1 = fixed) of the pins, for positions and for frames.
std::vector<unsigned char> fixedPositionMask(const Lattice& lat, const std::vector<Pin>& pins);
std::vector<unsigned char> fixedFrameMask(const Lattice& lat, const std::vector<Pin>& pins);

/// The breadth-first spanning tree the Path method integrates along: FIFO from the roots (in
/// point order), neighbours in slot order, so deterministic. Kept by callers that integrate
/// along the same tree repeatedly (the dynamics, twice a step).
struct SpanningTree {
    std::vector<Index> order;           ///< visit order, roots first; unreached points absent
    std::vector<Index> parent;          ///< #P: the tree parent (kNoPoint: a root or unreached)
    std::vector<signed char> slot;      ///< #P: slot of the edge parent -> point (-1: none)
    std::vector<Index> parentPosition;  ///< per entry of `order`: its parent's index there (-1: a root)
};
SpanningTree spanningTree(const Lattice& lat, const std::vector<unsigned char>& roots);

/// Frames and positions along the breadth-first spanning tree from the pins (method Path):
/// every point gets the value carried from its tree parent (frames: F(q) = F(p) exp(S_pq);
/// positions: x(q) = x(p) + D_pq from the frames at both ends). Points of components without a
/// pin keep their values.
void integrateFramesAlongTree(const Lattice& lat, const EdgeTransports& e, const std::vector<Pin>& pins,
                              std::vector<Mat3>& frames);
void integratePositionsAlongTree(const Lattice& lat, const EdgeTransports& e, const std::vector<Mat3>& frames,
                                 const std::vector<Pin>& pins, std::vector<Vec3>& positions);

/// Work arrays of connectionChangeSteps, kept between calls (no page faults on large lattices).
struct ConnectionChangeWorkspace {
    std::array<std::vector<Vec3>, 3> from0, to0, from1, to1;  ///< step vectors per edge (EdgeTransports)
    std::vector<Mat3> tree0, tree1;                           ///< #P: frame transport of the tree edge into each point
    std::vector<Mat3> ordered0, ordered1;  ///< the tree edges' transports, then the frames, in the tree's order
    std::vector<Mat3> frames0, frames1;    ///< #P: the frames of each connection
    std::array<std::vector<Mat3>, 3> up0, down0, up1, down1;  ///< every edge p -> p + e_b, on p: exp(±S)
    std::array<std::vector<unsigned char>, 3> steep;  ///< every edge, on p: 1 where |S|_1 is past the sweeps' bound
    double edgeSeconds = 0, treeSeconds = 0, sweepSeconds = 0;  ///< the last call's stages (seconds)
    std::array<std::vector<Index>, 2> swept;                    ///< the points the sweeps update, per colour
};

/// The edge steps a connection change asks for (the dynamics' reconstruction, dynamics/stepper):
/// with frames integrated along `tree` from `frames` at its roots, once with Γ0 and once with
/// Γ1, then `frameSweeps` red-black Gauss-Seidel sweeps of each frame field (every point but
/// the roots takes the mean of its neighbours' frames carried across the edges: the tree's
/// path dependence smoothed out; docs/math.md, "Frames that do not depend on the tree"),
/// forward[b][p] = D1 − D0 for every edge p -> p + e_b (zero where absent), D the positionStep
/// of each connection. With frameSweeps = 0 the same values, to round-off, as
/// computeEdgeTransports, integrateFramesAlongTree (points the tree misses keep `frames`) and
/// positionStep for each connection, in one parallel pass over the edges; the work arrays
/// hold 720 bytes a point, and with sweeps 1.6 kB (every edge's transports both ways).
/// @param frames   #P frames; those at the tree's roots start both integrations
/// @param forward  out: 3 x #P
void connectionChangeSteps(const Lattice& lat, const SpanningTree& tree, const std::array<std::vector<Mat3>, 3>& gamma0,
                           const std::array<std::vector<Mat3>, 3>& gamma1, const std::vector<Mat3>& frames,
                           ConnectionChangeWorkspace& work, std::array<std::vector<Vec3>, 3>& forward,
                           int frameSweeps = 0);

}  // namespace dgv
