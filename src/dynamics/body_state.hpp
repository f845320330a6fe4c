#pragma once
/// @file body_state.hpp
/// @brief Everything of a DeformableBody that changes from step to step, as plain arrays: what a
/// state checkpoint (docs/robustness.md, "State checkpoints") saves so that a run restarted from
/// it continues bit-identically. What is NOT in it is a function of the lattice, the settings
/// and the initial positions (masses, cells, rest volumes, pins, the reconstruction's solver),
/// or of the positions (the geometric state, recomputed on restore).
///
/// Which caches change later results, and how each is handled:
///  - the reconstruction's warm start (the last two twist displacements, extrapolated): the CG
///    stops at a relative tolerance, so its start changes the bits: saved;
///  - the volume projection's multigrid (VolumeProjectionCache): built from one call's normal
///    matrix and reused until the active cells change, so it changes the CG's iterates: the
///    input of the call that built it is saved and the hierarchy rebuilt from it on restore;
///  - the PoissonSolver's work arrays and the CG workspaces: overwritten before every use.
/// A new member of DeformableBody that carries from one step to the next belongs here (and in
/// io/state_file.cpp, with its format version raised).

#include "base/types.hpp"

#include <array>
#include <vector>

namespace dgv {

struct DeformableBodyState {
    std::vector<Vec3> positions;                   ///< #P x
    std::vector<Vec3> velocities;                  ///< #P v over the last step
    std::array<std::vector<Vec3>, 3> tangentPrev;  ///< #P each: the frames before the last step
    bool havePrev = false;
    std::array<std::vector<Mat3>, 3> deltaGamma;  ///< #P each: δΓ
    std::vector<unsigned char> contact;           ///< #P
    std::vector<Real> contactDepth;               ///< #P
    Vec3 centre = Vec3::Zero(), centreVelocity = Vec3::Zero();
    Mat3 flex = Mat3::Identity(), flexVelocity = Mat3::Zero();
    bool halfStep = false;
    Mat3 plasticFlex = Mat3::Identity();            ///< plasticity: the flex's rest stretch P
    std::array<std::vector<Mat3>, 3> plasticGamma;  ///< plasticity: Γ_p (#P each, or empty when off)
    Real lastStep = 0;                              ///< the last step's length, s (0: none yet); δΓ is per step of it
    Real freeFlight = 0;                            ///< s since the body last touched a collider (or since its start)
    Vec3 loadAmplitude = Vec3::Zero();              ///< a pinned body's load modes: amplitudes q, m (load_modes.hpp)
    Vec3 loadRate = Vec3::Zero();                   ///< ... and their rates q̇, m/s
    std::vector<Vec3> displacement;                 ///< #P: the reconstruction's warm start
    std::vector<Vec3> displacementPrev;  ///< #P: the displacement of the step before (extrapolated warm start)
    std::vector<Real> volumeLambda;  ///< #C or empty: the last step's volume multipliers (the next one's prediction)
    std::vector<Real> volumeLambdaPrev;            ///< #C or empty: the step's before
    std::vector<Vec3> volumeCachePositions;        ///< VolumeProjectionCache::builtFromPositions (#P or empty)
    std::vector<unsigned char> volumeCachePinned;  ///< VolumeProjectionCache::builtFromPinned (#P or empty)
    std::vector<Vec3> positionsBefore, velocitiesBefore;  ///< StepSolver::One, BDF2: the step before's (#P or empty)
    std::vector<Mat3> cellRest;                    ///< StepSolver::One with plasticity: each cell's rest stretch (#C or empty)
};

}  // namespace dgv
