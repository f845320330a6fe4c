#pragma once
/// @file errors.hpp
/// @brief The two kinds of user-facing failure. Both are thrown and caught once, in app/main,
/// which prints what() as one line and exits with the code below.
///   InputError   - bad input or usage (a malformed scene, a broken mesh, an impossible
///                  setting): exit 2, and nothing is written.
///   RuntimeError - a run-time failure (disk full, GL context unavailable, or a NumericalError:
///                  the dynamics faulted): exit 1.
/// Bugs use DGV_CHECK (check.hpp); numerical trouble is a returned report.

#include <stdexcept>
#include <string>

namespace dgv {

/// Bad input. Message form: "<input>: <where>: <what>", where <where> may be empty
/// (e.g. "scenes/a.json: objects[1].voxel_size: expected a positive number, got -1").
class InputError : public std::runtime_error {
public:
    InputError(const std::string& input, const std::string& where, const std::string& what)
        : std::runtime_error(compose(input, where, what)), mInput(input), mWhere(where), mWhat(what) {}

    const std::string& input() const { return mInput; }
    const std::string& where() const { return mWhere; }
    const std::string& problem() const { return mWhat; }

private:
    static std::string compose(const std::string& input, const std::string& where, const std::string& what) {
        std::string s = input;
        if (!where.empty()) s += (s.empty() ? "" : ": ") + where;
        return s + (s.empty() ? "" : ": ") + what;
    }
    std::string mInput, mWhere, mWhat;
};

/// A failure while running on valid input (I/O, GL, resources).
class RuntimeError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Numerical trouble in the dynamics that the run cannot step past (the lattice folds, a position
/// becomes non-finite, the rendered surface tears): a RuntimeError (exit 1) that the frame loop
/// can tell from I/O failures, and retry (sim/simulation, Simulation::advanceTo).
class NumericalError : public RuntimeError {
public:
    using RuntimeError::RuntimeError;
};

/// Exit codes of the dgv command (documented in README.md).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitBadInput = 2, kExitInterrupted = 130 };

}  // namespace dgv
