// DeformableBody's one-solve step (StepSolver::One; dynamics/cell_solve.hpp; docs/math.md, "The
// one-solve step"): the forces' inertial prediction, then one minimisation over the points.

#include "dynamics/stepper.hpp"

#include "base/parallel.hpp"
#include "dynamics/body.hpp"
#include "geom/geometric_state.hpp"
#include "base/errors.hpp"
#include "deform/sl3.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace dgv {

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

StepReport DeformableBody::predictOne(const ForceField& field, Real frame, Real dt) {
    // The inertial prediction: every force drives every point, so body, flex and twist (the
    // notes' eqs 64-76: the force's projections on those motions) all move. BDF2 where the step
    // before had the same length: with x̂ = (4 x_n − x_(n−1))/3, v̂ = (4 v_n − v_(n−1))/3 and
    // β = 2/3, x̃ = x̂ + β δt v̂ + (β δt)² F and v_(n+1) = (x_(n+1) − x̂)/(β δt) (second order: a
    // spin or a bounce is not damped away at the rate backward Euler's O(δt) error damps it);
    // else backward Euler, x̂ = x_n, v̂ = v_n, β = 1.
    const auto tStart = Clock::now();
    StepReport report;
    const Index n = mLat.size();
    ForceSamples fs;
    field.sample(mX, frame, ForceOrder::Value, fs);
    report.forcesSeconds = secondsSince(tStart);
    const bool bdf2 = mXBefore.size() == at(n) && mDtLast == dt;
    mBeta = bdf2 ? Real(2) / 3 : Real(1);
    const Real step = mBeta * dt;
    mXHat.resize(at(n));
    mXPred.resize(at(n));
    std::vector<Vec3> vHat(at(n));
    parallelFor(n, [&](Index p) {
        if (mPinned[at(p)]) {
            mXHat[at(p)] = mXPred[at(p)] = mPinnedPositions[at(p)];
            vHat[at(p)] = Vec3::Zero();
            return;
        }
        mXHat[at(p)] = bdf2 ? Vec3((4 * mX[at(p)] - mXBefore[at(p)]) / 3) : mX[at(p)];
        vHat[at(p)] = bdf2 ? Vec3((4 * mV[at(p)] - mVBefore[at(p)]) / 3) : mV[at(p)];
        mXPred[at(p)] = mXHat[at(p)] + step * vHat[at(p)] + step * step * fs.value[at(p)];
    });
    // The solve's first guess: in contact, the prediction with the last step's acceleration in
    // place of the forces' (a body at rest on the ground starts where it rests, not a step of
    // gravity into the ground); in flight, x̃ (exact for a free fall).
    mXGuess.clear();
    if (bdf2 && mFreeFlight == 0 && mDtLast > 0) {
        mXGuess.resize(at(n));
        parallelFor(n, [&](Index p) {
            const Vec3 a = (mV[at(p)] - mVBefore[at(p)]) / dt;
            mXGuess[at(p)] = mPinned[at(p)] ? mXPred[at(p)] : Vec3(mXHat[at(p)] + step * vHat[at(p)] + step * step * a);
        });
    }
    Vec3 momentum = Vec3::Zero();
    for (Index p = 0; p < n; ++p) momentum += mMass[at(p)] * (vHat[at(p)] + step * fs.value[at(p)]);
    mCPred = centreOfMass(mMass, mXPred);
    mVcPred = momentum / mTotalMass;
    mAPred = mA;
    mDtPred = dt;
    report.totalSeconds = secondsSince(tStart);
    mPredReport = report;
    mPredicted = true;
    return report;
}

StepReport DeformableBody::finishOne(const std::vector<Collider>& colliders) {
    std::vector<CellSolveMember> one{beginSolve(colliders)};
    solveTogether(one, {});
    return endSolve(one[0]);
}

