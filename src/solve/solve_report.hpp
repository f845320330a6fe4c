#pragma once
/// @file solve_report.hpp
/// @brief The outcome of a solve: numerical trouble is a returned value (docs/conventions.md).

#include "base/types.hpp"

namespace dgv {

struct [[nodiscard]] SolveReport {
    bool converged = false;  ///< residual <= tolerance (direct methods: true unless singular)
    int iterations = 0;      ///< sweeps done (0 for direct and path methods)
    Real residual = 0;       ///< relative residual at the end (its definition: the solver's header)
    double seconds = 0;      ///< wall-clock time of the call
    bool diverged = false;   ///< stopped because the residual grew past 1e30 (never overflows)
};

}  // namespace dgv
