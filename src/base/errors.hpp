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

/// A library's or a tool's message (OpenVDB, assimp, nlohmann-json, ffmpeg) as one short readable
/// line: its first non-blank line without trailing blanks ("" when there is none), other control
/// bytes as '?', cut to `limit` characters with "...". OpenVDB
/// echoes what it read from a damaged file: a truncated level set's message was 22,000
/// characters of one line.
inline std::string libraryMessage(const std::string& what, std::size_t limit = 200) {
    std::string line;
    for (char c : what) {
        if (c == '\n' || c == '\r') {
            if (line.find_first_not_of(' ') != std::string::npos) break;
            line.clear();
            continue;
        }
        const unsigned char u = static_cast<unsigned char>(c);
        line += u < 0x20 || u == 0x7f ? '?' : c;
        if (line.size() > limit) {
            line.resize(limit);
            return line + "...";
        }
    }
    line.erase(line.find_last_not_of(' ') + 1);
    return line;
}

/// A failure while running on valid input (I/O, GL, resources).
class RuntimeError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// What went wrong numerically in a dynamics step, so that a caller can branch on it (the frame
/// loop, the stress suite's tally) instead of parsing the message.
enum class FaultKind {
    None,
    FlexInverted,   ///< body and flex: the affine part turned over (det A <= 0)
    LatticeFolded,  ///< twist: the connection blew up (|Γ + δΓ| beyond 100 per lattice step)
    TwistTooFar,    ///< reconstruction: the twist moved a point over 2 lattice steps in one step
    CellsInverted,  ///< the volume projection left cells with non-positive volume
    NonFinite,      ///< a position became NaN or infinite
    SurfaceTorn,    ///< the rendered surface folds over or tears (docs/math.md, "Never a torn frame")
    Unknown,
};

/// The kind's name in messages and reports: "lattice_folded", ...; "none" for None.
inline const char* faultKindName(FaultKind kind) {
    switch (kind) {
        case FaultKind::None:
            return "none";
        case FaultKind::FlexInverted:
            return "flex_inverted";
        case FaultKind::LatticeFolded:
            return "lattice_folded";
        case FaultKind::TwistTooFar:
            return "twist_too_far";
        case FaultKind::CellsInverted:
            return "cells_inverted";
        case FaultKind::NonFinite:
            return "non_finite";
        case FaultKind::SurfaceTorn:
            return "surface_torn";
        case FaultKind::Unknown:
            break;
    }
    return "unknown";
}

/// Numerical trouble in the dynamics that the run cannot step past (the lattice folds, a position
/// becomes non-finite, the rendered surface tears): a RuntimeError (exit 1) that the frame loop
/// can tell from I/O failures, and retry (sim/simulation, Simulation::advanceTo). kind() says
/// which trouble.
class NumericalError : public RuntimeError {
public:
    explicit NumericalError(const std::string& what, FaultKind kind = FaultKind::Unknown)
        : RuntimeError(what), mKind(kind) {}
    FaultKind kind() const { return mKind; }

private:
    FaultKind mKind;
};

/// Exit codes of the dgv command (documented in README.md).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitBadInput = 2, kExitInterrupted = 130 };

}  // namespace dgv