CellSolveMember DeformableBody::beginSolve(const std::vector<Collider>& colliders) {
    if (mSet.solver != StepSolver::One || !mPredicted) throw std::logic_error("beginSolve: a predicted one-solve body only");
    mPredicted = false;
    mSolveStart = Clock::now();
    const Index n = mLat.size();
    const Real h = mLat.spacing;
    mSolveInertial = std::move(mXPred);
    mXPred.clear();
    mSolveColliders = colliders;
    const std::vector<Vec3>& inertial = mSolveInertial;

    // Another body's surface: this body keeps the share of the overlap at x̃ the other one takes
    // (Collider::share); the caller puts the pair's momentum right. A static collider holds the
    // points half a voxel outside it, where the surface the body renders lies.
    std::vector<std::vector<Real>>& allowed = mSolveAllowed;
    std::vector<Real>& margins = mSolveMargins;
    allowed.assign(colliders.size(), {});
    margins.assign(colliders.size(), 0);
    for (std::size_t c = 0; c < colliders.size(); ++c) {
        const Collider& col = colliders[c];
        if (!col.object) {
            margins[c] = Real(0.5) * h;
            continue;
        }
        allowed[c].assign(at(n), 0);
        parallelFor(n, [&](Index p) {
            Vec3 g;
            const Real phi = col.evaluate(inertial[at(p)], g), gn = g.norm();
            if (gn > 0 && phi < 0) allowed[c][at(p)] = (1 - col.share) * (-phi / gn);
        });
    }
    CellSolveSettings cs;
    cs.shearModulus = mShear;
    // The damping ζ of a body with shape memory is a Kelvin–Voigt viscosity, μ_v = 2 ζ μ / k: a
    // wobble at √k decays at ζ, faster modes faster, and a bounce on the ground (the centre
    // rising and falling on the squash of its contact) as much as a wobble in the air. Goo's ζ
    // decays the motion other than the rigid one (below).
    const bool memory = mSet.shapeStiffness > 0;
    cs.viscosity = mSet.density * mSet.viscosity + (memory ? 2 * mSet.damping * mShear / mSet.shapeStiffness : 0);
    cs.density = mSet.density;
    CellSolveMember m;
    m.solver = &mCellSolver;
    m.settings = cs;
    CellSolveInput& in = m.in;
    in.start = &mXHat;
    in.feasible = &mX;
    in.inertial = &inertial;
    in.dt = mBeta * mDtPred;
    in.restVolumes = &mRestVolumes;
    in.restStretch = mCellRest.empty() ? nullptr : &mCellRest;
    in.colliders = &mSolveColliders;
    in.allowedDepth = &allowed;
    in.margins = &margins;
    mSolveX = mXGuess.empty() ? inertial : mXGuess;
    m.x = &mSolveX;
    m.lambda = &mVolumeLambda;
    m.contact = &mContact;
    m.depth = &mContactDepth;
    return m;
}

