// Saving and restoring the dynamic state of a body (body_state.hpp).

#include "dynamics/body_state.hpp"

#include "base/check.hpp"
#include "dynamics/stepper.hpp"
#include "solve/sparse_solve.hpp"

#include <utility>

namespace dgv {

VolumeProjectionSettings DeformableBody::volumeSettings() {
    VolumeProjectionSettings vs;
    vs.tolerance = mSet.volumeTolerance;
    // The body's total volume within a twentieth of a cell's tolerance: 5e-7 at the default,
    // under the drift goal of 1e-6 (docs/math.md, "Cell volumes and the volume projection").
    vs.driftTolerance = mSet.volumeTolerance / 20;
    vs.cache = &mVolumeCache;
    vs.weights = &mVolumeWeight;
    return vs;
}

DeformableBodyState DeformableBody::saveState() const {
    DeformableBodyState s;
    s.positions = mX;
    s.velocities = mV;
    s.tangentPrev = mTangentPrev;
    s.havePrev = mHavePrev;
    s.deltaGamma = mDGamma;
    s.contact = mContact;
    s.contactDepth = mContactDepth;
    s.centre = mC;
    s.centreVelocity = mVc;
    s.flex = mA;
    s.flexVelocity = mAdot;
    s.halfStep = mHalfStep;
    s.plasticFlex = mPlasticFlex;
    s.plasticGamma = mPlasticGamma;
    s.lastStep = mDtLast;
    s.freeFlight = mFreeFlight;
    s.loadAmplitude = mQ;
    s.loadRate = mQdot;
    s.displacement = mDisplacement;
    s.displacementPrev = mDisplacementPrev;
    s.volumeLambda = mVolumeLambda;
    s.volumeLambdaPrev = mVolumeLambdaPrev;
    s.volumeCachePositions = mVolumeCache.builtFromPositions;
    s.volumeCachePinned = mVolumeCache.builtFromPinned;
    s.cellRest = mCellRest;
    s.positionsBefore = mXBefore;
    s.velocitiesBefore = mVBefore;
    return s;
}

bool DeformableBody::stateFits(const DeformableBodyState& s) const {
    const std::size_t n = static_cast<std::size_t>(mLat.size());
    const std::size_t cells = static_cast<std::size_t>(mCells.size());
    bool ok = s.positions.size() == n && s.velocities.size() == n && s.contact.size() == n &&
              s.contactDepth.size() == n && s.displacement.size() == n && s.displacementPrev.size() == n &&
              (s.volumeCachePositions.empty() || s.volumeCachePositions.size() == n) &&
              (s.volumeCachePinned.empty() || s.volumeCachePinned.size() == n) &&
              (!s.volumeCachePinned.empty() ? !s.volumeCachePositions.empty() : true) &&
              (s.volumeLambda.empty() || s.volumeLambda.size() == cells) &&
              (s.volumeLambdaPrev.empty() || s.volumeLambdaPrev.size() == cells) &&
              (s.cellRest.empty() || s.cellRest.size() == mCellRest.size()) &&
              (s.positionsBefore.empty() || s.positionsBefore.size() == n) &&
              s.velocitiesBefore.size() == s.positionsBefore.size();
    for (std::size_t a = 0; a < 3; ++a) {
        ok = ok && s.deltaGamma[a].size() == n;
        ok = ok && s.plasticGamma[a].size() == mPlasticGamma[a].size();  // n with plasticity, else 0
        ok = ok && (s.tangentPrev[a].size() == n || (!s.havePrev && s.tangentPrev[a].empty()));
    }
    return ok;
}

void DeformableBody::restoreState(DeformableBodyState s) {
    DGV_CHECK(stateFits(s));
    mX = std::move(s.positions);
    mV = std::move(s.velocities);
    mTangentPrev = std::move(s.tangentPrev);
    mHavePrev = s.havePrev;
    mDGamma = std::move(s.deltaGamma);
    mContact = std::move(s.contact);
    mContactDepth = std::move(s.contactDepth);
    mC = s.centre;
    mVc = s.centreVelocity;
    mA = s.flex;
    mAdot = s.flexVelocity;
    mHalfStep = s.halfStep;
    mPlasticFlex = s.plasticFlex;
    mPlasticGamma = std::move(s.plasticGamma);
    mDtLast = s.lastStep;
    mFreeFlight = s.freeFlight;
    mQ = s.loadAmplitude;
    mQdot = s.loadRate;
    mDisplacement = std::move(s.displacement);
    mDisplacementPrev = std::move(s.displacementPrev);
    mVolumeLambda = std::move(s.volumeLambda);
    mVolumeLambdaPrev = std::move(s.volumeLambdaPrev);
    // (none: a body re-voxelised in its current shape, which its new cells take as their rest)
    if (!s.cellRest.empty()) mCellRest = std::move(s.cellRest);
    else std::fill(mCellRest.begin(), mCellRest.end(), Mat3::Identity());
    mXBefore = std::move(s.positionsBefore);
    mVBefore = std::move(s.velocitiesBefore);
    mPredicted = false;  // a step cut short by a fault (Simulation::advanceTo retries the frame)
    // The geometric state is a function of the positions (the step ends by computing it so).
    computeGeometricState(mLat, mX, mState, BoundaryStencils::Realisable);
    mVolumeCache.builtFromPositions = std::move(s.volumeCachePositions);
    mVolumeCache.builtFromPinned = std::move(s.volumeCachePinned);
    if (mSet.projectVolume && mCells.size() > 0) {
        rebuildVolumeProjectionCache(mCells, mRestVolumes, volumeSettings());
    } else {
        mVolumeCache = VolumeProjectionCache();
    }
}

}  // namespace dgv