StepReport DeformableBody::endSolve(const CellSolveMember& member) {
    const auto tStart = mSolveStart;
    StepReport report = mPredReport;
    const Index n = mLat.size();
    const Real h = mLat.spacing;
    const Real dt = mDtPred;
    const std::vector<Collider>& colliders = mSolveColliders;
    const std::vector<Vec3> inertial = std::move(mSolveInertial);
    std::vector<Vec3> xNew = std::move(mSolveX);
    mSolveInertial.clear();
    mSolveX.clear();
    const bool memory = mSet.shapeStiffness > 0;
    const CellSolveReport& sr = member.report;
    auto t = tStart;
    report.solveIterations = sr.iterations;
    report.solveConverged = sr.converged;
    report.reconstructSeconds = secondsSince(t);
    report.contacts = sr.contacts;
    for (Index p = 0; p < n && !report.staticContact; ++p) {
        if (!mContact[at(p)]) continue;
        for (const Collider& col : colliders) {
            Vec3 g;
            if (!col.object && col.evaluate(xNew[at(p)], g) < Real(0.5) * h + Real(1e-6) * h) report.staticContact = true;
        }
    }
    if (report.contacts == 0 && !mAnyPinned) keepMomenta(inertial, xNew);
    report.contactTruth = report.contacts;
    report.contactTruePositive = report.contacts;

    // The solve leaves each cell within its volume tolerance; the exact projection takes the rest
    // with the pins held (a correction of the order of that tolerance, which the contact margin
    // covers; holding the contact points as well left the cells of a pile, whose corners all
    // touched another body, with nothing to correct them: 0.75 off).
    t = Clock::now();
    if (mSet.projectVolume && mCells.size() > 0) {
        std::vector<unsigned char> held(at(n));
        parallelFor(n, [&](Index p) { held[at(p)] = mPinned[at(p)] ? 1 : 0; });
        VolumeProjectionSettings vs = volumeSettings();
        std::vector<Real> lambda;
        vs.multipliers = &lambda;
        const VolumeProjectionReport vr = projectVolumes(mCells, mRestVolumes, held, xNew, vs);
        report.volumeIterations = vr.iterations;
        report.volumeConverged = vr.converged;
    }
    report.maxPenetration = parallelReduce(
        n, Real(0),
        [&](Real& acc, Index p) {
            for (const Collider& col : colliders) {
                if (col.object) continue;
                Vec3 g;
                const Real phi = col.evaluate(xNew[at(p)], g), gn = g.norm();
                if (phi < 0 && gn > 0) acc = std::max(acc, -phi / gn);
            }
        },
        [](Real a, Real b) { return std::max(a, b); });
    report.volumeSeconds = secondsSince(t);

    // Velocities of the step taken; goo's damping ζ decays the motion other than the body's rigid
    // one (momentum and angular momentum kept), in the velocities only; a pinned body's, all of
    // it (without, a jelly hanging from a small pin swung on for seconds: its swing bends only
    // the cells at the pin).
    t = Clock::now();
    mXBefore = mX;
    mVBefore = mV;
    parallelFor(n, [&](Index p) { mV[at(p)] = (xNew[at(p)] - mXHat[at(p)]) / (mBeta * dt); });
    if (mSet.damping > 0 && !memory && !mAnyPinned) {
        const Vec3 c = centreOfMass(mMass, xNew);
        Vec3 momentum = Vec3::Zero(), angular = Vec3::Zero();
        Mat3 inertia = Mat3::Zero();
        for (Index p = 0; p < n; ++p) {
            const Real m = mMass[at(p)];
            const Vec3 r = xNew[at(p)] - c;
            momentum += m * mV[at(p)];
            angular += m * r.cross(mV[at(p)]);
            inertia += m * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
        }
        const Vec3 vc = momentum / mTotalMass;
        const Vec3 omega = inertia.determinant() > 0 ? Vec3(inertia.ldlt().solve(angular)) : Vec3(Vec3::Zero());
        const Real decay = std::exp(-mSet.damping * dt);
        parallelFor(n, [&](Index p) {
            const Vec3 rigid = vc + omega.cross(xNew[at(p)] - c);
            mV[at(p)] = rigid + decay * (mV[at(p)] - rigid);
        });
    } else if (mSet.damping > 0) {
        // pinned: the motion relative to the pins (at rest) decays, a swing as well as a wobble
        const Real decay = std::exp(-mSet.damping * dt);
        parallelFor(n, [&](Index p) { mV[at(p)] *= decay; });
    }
    // Centre and flex: the fit of the positions (the flex its SL(3) part), for the stats and the
    // reparametrisation.
    Vec3 c1;
    Mat3 A1;
    fitAffine(xNew, c1, A1);
    const Sl3Result r1 = projectToSL3Scale(A1);
    if (r1.ok) A1 = r1.matrix;
    // the centre's velocity is the points' momentum over the mass (with BDF2, (c1 − c)/δt is not)
    Vec3 momentum = Vec3::Zero();
    for (Index p = 0; p < n; ++p) momentum += mMass[at(p)] * mV[at(p)];
    mVc = momentum / mTotalMass;
    mAdot = (A1 - mA) / dt;
    mC = c1;
    mA = A1;
    mHalfStep = true;
    report.kineticEnergy = parallelReduce(
        n, Real(0), [&](Real& acc, Index p) { acc += Real(0.5) * mMass[at(p)] * mV[at(p)].squaredNorm(); },
        [](Real a, Real b) { return a + b; });
    mTangentPrev = mState.tangent;
    mHavePrev = true;
    mDtLast = dt;
    mFreeFlight = report.contacts > 0 ? Real(0) : mFreeFlight + dt;
    mX.swap(xNew);
    // δΓ, the notes' connection change of a step, is the change the step made.
    const std::array<std::vector<Mat3>, 3> gammaOld = mState.christoffel;
    computeGeometricState(mLat, mX, mState, BoundaryStencils::Realisable);
    for (std::size_t c = 0; c < 3; ++c)
        parallelFor(n, [&](Index p) { mDGamma[c][at(p)] = mState.christoffel[c][at(p)] - gammaOld[c][at(p)]; });
    report.sumDeltaGamma2 = sumDeltaGamma2();
    if (!mCellRest.empty()) yieldCells();
    report.stateSeconds = secondsSince(t);
    volumeFigures(report.maxCellVolumeError, report.totalVolumeDrift, report.invertedCells);
    if (report.invertedCells > 0 && report.fault.empty()) {
        report.fault = std::to_string(report.invertedCells) +
                       " lattice cells inverted (the shape folded): use more substeps or viscosity";
        report.faultKind = FaultKind::CellsInverted;
    }
    for (Index p = 0; p < n && report.fault.empty(); ++p)
        if (!mX[at(p)].allFinite()) {
            report.fault = "one solve: a position became non-finite";
            report.faultKind = FaultKind::NonFinite;
        }
    report.totalSeconds = mPredReport.totalSeconds + secondsSince(tStart);
    return report;
}

void DeformableBody::keepMomenta(const std::vector<Vec3>& inertial, std::vector<Vec3>& x) const {
    // The minimiser of a translation- and rotation-invariant energy with nothing outside the body
    // has Σ m (x − x̃) = 0 and Σ m (x − c) × (x − x̃) = 0; the solve stops within its tolerance of
    // it, so the rigid translation and the small rigid turn about c that restore both are applied
    // (neither changes a cell).
    const Index n = mLat.size();
    Vec3 shift = Vec3::Zero();
    for (Index p = 0; p < n; ++p) shift -= mMass[at(p)] * (x[at(p)] - inertial[at(p)]);
    shift /= mTotalMass;
    for (Index p = 0; p < n; ++p) x[at(p)] += shift;
    const Vec3 c = centreOfMass(mMass, x);
    Vec3 torque = Vec3::Zero();
    Mat3 inertia = Mat3::Zero();
    for (Index p = 0; p < n; ++p) {
        const Vec3 r = x[at(p)] - c;
        torque += mMass[at(p)] * r.cross(x[at(p)] - inertial[at(p)]);
        // a turn δθ about c changes the residual by −Σ m (δθ × r) × s, s = x̃ − c: by
        // −Σ m (r sᵀ − (r·s) 1) δθ, so δθ = −(Σ m ((r·s) 1 − r sᵀ))⁻¹ τ
        const Vec3 s = inertial[at(p)] - c;
        inertia += mMass[at(p)] * (r.dot(s) * Mat3::Identity() - r * s.transpose());
    }
    if (!(std::abs(inertia.determinant()) > 0)) return;
    const Vec3 turn = -inertia.lu().solve(torque);
    const Real angle = turn.norm();
    if (!(angle > 0) || !(angle < Real(0.1))) return;
    const Mat3 R = Eigen::AngleAxis<Real>(angle, turn / angle).toRotationMatrix();
    for (Index p = 0; p < n; ++p) x[at(p)] = c + R * (x[at(p)] - c);
}

void DeformableBody::yieldCells() {
    // Each cell's elastic stretch U = sym(Rᵀ F P⁻¹), R its polar rotation; where the deviatoric
    // part of its logarithmic strain is longer than the yield, P takes the excess (the radial
    // return of the flex's rule, per cell). P stays a volume-keeping stretch, within
    // kMaxRestStretch of the cube along every axis.
    const Real yield = mSet.yieldStrain, h = mLat.spacing;
    parallelFor(mCells.size(), [&](Index c) {
        std::array<Vec3, 8> corners;
        for (std::size_t k = 0; k < 8; ++k) corners[k] = mX[at(mCells.corners[at(c)][k])];
        const Mat3 Fe = CellSolver::centreFrame(corners, h) * mCellRest[at(c)].inverse();
        const Mat3 E = polarRotationOf(Fe).transpose() * Fe;
        Eigen::SelfAdjointEigenSolver<Mat3> es;
        es.computeDirect(Real(0.5) * (E + E.transpose()));
        const Vec3 l = es.eigenvalues();
        if (!(l.minCoeff() > 0)) return;
        Vec3 strain = l.array().log().matrix();
        strain -= Vec3::Constant(strain.sum() / 3);
        const Real norm = strain.norm();
        if (!(norm > yield)) return;
        const Vec3 excess = (1 - yield / norm) * strain;
        Mat3 P = es.eigenvectors() * excess.array().exp().matrix().asDiagonal() * es.eigenvectors().transpose() *
                 mCellRest[at(c)];
        Eigen::SelfAdjointEigenSolver<Mat3> ps;
        ps.computeDirect(P.transpose() * P);
        const Vec3 stretch = ps.eigenvalues().cwiseSqrt().cwiseMax(1 / kMaxRestStretch).cwiseMin(kMaxRestStretch);
        P = ps.eigenvectors() * stretch.asDiagonal() * ps.eigenvectors().transpose();
        mCellRest[at(c)] = P / std::cbrt(P.determinant());
    });
}

}  // namespace dgv
