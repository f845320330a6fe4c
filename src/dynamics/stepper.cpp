// The dynamics step (stepper.hpp; docs/math.md, "The dynamics step").

#include "dynamics/stepper.hpp"

#include "base/check.hpp"
#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "deform/connection_delta.hpp"
#include "deform/sl3.hpp"
#include "dynamics/body.hpp"
#include "solve/holonomy.hpp"
#include "solve/reconstruct.hpp"
#include "solve/sparse_solve.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace dgv {

/// The reconstruction's spanning tree (from the solver's fixed points, the roots of both frame
/// integrations) and its work arrays, kept for the body's life.
struct ReconstructWork {
    SpanningTree tree;
    std::array<std::vector<Mat3>, 3> gammaBar;  ///< Γ + δΓ
    ConnectionChangeWorkspace change;
    std::vector<Mat3> frames;
    std::array<std::vector<Vec3>, 3> forward;
};

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Rotation by angle θ about unit axis k (Rodrigues), exactly orthogonal to round-off.
Mat3 rotation(const Vec3& axis, Real angle) {
    Mat3 K;
    K << 0, -axis.z(), axis.y(), axis.z(), 0, -axis.x(), -axis.y(), axis.x(), 0;
    return Mat3::Identity() + std::sin(angle) * K + (1 - std::cos(angle)) * K * K;
}

/// The rotation part of a near-identity step matrix S = 1 + G: the rotation whose skew part
/// equals skew(G) (exact when S is a rotation of angle < 90°), returned as axis and angle.
void stepRotation(const Mat3& G, Vec3& axis, Real& angle) {
    const Vec3 w(G(2, 1) - G(1, 2), G(0, 2) - G(2, 0), G(1, 0) - G(0, 1));
    const Real s = Real(0.5) * w.norm();  // sin θ
    if (!(s > 1e-300)) {
        axis = Vec3::UnitX();
        angle = 0;
        return;
    }
    axis = w / (2 * s);
    angle = std::asin(std::min(s, Real(1)));
}


/// The part of a change δA of the affine part that keeps det A to first order, in the kinetic
/// metric tr(δA S δAᵀ): δA − (⟨A⁻ᵀ, δA⟩ / ⟨A⁻ᵀ, A⁻ᵀS⁻¹⟩) A⁻ᵀS⁻¹ (tr(A⁻¹δA) = ⟨A⁻ᵀ, δA⟩).
Mat3 volumeKeeping(const Mat3& dA, const Mat3& a, const Mat3& secondMomentInv) {
    const Mat3 ait = a.inverse().transpose();
    const Mat3 wInvT = ait * secondMomentInv;
    return dA - ((ait.array() * dA.array()).sum() / (ait.array() * wInvT.array()).sum()) * wInvT;
}

/// det(M + μ G) = 1 by Newton's method on μ (SHAKE): the flex's step back onto SL(3) along
/// G = A⁻ᵀS⁻¹, the gradient of det at the start of the step A in the kinetic metric, which is the
/// direction of the constraint's reaction and exerts no torque about the body's centre. (The
/// nearest SL(3) matrix, taken before, corrects along the END's A⁻ᵀ: a torque against the spin
/// of a sagging body, which lost 12 % of its angular momentum in 3 s; docs/math.md.) Falls back
/// to projectToSL3 if Newton does not settle.
Sl3Result projectToSL3Along(const Mat3& M, const Mat3& G) {
    Real mu = 0;
    for (int it = 0; it < 8; ++it) {
        const Mat3 X = M + mu * G;
        const Real d = X.determinant();
        if (!(d > 0)) break;
        if (std::abs(d - 1) <= Real(1e-15) || it == 7) {
            if (std::abs(d - 1) > Real(1e-14)) break;
            Sl3Result r;
            r.matrix = X;
            r.ok = true;
            r.iterations = it;
            return r;
        }
        const Real slope = d * (X.inverse() * G).trace();
        if (!(std::abs(slope) > 0) || !std::isfinite(slope)) break;
        mu -= (d - 1) / slope;
    }
    return projectToSL3(M);
}

}  // namespace

// The affine contact response (stepper.hpp).
void affineContactCorrection(const std::vector<AffineContact>& contacts, const Mat3& a, const Mat3& secondMoment,
                             Vec3& dc, Mat3& dA, Real viscousMoment) {
    const Mat3 sInv = secondMoment.inverse();
    std::vector<Vec3> gc(contacts.size());
    std::vector<Mat3> gA(contacts.size());
    std::vector<Real> invMass(contacts.size()), lambda(contacts.size(), 0);
    // With viscosity the flex's metric is tr(δA S δAᵀ) + c |sym(δA A⁻¹)|² (c = 2ν δt: the
    // implicit viscous stress resists a strain as added inertia; a turn not at all), a 9 × 9
    // form on vec(δA) (column-major); its inverse maps an impulse's n X̃ᵀ to δA.
    using Mat9 = Eigen::Matrix<Real, 9, 9>;
    using Vec9 = Eigen::Matrix<Real, 9, 1>;
    Eigen::LDLT<Mat9> metric;
    Mat3 volumeDir = Mat3::Zero();  // the metric's inverse applied to A⁻ᵀ (det's gradient)
    const bool viscous = viscousMoment > 0;
    const Mat3 ait = a.inverse().transpose();
    auto applyInverse = [&](const Mat3& g) {
        const Vec9 v = metric.solve(Eigen::Map<const Vec9>(g.data()));
        return Mat3(Eigen::Map<const Mat3>(v.data()));
    };
    if (viscous) {
        const Mat3 ai = a.inverse();
        Eigen::Matrix<Real, 9, 9> P;  // vec(δA) -> vec(sym(δA A⁻¹))
        for (int j = 0; j < 9; ++j) {
            Mat3 e = Mat3::Zero();
            e.data()[j] = 1;
            const Mat3 l = e * ai;
            const Mat3 sym = Real(0.5) * (l + l.transpose());
            P.col(j) = Eigen::Map<const Vec9>(sym.data());
        }
        Mat9 kinetic = Mat9::Zero();  // tr(δA S δAᵀ) = vec(δA)ᵀ (S ⊗ 1) vec(δA)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) kinetic.block<3, 3>(3 * r, 3 * c) = secondMoment(r, c) * Mat3::Identity();
        metric.compute(kinetic + viscousMoment * P.transpose() * P);
        volumeDir = applyInverse(ait);
    }
    for (std::size_t k = 0; k < contacts.size(); ++k) {
        const AffineContact& c = contacts[k];
        gc[k] = c.normal;
        if (viscous) {
            // The part that keeps det A to first order, in the same metric (volumeKeeping's).
            const Mat3 g = applyInverse(c.normal * c.rest.transpose());
            gA[k] = g - ((ait.array() * g.array()).sum() / (ait.array() * volumeDir.array()).sum()) * volumeDir;
        } else {
            gA[k] = volumeKeeping(c.normal * c.rest.transpose() * sInv, a, sInv);
        }
        const Real m = c.normal.dot(gc[k] + gA[k] * c.rest);
        invMass[k] = m > 0 ? 1 / m : 0;
    }
    dc.setZero();
    dA.setZero();
    Real deepest = 0;
    for (const AffineContact& c : contacts) deepest = std::max(deepest, c.depth);
    for (int sweep = 0; sweep < 64; ++sweep) {
        Real worst = 0;
        for (std::size_t k = 0; k < contacts.size(); ++k) {
            const AffineContact& c = contacts[k];
            const Real r = c.depth - c.normal.dot(dc + dA * c.rest);
            const Real next = std::max(Real(0), lambda[k] + r * invMass[k]);
            const Real d = next - lambda[k];
            lambda[k] = next;
            dc += d * gc[k];
            dA += d * gA[k];
            if (next > 0 || r > 0) worst = std::max(worst, std::abs(r));
        }
        if (worst <= 1e-3 * deepest) break;
    }
}

bool twistUpdate(const Mat3& F, const Mat3& Fi, const Mat3& step, const std::array<Mat3, 3>& hessian,
                 const PointConnection& gamma, Real dt, const DynamicsSettings& settings, PointConnection& dGamma) {
    const Real dt2 = dt * dt;
    const Real decay = settings.damping > 0 ? std::exp(-settings.damping * dt) : Real(1);
    // exp(-δt W) = F⁻¹ exp(-2 δt L) F with the frames' step S = exp(δt L) = F F_prev⁻¹.
    Mat3 E;
    if (settings.twistStretch == TwistStretch::Full) {
        const Mat3 si = step.inverse();
        E = Fi * si * si * F;
    } else {
        const Mat3 G = step - Mat3::Identity();
        Mat3 world = Mat3::Identity();
        if (settings.twistRotation) {
            Vec3 axis;
            Real angle = 0;
            stepRotation(G, axis, angle);
            world = rotation(axis, -2 * angle);
        }
        if (settings.twistStretch == TwistStretch::DampOnly) {
            // stretch eigenvalues d > 0 damp by (1 + d)^-2 ≈ exp(-2 δt D); d < 0 would amplify: dropped
            Eigen::SelfAdjointEigenSolver<Mat3> es;
            es.computeDirect(Real(0.5) * (G + G.transpose()));
            const Vec3 d = es.eigenvalues();
            if (d.maxCoeff() > 0) {
                Vec3 f;
                for (int k = 0; k < 3; ++k) f[k] = d[k] > 0 ? Real(1) / ((1 + d[k]) * (1 + d[k])) : Real(1);
                world = world * es.eigenvectors() * f.asDiagonal() * es.eigenvectors().transpose();
            }
        }
        E = Fi.lazyProduct(world).lazyProduct(F);
    }
    // ∇∇F_i x_b for each i and b once (the loop over the six pairs a <= b below asked for x_b
    // b + 1 times); lazyProduct: the products inline, the same arithmetic as Eigen's call.
    const std::array<Mat3, 3> hx = {hessian[0].lazyProduct(F), hessian[1].lazyProduct(F), hessian[2].lazyProduct(F)};
    PointConnection next;
    for (Mat3& m : next) m.setZero();
    for (int a = 0; a < 3; ++a)
        for (int b = a; b < 3; ++b) {
            const Vec3 xa = F.col(a);
            // (x_a x_b) : ∇∇F, component i = x_aᵀ (∇∇F_i) x_b
            const Vec3 hab(xa.dot(hx[0].col(b)), xa.dot(hx[1].col(b)), xa.dot(hx[2].col(b)));
            Vec3 old;
            for (std::size_t d = 0; d < 3; ++d) old[static_cast<Index>(d)] = dGamma[d](a, b);
            const Vec3 rotated = E.lazyProduct(old);
            for (std::size_t c = 0; c < 3; ++c) {
                Real v = rotated[static_cast<Index>(c)] + dt2 * hab.dot(Fi.row(static_cast<Index>(c)).transpose());
                if (settings.shapeStiffness > 0) v -= dt2 * settings.shapeStiffness * gamma[c](a, b);
                v *= decay;
                next[c](a, b) = v;
                next[c](b, a) = v;
            }
        }
    if (settings.traceFree) projectTraceFree(next);
    const Real cap2 = settings.maxDeltaGamma * settings.maxDeltaGamma;
    Real norm2 = 0;
    for (const Mat3& m : next) norm2 += m.squaredNorm();
    bool limited = false;
    if (norm2 > cap2) {
        const Real s = std::sqrt(cap2 / norm2);
        for (Mat3& m : next) m *= s;
        limited = true;
    }
    dGamma = next;
    return limited;
}

int viscousTwistStep(const Lattice& lat, Real alpha, std::array<std::vector<Mat3>, 3>& dGamma) {
    const Index n = lat.size();
    if (!(alpha > 0) || n == 0) return 0;
    using Vec27 = Eigen::Matrix<Real, 27, 1>;
    auto get = [&](Index p) {
        Vec27 v;
        for (std::size_t c = 0; c < 3; ++c)
            v.segment<9>(9 * static_cast<Index>(c)) =
                Eigen::Map<const Eigen::Matrix<Real, 9, 1>>(dGamma[c][at(p)].data());
        return v;
    };
    std::vector<Vec27> b(at(n)), x(at(n)), r(at(n)), z(at(n)), d(at(n)), q(at(n));
    std::vector<Real> diag(at(n));
    parallelFor(n, [&](Index p) {
        int k = 0;
        for (const Index nb : lat.neighbours[at(p)]) k += nb != kNoPoint ? 1 : 0;
        diag[at(p)] = 1 + alpha * k;
        b[at(p)] = get(p);
    });
    auto apply = [&](const std::vector<Vec27>& in, std::vector<Vec27>& out) {
        parallelFor(n, [&](Index p) {
            Vec27 acc = diag[at(p)] * in[at(p)];
            for (const Index nb : lat.neighbours[at(p)])
                if (nb != kNoPoint) acc -= alpha * in[at(nb)];
            out[at(p)] = acc;
        });
    };
    auto dot = [&](const std::vector<Vec27>& u, const std::vector<Vec27>& v) {
        return parallelReduce(
            n, Real(0), [&](Real& acc, Index p) { acc += u[at(p)].dot(v[at(p)]); },
            [](Real a, Real c) { return a + c; });
    };
    // x0 = D⁻¹ b (the Jacobi step): r = b − A x0.
    parallelFor(n, [&](Index p) { x[at(p)] = b[at(p)] / diag[at(p)]; });
    apply(x, q);
    parallelFor(n, [&](Index p) {
        r[at(p)] = b[at(p)] - q[at(p)];
        z[at(p)] = r[at(p)] / diag[at(p)];
        d[at(p)] = z[at(p)];
    });
    const Real bb = dot(b, b);
    Real rz = dot(r, z);
    int it = 0;
    constexpr int kMaxIterations = 200;
    while (it < kMaxIterations && dot(r, r) > 1e-16 * bb) {
        apply(d, q);
        const Real step = rz / dot(d, q);
        parallelFor(n, [&](Index p) {
            x[at(p)] += step * d[at(p)];
            r[at(p)] -= step * q[at(p)];
            z[at(p)] = r[at(p)] / diag[at(p)];
        });
        const Real rzNew = dot(r, z);
        const Real beta = rzNew / rz;
        rz = rzNew;
        parallelFor(n, [&](Index p) { d[at(p)] = z[at(p)] + beta * d[at(p)]; });
        ++it;
    }
    parallelFor(n, [&](Index p) {
        for (std::size_t c = 0; c < 3; ++c)
            Eigen::Map<Eigen::Matrix<Real, 9, 1>>(dGamma[c][at(p)].data()) =
                x[at(p)].segment<9>(9 * static_cast<Index>(c));
    });
    return it;
}

std::vector<std::string> DynamicsSettings::validate() const {
    std::vector<std::string> out;
    auto positive = [&](Real v, const char* name) {
        if (!(v > 0) || !std::isfinite(v))
            out.push_back(std::string(name) + ": expected a positive number, got " + std::to_string(v));
    };
    auto nonNegative = [&](Real v, const char* name) {
        if (!(v >= 0) || !std::isfinite(v))
            out.push_back(std::string(name) + ": expected a number >= 0, got " + std::to_string(v));
    };
    positive(density, "density");
    nonNegative(damping, "damping");
    nonNegative(viscosity, "viscosity");
    nonNegative(shapeStiffness, "stiffness");
    nonNegative(yieldStrain, "yield");
    if (yieldStrain > 0 && !(shapeStiffness > 0))
        out.push_back("yield: needs a stiffness > 0 (goo has no rest shape to yield; it flows at any strain)");
    positive(maxDeltaGamma, "max_delta_gamma");
    positive(volumeTolerance, "volume_tolerance");
    positive(reconstructTolerance, "reconstruct_tolerance");
    positive(maxLoadStrain, "max_load_strain");
    positive(maxLandingStrain, "max_landing_strain");
    if (frameSweeps < 0) out.push_back("frame_sweeps: expected a count >= 0, got " + std::to_string(frameSweeps));
    nonNegative(frameSweepsAfter, "frame_sweeps_after");
    return out;
}

DeformableBody::DeformableBody(const Lattice& lattice, std::vector<Vec3> positions, const DynamicsSettings& settings,
                               std::vector<unsigned char> pinned)
    : mLat(lattice), mSet(settings), mPinned(std::move(pinned)), mX(std::move(positions)) {
    const Index n = mLat.size();
    DGV_CHECK(n > 0);
    DGV_CHECK_EQ(static_cast<Index>(mX.size()), n);
    if (mPinned.empty()) mPinned.assign(at(n), 0);
    DGV_CHECK_EQ(static_cast<Index>(mPinned.size()), n);
    const std::vector<std::string> problems = mSet.validate();
    if (!problems.empty()) throw InputError("", "material", problems.front());
    mAnyPinned = std::any_of(mPinned.begin(), mPinned.end(), [](unsigned char c) { return c != 0; });
    mPinnedPositions = mX;

    mCells = buildCells(mLat);
    mRestVolumes = cellVolumes(mCells, mX);
    mRestTotal = 0;
    for (Real v : mRestVolumes) mRestTotal += v;
    mMass = pointMasses(mLat, mSet.density, MassRule::CellShare);
    mTotalMass = 0;
    for (Real m : mMass) mTotalMass += m;
    if (!(mTotalMass > 0)) {  // no complete cell (a one-voxel-thin object): a voxel each
        mMass = pointMasses(mLat, mSet.density, MassRule::Voxel);
        mTotalMass = mSet.density * std::pow(mLat.spacing, 3) * static_cast<Real>(n);
    }
    // The volume projection's metric: the inverse masses relative to the largest (a point in
    // no cell has no mass and no volume gradient; any weight serves).
    const Real heaviest = *std::max_element(mMass.begin(), mMass.end());
    mVolumeWeight.resize(at(n));
    for (Index p = 0; p < n; ++p) mVolumeWeight[at(p)] = mMass[at(p)] > 0 ? heaviest / mMass[at(p)] : Real(1);
    mC = centreOfMass(mMass, mX);
    mRestRel.resize(at(n));
    Mat3 S0 = Mat3::Zero();
    for (Index p = 0; p < n; ++p) {
        mRestRel[at(p)] = mX[at(p)] - mC;
        S0 += mMass[at(p)] * mRestRel[at(p)] * mRestRel[at(p)].transpose();
    }
    S0 /= mTotalMass;
    // A flat or thin body has a (near) singular second moment: give each point its voxel's
    // own moment h²/12 along the missing axes only then, so the fit stays exact otherwise.
    const Real h2 = mLat.spacing * mLat.spacing;
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(S0);
    if (eig.eigenvalues().minCoeff() < 1e-6 * h2) S0 += (h2 / 12) * Mat3::Identity();
    mS0inv = S0.inverse();

    computeGeometricState(mLat, mX, mState, BoundaryStencils::Realisable);
    for (auto& g : mDGamma) g.assign(at(n), Mat3::Zero());
    if (mSet.yieldStrain > 0) {
        // Plasticity: the rest connection starts at the lattice's (0, as the shape memory's);
        // its yield is the strain across the body's radius of gyration, in lattice steps.
        for (auto& g : mPlasticGamma) g.assign(at(n), Mat3::Zero());
        mGammaYield = mSet.yieldStrain / (std::sqrt(S0.trace()) / mLat.spacing);
    }
    mContact.assign(at(n), 0);
    mContactDepth.assign(at(n), 0);
    mV.assign(at(n), Vec3::Zero());

    // The reconstruction's reference: pinned points, plus the point nearest the centre of each
    // component that has no pinned point.
    std::vector<Mat3> frames(at(n));
    for (Index p = 0; p < n; ++p)
        frames[at(p)] << mState.tangent[0][at(p)], mState.tangent[1][at(p)], mState.tangent[2][at(p)];
    std::vector<unsigned char> fixed = mPinned;
    std::vector<char> componentPinned(static_cast<std::size_t>(mLat.components), 0);
    for (Index p = 0; p < n; ++p)
        if (mPinned[at(p)]) componentPinned[static_cast<std::size_t>(mLat.component[at(p)])] = 1;
    for (const Pin& pin : centrePins(mLat, mX, frames))
        if (!componentPinned[static_cast<std::size_t>(mLat.component[at(pin.point)])]) fixed[at(pin.point)] = 1;
    for (Index p = 0; p < n; ++p)
        if (fixed[at(p)]) mSolverFixed.push_back(p);
    mSolver = std::make_unique<PoissonSolver>(mLat, fixed);
    if (mSet.solver == StepSolver::One) {
        mCellSolver = CellSolver(mLat, mCells, mMass, mPinned);
        mShear = mSet.density * mSet.modulusPerStiffness * mSet.shapeStiffness * (S0.trace() / 3);
        if (mSet.yieldStrain > 0) mCellRest.assign(at(mCells.size()), Mat3::Identity());
    }
    if (mAnyPinned && mSet.pinnedLoad && mSet.solver == StepSolver::Chain)
        mLoad = computeLoadModes(mLat, mX, mPinned, mCells, mRestVolumes, mMass, *mSolver);
    mRecWork = std::make_unique<ReconstructWork>();
    mRecWork->tree = spanningTree(mLat, fixed);
    mDisplacement.assign(at(n), Vec3::Zero());
    mDisplacementPrev.assign(at(n), Vec3::Zero());
}

DeformableBody::~DeformableBody() = default;

void DeformableBody::setAffineVelocity(const Vec3& velocity, const Mat3& gradient) {
    mVc = velocity;
    mAdot = gradient * mA;
    mHalfStep = false;
    mHavePrev = false;
    for (Index p = 0; p < mLat.size(); ++p)
        mV[at(p)] = mPinned[at(p)] ? Vec3(Vec3::Zero()) : Vec3(velocity + gradient * (mX[at(p)] - mC));
}

void DeformableBody::shiftVelocity(const Vec3& dv) {
    mVc += dv;
    parallelFor(mLat.size(), [&](Index p) { mV[at(p)] += dv; });
}

void DeformableBody::setRigidVelocity(const Vec3& velocity, const Vec3& angularVelocity) {
    Mat3 W;
    W << 0, -angularVelocity.z(), angularVelocity.y(), angularVelocity.z(), 0, -angularVelocity.x(),
        -angularVelocity.y(), angularVelocity.x(), 0;
    setAffineVelocity(velocity, W);
}

void DeformableBody::viscousFlexKick(Real kick) {
    // The viscous stress on the affine motion (docs/math.md, "Viscosity: the viscous stress at every scale"): a
    // straining flow v = D x (D = sym(Ȧ A⁻¹)) dissipates 2 μ V |D|² = 2 ν M |D|²; as a Rayleigh dissipation in the
    // flex's coordinates its force is Ä = −2ν D A⁻ᵀ S⁻¹ (S the rest second moment per unit mass), whose torque skew(D)
    // is zero: angular momentum is kept exactly. Implicit over the kick, with L = Ȧ A⁻¹ the unknown: L + c sym(L) B⁻¹ =
    // L₀ (c = 2ν kick, B = A S Aᵀ the second moment now). Its symmetric part D + (c/2)(D B⁻¹ + B⁻¹ D) = sym(L₀) is
    // diagonal in B's eigenbasis (D'_ij / (1 + (c/2)(1/λ_i + 1/λ_j))), and the spin follows from the skew part. For a
    // ball at rest (B = s·1) the strain rate decays by 1/(1 + 2ν kick/s) a kick.
    const Mat3 invA = mA.inverse();
    const Mat3 L0 = mAdot * invA;
    const Mat3 B = mA * mS0inv.inverse() * mA.transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> es;
    es.computeDirect(Real(0.5) * (B + B.transpose()));
    const Vec3 lambda = es.eigenvalues();
    if (!(lambda.minCoeff() > 0)) return;
    const Mat3& Q = es.eigenvectors();
    const Real c = 2 * mSet.viscosity * kick;
    Mat3 D = Q.transpose() * (Real(0.5) * (L0 + L0.transpose())) * Q;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) D(i, j) /= 1 + Real(0.5) * c * (1 / lambda[i] + 1 / lambda[j]);
    D = Q * D * Q.transpose();
    const Mat3 Binv = Q * lambda.cwiseInverse().asDiagonal() * Q.transpose();
    const Mat3 omega = Real(0.5) * (L0 - L0.transpose()) - Real(0.5) * c * (D * Binv - Binv * D);
    mAdot = (D + omega) * mA;
}

void DeformableBody::fitAffine(const std::vector<Vec3>& x, Vec3& centre, Mat3& affine) const {
    centre = centreOfMass(mMass, x);
    using Acc = Eigen::Matrix<Real, 9, 1>;
    const Acc s = parallelReduce(
        mLat.size(), Acc(Acc::Zero()),
        [&](Acc& acc, Index p) {
            const Mat3 m = mMass[at(p)] * (x[at(p)] - centre) * mRestRel[at(p)].transpose();
            acc += Eigen::Map<const Acc>(m.data());
        },
        [](const Acc& a, const Acc& b) { return Acc(a + b); });
    affine = Eigen::Map<const Mat3>(s.data()) / mTotalMass * mS0inv;
}

void DeformableBody::yieldRestShape() {
    const Real yield = mSet.yieldStrain;
    // Flex: the elastic part A P⁻¹ = R U; where its logarithmic strain log U (trace-free, as
    // det = 1) is longer than the yield, P takes the excess: P ← exp(ε − ε_y) P along U's axes,
    // ε_y = ε · yield/|ε| (the radial return of plasticity).
    const Mat3 elastic = mA * mPlasticFlex.inverse();
    Eigen::SelfAdjointEigenSolver<Mat3> es;
    es.computeDirect(elastic.transpose() * elastic);
    const Vec3 lambda = es.eigenvalues();
    if (lambda.minCoeff() > 0) {
        const Vec3 strain = Real(0.5) * lambda.array().log().matrix();
        const Real norm = strain.norm();
        if (norm > yield) {
            const Vec3 excess = (1 - yield / norm) * strain;
            Mat3 P = es.eigenvectors() * excess.array().exp().matrix().asDiagonal() * es.eigenvectors().transpose() *
                     mPlasticFlex;
            P /= std::cbrt(P.determinant());  // det 1 to rounding
            mPlasticFlex = P;
        }
    }
    // Twist: Γ_p takes the part of Γ − Γ_p beyond the yield (Frobenius norm over the 27
    // components, per lattice step).
    const Real tau = mGammaYield;
    parallelFor(mLat.size(), [&](Index p) {
        const std::size_t i = at(p);
        Real norm2 = 0;
        for (std::size_t c = 0; c < 3; ++c) norm2 += (mState.christoffel[c][i] - mPlasticGamma[c][i]).squaredNorm();
        if (!(norm2 > tau * tau)) return;
        const Real f = 1 - tau / std::sqrt(norm2);
        for (std::size_t c = 0; c < 3; ++c) mPlasticGamma[c][i] += f * (mState.christoffel[c][i] - mPlasticGamma[c][i]);
    });
}

void DeformableBody::rescaleStep(Real ratio) {
    // δΓ and the twist displacements (the warm start) are changes per step: ∝ the step's length
    // at the same rate. The frames' last step F F_prev⁻¹ = exp(δt L) becomes exp(r δt L) to first
    // order: F_prev ← F − r (F − F_prev).
    for (Real& l : mVolumeLambda) l *= ratio;  // the volume correction a step: ∝ its length too (measured)
    for (Real& l : mVolumeLambdaPrev) l *= ratio;
    parallelFor(mLat.size(), [&](Index p) {
        const std::size_t i = at(p);
        for (auto& g : mDGamma) g[i] *= ratio;
        mDisplacement[i] *= ratio;
        mDisplacementPrev[i] *= ratio;
        if (mHavePrev)
            for (std::size_t a = 0; a < 3; ++a)
                mTangentPrev[a][i] = mState.tangent[a][i] - ratio * (mState.tangent[a][i] - mTangentPrev[a][i]);
    });
}

Real DeformableBody::sumDeltaGamma2() const {
    return parallelReduce(
        mLat.size(), Real(0),
        [&](Real& acc, Index p) {
            for (const auto& g : mDGamma) acc += g[at(p)].squaredNorm();
        },
        [](Real a, Real b) { return a + b; });
}

void DeformableBody::volumeFigures(Real& maxCellError, Real& totalDrift, Index& inverted) const {
    const std::vector<Real> v = cellVolumes(mCells, mX);
    maxCellError = 0;
    inverted = 0;
    Real total = 0;
    for (std::size_t c = 0; c < v.size(); ++c) {
        maxCellError = std::max(maxCellError, std::abs(v[c] / mRestVolumes[c] - 1));
        if (!(v[c] > 0)) ++inverted;
        total += v[c];
    }
    totalDrift = mRestTotal > 0 ? total / mRestTotal - 1 : 0;
}

StepReport DeformableBody::step(const ForceField& field, Real frame, Real dt, const std::vector<Collider>& colliders) {
    StepReport r = predict(field, frame, dt);
    if (!mPredicted) return r;
    return finish(colliders);
}

/// Stage 2 of the chain's prediction: body and flex (Störmer-Verlet; the flex projected onto
/// SL(3)), driven by the force's moments and the shape memory.
DeformableBody::BodyFlexStep DeformableBody::predictBodyAndFlex(const ForceSamples& fs, Real dt, StepReport& report) {
    const Index n = mLat.size();
    BodyFlexStep r;
    r.L0 = mAdot * mA.inverse();  // the affine velocity gradient before the step
    const Mat3& L0 = r.L0;
    // Σ m F, the first moment Σ m F X̃ᵀ (the flex's drive, and a pinned body's load), and with
    // FlexDrive::Gradient Σ m ∇F.
    using Acc = Eigen::Matrix<Real, 21, 1>;
    const bool byGradient = mSet.flexDrive != FlexDrive::FirstMoment;
    const Acc mom = parallelReduce(
        n, Acc(Acc::Zero()),
        [&](Acc& acc, Index p) {
            const Real m = mMass[at(p)];
            const Vec3& F = fs.value[at(p)];
            acc.head<3>() += m * F;
            const Mat3 M = m * F * mRestRel[at(p)].transpose();
            acc.segment<9>(3) += Eigen::Map<const Eigen::Matrix<Real, 9, 1>>(M.data());
            if (byGradient) {
                const Mat3 G = m * fs.gradient[at(p)];
                acc.tail<9>() += Eigen::Map<const Eigen::Matrix<Real, 9, 1>>(G.data());
            }
        },
        [](const Acc& a, const Acc& b) { return Acc(a + b); });
    r.accel = mom.head<3>() / mTotalMass;
    const Vec3& accel = r.accel;
    r.firstMoment = Eigen::Map<const Mat3>(mom.segment<9>(3).data()) / mTotalMass;
    const Mat3& firstMoment = r.firstMoment;
    const Mat3 moment = byGradient ? Mat3(Eigen::Map<const Mat3>(mom.tail<9>().data()) / mTotalMass) : firstMoment;
    Mat3 flexAccel = mSet.flexDrive == FlexDrive::FirstMoment ? Mat3(moment * mS0inv) : Mat3(moment * mA);
    if (mSet.shapeStiffness > 0) {
        if (mSet.yieldStrain > 0) {
            // The memory's energy k/2 |A P⁻¹ − R|² of the elastic part A P⁻¹ (R its polar
            // rotation; P the rest stretch): its gradient k (A P⁻¹ − R) P⁻ᵀ. A flattened rest
            // shape (small P_yy) resists a further squash more (docs/math.md, "Plasticity").
            const Mat3 Pinv = mPlasticFlex.inverse();
            const Mat3 elastic = mA * Pinv;
            flexAccel -= mSet.shapeStiffness * (elastic - polarRotationOf(elastic)) * Pinv.transpose();
        } else {
            flexAccel -= mSet.shapeStiffness * (mA - polarRotationOf(mA));
        }
    }
    if (mSet.damping > 0) flexAccel -= mSet.damping * Real(0.5) * (L0 + L0.transpose()) * mA;
    // Leapfrog: the half-step velocities kick by the mean of the last step and this one (dt
    // exactly when they are equal).
    const Real kick = mHalfStep ? Real(0.5) * (mDtLast + dt) : Real(0.5) * dt;
    r.vcBefore = mVc + kick * accel;
    mVc = r.vcBefore;
    mAdot += kick * flexAccel;
    if (mSet.viscosity > 0) viscousFlexKick(kick);
    mHalfStep = true;
    r.cNew = mC + dt * mVc;
    Mat3& aNew = r.aNew;
    aNew = mA + dt * mAdot;
    const Sl3Result sl3 = projectToSL3Along(aNew, mA.inverse().transpose() * mS0inv);
    if (sl3.ok) {
        aNew = sl3.matrix;
    } else {
        report.fault = "flex: the affine part inverted (det A <= 0); use more substeps";
        report.faultKind = FaultKind::FlexInverted;
        aNew = mA;
        mAdot.setZero();
    }
    return r;
}

/// Stage 2b: a pinned body's load modes (file comment of load_modes.hpp): the amplitudes move
/// under the load's share on each mode, the shape memory's stiffness and the damping
/// (semi-implicit), up to the strain bound; the memory's target is the displaced rest shape.
/// The load is what the pins refuse: the field's affine part over the body, a + K X̃ (the
/// mass-weighted least-squares fit that drives body and flex, eqs 66-68); its curvature
/// drives the twist (eq 76) as on a free body. Fed the whole field, an attractor pulling a
/// pinned jelly stretched it twice over, by the mode and by the twist, and folded it.
/// Being affine, the load's share on mode i is a · Σ m w_i + K : Σ m w_i X̃ᵀ (both sums fixed
/// at setup, LoadModes): no pass over the points.
/// Returns the step of the amplitudes.
Vec3 DeformableBody::stepLoadModes(const Vec3& accel, const Mat3& firstMoment, Real dt) {
    const Index n = mLat.size();
    if (mLoad.empty()) return Vec3::Zero();
    const Mat3 K = firstMoment * mS0inv;
    Vec3 fq;
    for (std::size_t i = 0; i < 3; ++i)
        fq[static_cast<Index>(i)] = accel.dot(mLoad.massSum[i]) + K.cwiseProduct(mLoad.firstMoment[i]).sum();
    if (mSet.shapeStiffness > 0 && !mQ.isZero()) {
        if (mLoadGamma[0].empty() || mQ != mQTarget) {
            std::vector<Vec3> displaced(at(n));
            parallelFor(n, [&](Index p) {
                displaced[at(p)] = mPinnedPositions[at(p)] + mQ[0] * mLoad.w[0][at(p)] + mQ[1] * mLoad.w[1][at(p)] +
                                   mQ[2] * mLoad.w[2][at(p)];
            });
            GeometricState target;
            computeGeometricState(mLat, displaced, target, BoundaryStencils::Realisable);
            mLoadGamma = std::move(target.christoffel);
            mQTarget = mQ;
        }
    } else {
        for (auto& g : mLoadGamma) g.clear();
    }
    const Vec3 qdd = Vec3(mLoad.mass.ldlt().solve(fq)) - mSet.shapeStiffness * mQ;
    mQdot = (mQdot + dt * qdd) / (1 + mSet.damping * dt);
    Vec3 qNew = mQ + dt * mQdot;
    const Real strain = qNew.cwiseAbs().dot(mLoad.strain);
    if (strain > mSet.maxLoadStrain) {
        qNew *= mSet.maxLoadStrain / strain;
        mQdot = (qNew - mQ) / dt;
    }
    const Vec3 dq = qNew - mQ;
    mQ = qNew;
    return dq;
}

/// Stage 3: the twist, eq 76 with W split into rotation and stretch (file comment), and the
/// viscous term on the twist rate.
void DeformableBody::predictTwist(const ForceSamples& fs, const Mat3& L0, Real dt, StepReport& report) {
    const Index n = mLat.size();
    std::vector<unsigned char> limited(at(n), 0);
    parallelFor(n, [&](Index p) {
        const std::size_t i = at(p);
        Mat3 F, Fi;
        F << mState.tangent[0][i], mState.tangent[1][i], mState.tangent[2][i];
        Fi << mState.dual[0][i].transpose(), mState.dual[1][i].transpose(), mState.dual[2][i].transpose();
        Mat3 step;
        if (mHavePrev) {
            Mat3 Fp;
            Fp << mTangentPrev[0][i], mTangentPrev[1][i], mTangentPrev[2][i];
            step = F.lazyProduct(Fp.inverse());
        } else {
            step = Mat3::Identity() + dt * L0;
        }
        PointConnection gamma, dg;
        std::array<Mat3, 3> hess;
        for (std::size_t c = 0; c < 3; ++c) {
            gamma[c] = mState.christoffel[c][i];
            if (!mPlasticGamma[c].empty()) gamma[c] -= mPlasticGamma[c][i];  // memory toward Γ_p
            if (!mLoadGamma[c].empty()) gamma[c] -= mLoadGamma[c][i];        // ... displaced by the load modes
            dg[c] = mDGamma[c][i];
            hess[c] = fs.hessian[c][i];
        }
        if (twistUpdate(F, Fi, step, hess, gamma, dt, mSet, dg)) limited[i] = 1;
        for (int c = 0; c < 3; ++c) mDGamma[static_cast<std::size_t>(c)][i] = dg[static_cast<std::size_t>(c)];
    });
    report.limitedPoints = std::count(limited.begin(), limited.end(), 1);
    // Viscosity: the viscous term on the twist rate, implicit (docs/math.md, "Viscosity: the viscous stress at every
    // scale").
    if (mSet.viscosity > 0) (void)viscousTwistStep(mLat, mSet.viscosity * dt / (mLat.spacing * mLat.spacing), mDGamma);
    report.sumDeltaGamma2 = sumDeltaGamma2();
}

/// A folded lattice (a boundary frame turned over) has |Γ| of tens per lattice step and growing;
/// the edge transports exp(Γ) overflow past a few hundred. True, with a fault naming the point,
/// where Γ + δΓ is that large (also NaN).
bool DeformableBody::connectionFolded(const std::array<std::vector<Mat3>, 3>& gammaBar, StepReport& report) const {
    const Index n = mLat.size();
    constexpr Real kMaxGamma = 100;
    auto size2 = [&](Index p) {
        Real acc = 0;
        for (std::size_t c = 0; c < 3; ++c) acc += gammaBar[c][at(p)].squaredNorm();
        return acc;
    };
    const Index folded = parallelReduce(
        n, Index(0), [&](Index& acc, Index p) { acc += !(size2(p) <= kMaxGamma * kMaxGamma) ? 1 : 0; },
        [](Index a, Index b) { return a + b; });
    if (folded > 0) {
        Index worst = 0;
        for (Index p = 0; p < n; ++p)
            if (!(size2(p) <= size2(worst))) worst = p;
        const Vec3i& u = mLat.coords[at(worst)];
        char what[300];
        std::snprintf(what, sizeof what,
                      "the lattice folded at material point u = (%d, %d, %d): its connection |Γ + δΓ| = %.3g per "
                      "lattice step (a smooth shape has well under 1): use more damping, more substeps, a "
                      "briefer force or a stiffer material",
                      u.x(), u.y(), u.z(), std::sqrt(size2(worst)));
        report.fault = what;
        report.faultKind = FaultKind::LatticeFolded;
        return true;
    }
    return false;
}

/// Stage 4: the displacement that Γ + δΓ asks for relative to Γ (file comment), into
/// mDisplacement; false, with a fault, where it leaves the lattice's reach in one step.
bool DeformableBody::reconstructStep(StepReport& report) {
    const Index n = mLat.size();
    const Real h = mLat.spacing;
    ReconstructWork& rw = *mRecWork;
    const std::array<std::vector<Mat3>, 3>& gammaBar = rw.gammaBar;
    // Both frame fields start from the current frames at the solver's fixed points.
    rw.frames.resize(at(n));
    parallelFor(n, [&](Index p) {
        rw.frames[at(p)] << mState.tangent[0][at(p)], mState.tangent[1][at(p)], mState.tangent[2][at(p)];
    });
    // The frame sweeps run clear of colliders only (DynamicsSettings::frameSweeps): a body that
    // touched one less than frameSweepsAfter ago keeps the tree's frames. Pinned or not.
    const bool nearContact = mFreeFlight < mSet.frameSweepsAfter;
    connectionChangeSteps(mLat, rw.tree, mState.christoffel, gammaBar, rw.frames, rw.change, rw.forward,
                          nearContact ? 0 : mSet.frameSweeps);
    // Warm start: the last two displacements extrapolated linearly, 2 d_n − d_(n−1) (exact for a
    // displacement growing linearly, as from rest under a steady force; measured at r = 32 in a
    // vortex: 8 → 5 CG iterations against d_n alone).
    parallelFor(n, [&](Index p) {
        const Vec3 last = mDisplacement[at(p)];
        mDisplacement[at(p)] = 2 * last - mDisplacementPrev[at(p)];
        mDisplacementPrev[at(p)] = last;
    });
    for (Index p : mSolverFixed) mDisplacement[at(p)].setZero();
    const auto tSolve = Clock::now();
    const SolveReport rec = mSolver->solveSteps(mLat, rw.forward, mDisplacement, mSet.reconstructTolerance, 200);
    report.reconstructSolveSeconds = since(tSolve);
    report.reconstructEdgeSeconds = rw.change.edgeSeconds;
    report.reconstructFrameSeconds = rw.change.treeSeconds + rw.change.sweepSeconds;
    report.reconstructIterations = rec.iterations;
    const Real maxStep = parallelReduce(
        n, Real(0), [&](Real& acc, Index p) { acc = std::max(acc, mDisplacement[at(p)].norm()); },
        [](Real a, Real b) { return std::max(a, b); });
    if (!(maxStep <= 2 * h)) {  // also NaN
        // The twist's displacement left the lattice's reach in one step (measured: it follows
        // a frame that has become near-singular at the boundary after long shearing).
        Index worst = 0;
        for (Index p = 0; p < n; ++p)
            if (!(mDisplacement[at(p)].norm() <= mDisplacement[at(worst)].norm())) worst = p;
        const Vec3i& u = mLat.coords[at(worst)];
        const Vec3& xw = mX[at(worst)];
        char what[400];
        std::snprintf(
            what, sizeof what,
            "reconstruction: the twist moved material point u = (%d, %d, %d) at (%.4g, %.4g, %.4g) %.3g voxels "
            "in one step (solve %s); the shape is sheared past what the lattice resolves (measured: a "
            "boundary frame folds first): use more damping, more substeps, a briefer force or a stiffer material",
            u.x(), u.y(), u.z(), xw.x(), xw.y(), xw.z(), maxStep / h, rec.converged ? "converged" : "did not converge");
        report.fault = what;
        report.faultKind = FaultKind::TwistTooFar;
        mDisplacement.assign(at(n), Vec3::Zero());
        mDisplacementPrev.assign(at(n), Vec3::Zero());
        return false;
    }
    return true;
}

/// The gauge: a free body's affine part and centre are the flex and body state; a pinned body's
/// pins are put back, and the load modes' step added.
void DeformableBody::applyGauge(const Vec3& cNew, const Mat3& aNew, const Vec3& dq, std::vector<Vec3>& xNew) const {
    const Index n = mLat.size();
    // The gauge: a free body's affine part and centre are the flex and body state. The map
    // keeps the volume: the affine fit B of a body whose cells keep their volumes need not have
    // det 1 (a swirled ball's fit shrinks), and mapping B onto the flex A (det 1) scaled every
    // cell by 1/det B, an error the volume projection then undid each step (the vortex
    // benchmark: 4e-3 a step by step 27, and a second Gauss-Newton iteration). (det B)^(1/3) A B⁻¹
    // has det 1: the fit's SL(3) part becomes A (docs/math.md, "The gauge keeps the volume").
    if (!mAnyPinned) {
        Vec3 yc;
        Mat3 B;
        fitAffine(xNew, yc, B);
        const Real detB = B.determinant();
        const Mat3 map = (detB > 0 ? std::cbrt(detB) : Real(1)) * aNew * B.inverse();
        parallelFor(n, [&](Index p) { xNew[at(p)] = cNew + map * (xNew[at(p)] - yc); });
    } else {
        parallelFor(n, [&](Index p) {
            if (mPinned[at(p)]) xNew[at(p)] = mPinnedPositions[at(p)];
        });
        if (!dq.isZero())
            parallelFor(n, [&](Index p) {
                xNew[at(p)] += dq[0] * mLoad.w[0][at(p)] + dq[1] * mLoad.w[1][at(p)] + dq[2] * mLoad.w[2][at(p)];
            });
    }
}

StepReport DeformableBody::predict(const ForceField& field, Real frame, Real dt) {
    DGV_CHECK(dt > 0);
    mPredicted = false;
    if (mSet.solver == StepSolver::One) return predictOne(field, frame, dt);
    const auto tStart = Clock::now();
    StepReport report;
    const Index n = mLat.size();
    // A step of another length than the last one (adaptive substeps, sim/simulation.cpp): what
    // the body keeps per step becomes per step of the new length (velocities are per second
    // already; docs/math.md, "Adaptive substeps").
    if (mDtLast > 0 && dt != mDtLast) rescaleStep(dt / mDtLast);

    // 1. Forces: value for body and flex, Hessian for the twist.
    auto t = Clock::now();
    ForceSamples fs;
    field.sample(mX, frame, ForceOrder::Hessian, fs);
    report.forcesSeconds = since(t);

    // 2. Body and flex (Störmer-Verlet; flex projected onto SL(3)).
    t = Clock::now();
    const BodyFlexStep bf = predictBodyAndFlex(fs, dt, report);
    const Vec3 dq = stepLoadModes(bf.accel, bf.firstMoment, dt);
    report.bodyFlexSeconds = since(t);

    // 3. Twist: eq 76 with W split into rotation and stretch (file comment).
    t = Clock::now();
    predictTwist(fs, bf.L0, dt, report);
    report.twistSeconds = since(t);

    // 4. The displacement that Γ + δΓ asks for relative to Γ (file comment).
    t = Clock::now();
    ReconstructWork& rw = *mRecWork;
    std::array<std::vector<Mat3>, 3>& gammaBar = rw.gammaBar;
    for (std::size_t c = 0; c < 3; ++c) {
        gammaBar[c].resize(at(n));
        parallelFor(n, [&](Index p) { gammaBar[c][at(p)] = mState.christoffel[c][at(p)] + mDGamma[c][at(p)]; });
    }
    if (connectionFolded(gammaBar, report) || !reconstructStep(report)) {
        report.totalSeconds = since(tStart);
        return report;
    }
    std::vector<Vec3> xNew(at(n));
    parallelFor(n, [&](Index p) { xNew[at(p)] = mX[at(p)] + mDisplacement[at(p)]; });
    applyGauge(bf.cNew, bf.aNew, dq, xNew);
    report.reconstructSeconds = since(t);
    mXPred = std::move(xNew);
    mCPred = bf.cNew;
    mVcPred = bf.vcBefore;
    mAPred = bf.aNew;
    mDtPred = dt;
    report.totalSeconds = since(tStart);
    mPredReport = report;
    mPredicted = true;
    return report;
}

/// The chain step's collider stage: which points respond to which collider (the GLN network's R,
/// eqs 90-91, collide/gln_network; without a detector, the points inside that collider), and φ of
/// another body's surface at the prediction, before any response (its push is shared). Only a
/// collider's own points respond to it: were every point inside some collider to respond to
/// each, a body touching only another body would count as touching the ground too, and its
/// pair's momentum would not be put right.
struct DeformableBody::Responders {
    std::vector<std::vector<unsigned char>> responds;  ///< per collider, #P flags
    std::vector<std::vector<Real>> phi0;               ///< per collider that is a body: φ at the prediction
    std::vector<unsigned char> truth;                  ///< #P: φ < 0 for some collider (the stats' truth)

    /// The responding collider whose surface is nearest to x (least φ/|∇φ|; negative: inside):
    /// its index (-1 if none with a gradient), that distance and its unit normal.
    int nearest(const std::vector<Collider>& colliders, Index p, const Vec3& x, Real& distance, Vec3& normal) const {
        int best = -1;
        distance = std::numeric_limits<Real>::infinity();
        for (std::size_t c = 0; c < colliders.size(); ++c) {
            if (!responds[c][at(p)]) continue;
            Vec3 g;
            const Real phi = colliders[c].evaluate(x, g);
            const Real gn = g.norm();
            if (gn > 0 && phi / gn < distance) {
                distance = phi / gn;
                normal = g / gn;
                best = static_cast<int>(c);
            }
        }
        return best;
    }
};

DeformableBody::Responders DeformableBody::findResponders(const std::vector<Collider>& colliders,
                                                          const std::vector<Vec3>& xNew) const {
    const Index n = mLat.size();
    Responders r;
    r.responds.resize(colliders.size());
    r.phi0.resize(colliders.size());
    std::vector<std::vector<unsigned char>>& responds = r.responds;
    std::vector<std::vector<Real>>& phi0 = r.phi0;
    std::vector<unsigned char>& truth = r.truth;
    truth.assign(at(n), 0);
    for (std::size_t c = 0; c < colliders.size(); ++c) {
        if (colliders[c].object) phi0[c].assign(at(n), Real(0));
        responds[c].assign(at(n), 0);
    }
    parallelFor(n, [&](Index p) {
        if (mPinned[at(p)]) return;
        for (std::size_t c = 0; c < colliders.size(); ++c) {
            Vec3 g;
            const Real phi = colliders[c].evaluate(xNew[at(p)], g);
            if (phi < 0) {
                truth[at(p)] = 1;
                if (!mDetector) responds[c][at(p)] = 1;
            }
            if (colliders[c].object) phi0[c][at(p)] = phi;
        }
    });
    if (mDetector)
        for (std::size_t c = 0; c < colliders.size(); ++c) {
            std::vector<unsigned char>& R = responds[c];
            mDetector(xNew, colliders[c], R);
            for (Index p = 0; p < n; ++p)
                if (mPinned[at(p)]) R[at(p)] = 0;
        }
    return r;
}

/// Body and flex take the collider's push first (docs/math.md, "Contact: body and flex take the
/// collider's push first"): the affine correction of the contacts' depths, bounded, applied to x.
void DeformableBody::pushBodyAndFlex(const std::vector<Collider>& colliders, const Responders& r, const Vec3& cNew,
                                     const Mat3& aNew, Real dt, std::vector<Vec3>& xNew) {
    const Index n = mLat.size();
    std::vector<AffineContact> contacts;
    for (Index p = 0; p < n; ++p) {
        // The deepest collider decides; the point is lifted to its surface and beyond it
        // by `restitution` × the depth, as the point response below would.
        Real distance;
        Vec3 nrm;
        const int c = r.nearest(colliders, p, xNew[at(p)], distance, nrm);
        if (c >= 0 && distance < 0) {
            const Collider& col = colliders[static_cast<std::size_t>(c)];
            mContactDepth[at(p)] = -distance;  // the depth the prediction reached
            contacts.push_back({mRestRel[at(p)], nrm, col.share * ((1 + col.restitution) * -distance)});
        }
    }
    Vec3 dc;
    Mat3 dA;
    if (!contacts.empty()) {
        affineContactCorrection(contacts, aNew, mS0inv.inverse(), dc, dA, 2 * mSet.viscosity * dt);
        // Bounded: no point is thrown further along the contacts' mean normal than the
        // deepest contact is deep, and the strain of one step stays under
        // kMaxContactStrain; the points take the rest. (Contacts on opposite sides, e.g.
        // through a ring, can ask for a large squeeze in one step; where the normals do
        // not agree, by at least half, the whole displacement is bounded.) The sideways
        // widening of a squashed body is not bounded: its rim moves a little further than
        // its flat bottom facet is deep, and bounding that cut the lift by 1-6 % on every
        // step of a goo ball resting on the ground; its contact points took the rest
        // alone, which crushed the bottom layer until the lattice folded at frame 58
        // (docs/math.md, "Goo resting on the ground").
        constexpr Real kMaxContactStrain = 0.3;
        Real deepest = 0;
        Vec3 normalSum = Vec3::Zero();
        for (const AffineContact& c : contacts) {
            deepest = std::max(deepest, c.depth);
            normalSum += c.normal;
        }
        const bool agree = normalSum.norm() >= Real(0.5) * static_cast<Real>(contacts.size());
        const Vec3 meanNormal = agree ? Vec3(normalSum.normalized()) : Vec3::Zero();
        const Real largest = parallelReduce(
            n, Real(0),
            [&](Real& acc, Index p) {
                const Vec3 move = dc + dA * mRestRel[at(p)];
                acc = std::max(acc, agree ? std::abs(meanNormal.dot(move)) : move.norm());
            },
            [](Real x, Real y) { return std::max(x, y); });
        const Real strain = (aNew.inverse() * dA).norm();
        Real scale = 1;
        if (largest > deepest) scale = deepest / largest;
        if (strain * scale > kMaxContactStrain) scale = kMaxContactStrain / strain;
        dc *= scale;
        dA *= scale;
        // The jump dA also moves the arms of the body's angular momentum L = skew(Ȧ S Aᵀ)
        // (S the rest second moment): read off the positions, the velocity after it gives
        // (Ȧ + dA/δt) S (A + dA)ᵀ, whose cross term Ȧ S dAᵀ is a torque no impulse exerts
        // (a body resting on the ground, spun by it each step: docs/math.md). It is taken
        // out by a rotation of the jump, dA −= δt [ω]× A with ½ (tr B − B) ω =
        // vee skew(Ȧ S dAᵀ), B = A S Aᵀ (vee skew([ω]× B) = ½ (tr B − B) ω).
        {
            const Mat3 S = mS0inv.inverse();
            const Mat3 cross = mAdot * S * dA.transpose();
            const Mat3 k = Real(0.5) * (cross - cross.transpose());
            const Vec3 spinUp(k(2, 1), k(0, 2), k(1, 0));
            const Mat3 B = aNew * S * aNew.transpose();
            const Mat3 inertia = Real(0.5) * (B.trace() * Mat3::Identity() - B);
            const Vec3 w = inertia.ldlt().solve(spinUp);
            Mat3 wx;
            wx << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
            dA -= dt * wx * aNew;
        }
        const Sl3Result r1 = projectToSL3(aNew + dA);
        if (r1.ok) {
            const Vec3 c1 = cNew + dc;
            const Mat3 map = r1.matrix * aNew.inverse();
            parallelFor(n, [&](Index p) { xNew[at(p)] = c1 + map * (xNew[at(p)] - cNew); });
        }
    }
}

/// Each point still inside a collider it responds to is moved out, with friction.
void DeformableBody::respondPoints(const std::vector<Collider>& colliders, const Responders& r, const Vec3& vcBefore,
                                   Real dt, std::vector<Vec3>& xNew) {
    const Index n = mLat.size();
    const std::vector<std::vector<unsigned char>>& responds = r.responds;
    const std::vector<std::vector<Real>>& phi0 = r.phi0;
    // The tangential step `slip` of a contact point cut by the friction μ (1: sticky, 0:
    // slip), but by no more than μ × the normal step the contact takes out, Coulomb's bound:
    // the larger of the point's own push and the body's, (1 + e) × its centre's velocity
    // into the collider × δt (a resting body: g δt², whatever the point's depth). A point
    // resting or creeping is held as before; one sliding fast (a spinning body's rim) is
    // braked by that bound, not stopped dead each step, which tore a spinning ball's contact
    // layer apart in a few steps (docs/math.md, "Friction acts on the patch's slip").
    auto frictionStep = [&](const Vec3& slip, const Vec3& nrm, Real mu, Real push, Real restitution,
                            const Vec3& against) -> Vec3 {
        const Real size = slip.norm();
        if (!(size > 0)) return Vec3::Zero();
        const Real body = (1 + restitution) * std::max(Real(0), -(vcBefore - against).dot(nrm)) * dt;
        return (mu * std::min(size, std::max(push, body)) / size) * slip;
    };
    // The response of one point to one collider: out along the signed distance's gradient,
    // to the surface and beyond it by `restitution` × the depth (the normal reflection of an
    // elastic contact; 0: onto the surface), the tangential step reduced by the friction.
    auto respond = [&](Index p, const Collider& col) {
        Vec3& x = xNew[at(p)];
        Vec3 g;
        const Real phi = col.evaluate(x, g);
        if (!(phi < 0)) return;
        const Real gn = g.norm();
        if (!(gn > 0)) return;
        const Vec3 nrm = g / gn;
        const Real push = (1 + col.restitution) * (-phi / gn);
        x += push * nrm;
        const Vec3 s = x - mX[at(p)];
        x -= frictionStep(s - s.dot(nrm) * nrm, nrm, col.friction, push, col.restitution, Vec3::Zero());
        mContactDepth[at(p)] = std::max(mContactDepth[at(p)], -phi / gn);
    };
    // Another body's surface: this body's share of the push the prediction asked for,
    // share × (1 + restitution) × its depth then (the body and flex may have taken part of
    // it already), and the share of the friction on the step relative to the other body.
    auto respondShared = [&](Index p, const Collider& col, Real phiBefore) {
        if (!(phiBefore < 0)) return;
        Vec3& x = xNew[at(p)];
        Vec3 g;
        const Real phi = col.evaluate(x, g);
        const Real gn = g.norm();
        if (!(gn > 0)) return;
        const Vec3 nrm = g / gn;
        const Real target = phiBefore * (1 - col.share * (1 + col.restitution));  // φ after the push
        const Real push = phi < target ? (target - phi) / gn : Real(0);
        x += push * nrm;
        const Vec3 s = x - mX[at(p)] - dt * col.velocity;
        x -= frictionStep(s - s.dot(nrm) * nrm, nrm, col.share * col.friction, push, col.restitution, col.velocity);
        mContactDepth[at(p)] = std::max(mContactDepth[at(p)], -phiBefore / gn);
    };
    parallelFor(n, [&](Index p) {
        for (std::size_t c = 0; c < colliders.size(); ++c) {
            if (!responds[c][at(p)]) continue;
            mContact[at(p)] = 1;
            if (colliders[c].object)
                respondShared(p, colliders[c], phi0[c][at(p)]);
            else
                respond(p, colliders[c]);
        }
    });
}

/// Volume, cell by cell, with pinned and contact points held (docs/math.md, "Cell volumes and the
/// volume projection").
void DeformableBody::projectChainVolumes(const std::vector<Collider>& colliders, const Responders& r,
                                         std::vector<Vec3>& xNew, StepReport& report) {
    const Index n = mLat.size();
    // Pins are fixed; a contact point slides on its collider's surface (the plane normal to
    // the gradient of the responding collider it is nearest): the projection's push then
    // has no net tangential part, as a surface's reaction (docs/math.md, "Contact points
    // slide in the volume projection"). Held in all directions, it gave a resting body a
    // steady sideways push: without friction it accelerated, with friction its contact
    // layer sheared until it folded.
    std::vector<unsigned char> held(at(n));
    std::vector<Vec3> slideNormal;
    if (report.contacts > 0) slideNormal.assign(at(n), Vec3::Zero());
    parallelFor(n, [&](Index p) {
        held[at(p)] = mPinned[at(p)] ? 1 : 0;
        if (mPinned[at(p)] || !mContact[at(p)]) return;
        Real distance;
        Vec3 normal;
        if (r.nearest(colliders, p, xNew[at(p)], distance, normal) < 0) {
            held[at(p)] = 1;
        } else {
            held[at(p)] = kSlides;
            slideNormal[at(p)] = normal;
        }
    });
    // A cell whose eight corners are all held could not be corrected at all: a fast body
    // can put whole cells inside a collider in one step, and the response flattens them
    // onto its surface (ring_drop's landing: one cell 5.7% off; a ball landing at 8 m/s:
    // 33%). The four corners of such a cell on its far side from the collider (along the
    // collider's normal at the cell, by the body's affine map of the rest offsets) are
    // released for the projection, which then restores the volume by lifting them off the
    // surface rather than pushing the near face into the collider. Pins stay held.
    if (report.contacts > 0 && !colliders.empty()) {
        std::vector<Index> release;
        for (Index c = 0; c < mCells.size(); ++c) {
            const std::array<Index, 8>& corners = mCells.corners[at(c)];
            bool all = true;
            for (Index id : corners) all = all && held[at(id)];
            if (!all) continue;
            Vec3 centre = Vec3::Zero();
            for (Index id : corners) centre += xNew[at(id)] / 8;
            Real nearest = std::numeric_limits<Real>::infinity();
            Vec3 normal = Vec3::Zero();
            for (const Collider& col : colliders) {
                Vec3 g;
                const Real phi = col.evaluate(centre, g);
                if (phi < nearest && g.norm() > 0) {
                    nearest = phi;
                    normal = g.normalized();
                }
            }
            if (normal.isZero()) continue;
            std::array<std::pair<Real, Index>, 8> away;
            for (std::size_t k = 0; k < 8; ++k) away[k] = {normal.dot(mA * mRestRel[at(corners[k])]), corners[k]};
            std::sort(away.begin(), away.end());
            for (std::size_t k = 4; k < 8; ++k) release.push_back(away[k].second);
        }
        for (Index id : release)
            if (!mPinned[at(id)]) held[at(id)] = 0;
    }
    VolumeProjectionSettings vs = volumeSettings();  // also used by restoreState
    if (!slideNormal.empty()) vs.slideNormals = &slideNormal;
    // The multipliers' prediction: the last two steps' extrapolated, 2 λ_n − λ_(n−1) (file
    // comment of volume.hpp; docs/math.md, "The volume correction predicted").
    const std::size_t nc = at(mCells.size());
    std::vector<Real> lambda;
    if (mVolumeLambda.size() == nc) {
        lambda.resize(nc);
        const bool two = mVolumeLambdaPrev.size() == nc;
        parallelFor(mCells.size(), [&](Index c) {
            lambda[at(c)] = two ? 2 * mVolumeLambda[at(c)] - mVolumeLambdaPrev[at(c)] : mVolumeLambda[at(c)];
        });
    }
    vs.multipliers = &lambda;
    const VolumeProjectionReport vr = projectVolumes(mCells, mRestVolumes, held, xNew, vs);
    mVolumeLambdaPrev = std::move(mVolumeLambda);
    mVolumeLambda = std::move(lambda);
    report.volumeIterations = vr.iterations;
    report.volumeConverged = vr.converged;
}

/// The contact's rules on the body's centre and flex velocities after the constraints: the
/// restitution on the normal part of the body velocity about the mean contact normal, the
/// patch's friction, and the flex rate that would lift the patch off (docs/math.md, "Contact:
/// body and flex take the collider's push first").
void DeformableBody::landOnColliders(const std::vector<Collider>& colliders, const std::vector<Vec3>& xNew,
                                     const Mat3& A1, const Vec3& vcBefore, Real inelastic, bool jellyLanding) {
    const Index n = mLat.size();
    const Real h = mLat.spacing;
    // restitution on the normal part of the body velocity, about the mean contact normal
    Vec3 nSum = Vec3::Zero(), restSum = Vec3::Zero();
    std::vector<Vec3> patch;  // the contact points' positions
    Real e = 0, mu = 0;
    Index count = 0;
    for (Index p = 0; p < n; ++p) {
        if (!mContact[at(p)]) continue;
        for (const Collider& col : colliders) {
            if (col.object) continue;  // below
            Vec3 g;
            if (col.evaluate(xNew[at(p)], g) <= 1e-9 * h) {
                nSum += g;
                restSum += mRestRel[at(p)];
                patch.push_back(xNew[at(p)]);
                e += col.restitution;
                mu += col.friction;
                ++count;
                break;
            }
        }
    }
    if (count > 0 && nSum.norm() > 0) {
        // The body meets the collider: its centre's velocity into it stops (or bounces back
        // with the restitution); otherwise the free points keep falling onto the held ones
        // and fold the bottom layers within a few steps. And the flex rate may not lift the
        // contact patch off by itself: a body that squashes on impact (goo has nothing to
        // stop the squash) would otherwise hop. The part of Ȧ that moves the mean contact
        // point X̄ away from the collider relative to the centre is taken out (the least
        // change in the kinetic metric, trace-free: det A kept), so the squash's momentum
        // is absorbed by the contact (docs/math.md, "Contact: body and flex take the
        // collider's push first").
        const Vec3 nrm = nSum.normalized();
        const Real vn = vcBefore.dot(nrm);
        // ... and a slow approach (a body resting or set down: |v_n| of a few g δt) is
        // inelastic too: an elastic one chattered on the ground, the push of each step
        // thrown back by the memory (a jelly of k = 1000 set down kept 3 J of 14).
        // The scale: a tenth of the memory's velocity for a unit strain, √(k s).
        const Real slow =
            jellyLanding ? Real(0.1) * std::sqrt(mSet.shapeStiffness * mS0inv.inverse().trace() / 3) : Real(0);
        const Real share =
            slow > 0 ? std::max(inelastic, std::clamp(2 - std::abs(vn) / slow, Real(0), Real(1))) : inelastic;
        const Vec3 xbar = restSum / static_cast<Real>(count);
        // The body's rigid motion about its centre: ω = J⁻¹ L with L the angular momentum
        // of the flex rate per unit mass (vee of the skew part of Ȧ S Aᵀ) and J = tr B − B,
        // B = A S Aᵀ; the flex rate of a spin ω is [ω]× A.
        const Mat3 S = mS0inv.inverse();
        const Mat3 B = A1 * S * A1.transpose();
        const Eigen::LDLT<Mat3> inertia((B.trace() * Mat3::Identity() - B).eval());
        auto spinOf = [&](const Mat3& rate) {
            const Mat3 K = rate * S * A1.transpose();  // Σ m v rᵀ / M
            return Vec3(inertia.solve(Vec3(K(2, 1) - K(1, 2), K(0, 2) - K(2, 0), K(1, 0) - K(0, 1))));
        };
        auto spinRate = [&](const Vec3& w) {
            Mat3 wx;
            wx << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
            return Mat3(wx * A1);
        };
        const Vec3 arm = A1 * xbar;
        if (vn < 0) {
            const Real restitution = e / static_cast<Real>(count), friction = mu / static_cast<Real>(count);
            // (the whole approach stops for the inelastic rule; a jelly's slow approach loses
            // only its velocity into the collider, so its rebound off a squash keeps going)
            mVc += -inelastic * (mVc.dot(nrm) + restitution * vn) * nrm;
            if (share > inelastic && mVc.dot(nrm) < 0)
                mVc -= ((share - inelastic) / (1 - inelastic)) * mVc.dot(nrm) * nrm;
            // Coulomb friction at the contact patch: the slip of the patch's mean material
            // point X̄ under the body's rigid motion, v_c + ω × A X̄ (its deformation, a
            // sag spreading the patch, is the points' own friction's), loses up to the
            // friction coefficient times the normal velocity the contact took out (a body
            // resting under gravity: μ g δt a step, so a slow creep stops dead), by an
            // impulse at A X̄ as on a rigid body: δv_c = −λ t, δω = J⁻¹ (A X̄ × −λ t),
            // δȦ = [δω]× A (det A kept). A body spinning on a rough ground so rolls away;
            // braking the centre alone held it where it was, spinning (docs/math.md,
            // "Friction acts on the patch's slip").
            const Vec3 slipVel = mVc + spinOf(mAdot).cross(arm);
            const Vec3 slip = slipVel - slipVel.dot(nrm) * nrm;
            const Real vs = slip.norm(), brake = friction * (1 + restitution) * (-vn);
            if (vs > 0 && brake > 0) {
                const Vec3 tdir = slip / vs;
                const Vec3 turn = inertia.solve(arm.cross(tdir));     // δω per unit impulse along −t
                const Real response = 1 + arm.cross(tdir).dot(turn);  // slip change per unit impulse
                const Real lambda = std::min(vs / response, brake);
                mVc -= lambda * tdir;
                mAdot -= lambda * spinRate(turn);
            }
            // And the patch's friction against turning about the normal (a body spinning
            // like a top on it): up to μ × the normal impulse × the mean distance of the
            // contact points from their centroid in the plane (for a uniformly pressed
            // disc of radius a, 2a/3: the Coulomb torque). Without it a ball kept
            // spinning on the ground on the spot for as long as it was watched.
            Vec3 centroid = Vec3::Zero();
            for (const Vec3& x : patch) centroid += x / static_cast<Real>(patch.size());
            Real reach = 0;
            for (const Vec3& x : patch) {
                const Vec3 d = x - centroid;
                reach += (d - d.dot(nrm) * nrm).norm() / static_cast<Real>(patch.size());
            }
            const Vec3 turnAxis = inertia.solve(nrm);  // δω per unit angular impulse about n
            const Real twist = spinOf(mAdot).dot(nrm), perImpulse = nrm.dot(turnAxis);
            if (twist != 0 && perImpulse > 0 && reach > 0) {
                const Real tau = std::min(std::abs(twist) / perImpulse, brake * reach);
                mAdot -= (std::copysign(tau, twist)) * spinRate(turnAxis);
            }
        }
        const Real lift = nrm.dot(mAdot * xbar);  // > 0: the patch leaves the collider
        const Mat3 gA = volumeKeeping(nrm * xbar.transpose() * mS0inv, A1, mS0inv);
        const Real effect = nrm.dot(gA * xbar);
        if (inelastic > 0 && lift > 0 && vn < 0 && effect > 1e-12 * xbar.squaredNorm() * mS0inv.norm())
            mAdot -= (inelastic * lift / effect) * gA;
    }
}

/// The rate δΓ carried to the next step: in contact only what the constraints realised of it
/// (anti-windup), or (realizedRate) the change that happened.
void DeformableBody::carryRate(bool antiWindup, const std::array<std::vector<Mat3>, 3>& gammaOld) {
    const Index n = mLat.size();
    if (antiWindup) {
        // Anti-windup in contact: keep the realised fraction of δΓ at each point, between 0 (the
        // constraints refused it all, or turned it round) and 1 (it all happened). The direction
        // stays eq 76's; the constraints' own push never becomes a rate.
        parallelFor(n, [&](Index p) {
            Real realised = 0, asked = 0;
            for (std::size_t c = 0; c < 3; ++c) {
                const Mat3 change = mState.christoffel[c][at(p)] - gammaOld[c][at(p)];
                realised += change.cwiseProduct(mDGamma[c][at(p)]).sum();
                asked += mDGamma[c][at(p)].squaredNorm();
            }
            if (!(asked > 0)) return;
            const Real f = std::clamp(realised / asked, Real(0), Real(1));
            for (std::size_t c = 0; c < 3; ++c) mDGamma[c][at(p)] *= f;
        });
    }
    if (mSet.realizedRate) {
        // The rate carried to the next step is the change that happened (after reconstruction,
        // colliders, pins and the volume projection), not the one that was asked for: what the
        // constraints refused does not wind up in δΓ.
        parallelFor(n, [&](Index p) {
            PointConnection d;
            for (std::size_t c = 0; c < 3; ++c) d[c] = mState.christoffel[c][at(p)] - gammaOld[c][at(p)];
            if (mSet.traceFree) projectTraceFree(d);
            Real norm2 = 0;
            for (const Mat3& m : d) norm2 += m.squaredNorm();
            const Real cap2 = mSet.maxDeltaGamma * mSet.maxDeltaGamma;
            if (norm2 > cap2) {
                const Real s = std::sqrt(cap2 / norm2);
                for (Mat3& m : d) m *= s;
            }
            for (std::size_t c = 0; c < 3; ++c) mDGamma[c][at(p)] = d[c];
        });
    }
}

StepReport DeformableBody::finish(const std::vector<Collider>& colliders) {
    DGV_CHECK(mPredicted);
    if (mSet.solver == StepSolver::One) return finishOne(colliders);
    mPredicted = false;
    const auto tStart = Clock::now();
    StepReport report = mPredReport;
    const Index n = mLat.size();
    const Real dt = mDtPred;
    std::vector<Vec3> xNew = std::move(mXPred);
    mXPred.clear();
    const Vec3 cNew = mCPred, vcBefore = mVcPred;
    const Mat3 aNew = mAPred;

    // 5. Colliders.
    auto t = Clock::now();
    std::fill(mContact.begin(), mContact.end(), 0);
    std::fill(mContactDepth.begin(), mContactDepth.end(), Real(0));
    Responders responders;
    if (!colliders.empty()) {
        responders = findResponders(colliders, xNew);
        // Body and flex take the push first, then each point still inside is moved out.
        if (mSet.affineContact && !mAnyPinned) pushBodyAndFlex(colliders, responders, cNew, aNew, dt, xNew);
        respondPoints(colliders, responders, vcBefore, dt, xNew);
        for (std::size_t c = 0; c < colliders.size(); ++c)
            if (!colliders[c].object && std::count(responders.responds[c].begin(), responders.responds[c].end(), 1) > 0)
                report.staticContact = true;
        for (Index p = 0; p < n; ++p) {
            report.contactTruth += responders.truth[at(p)];
            if (responders.truth[at(p)] && mContact[at(p)]) ++report.contactTruePositive;
        }
    }
    report.contacts = std::count(mContact.begin(), mContact.end(), 1);
    report.collideSeconds = since(t);

    // 6. Volume, cell by cell, with pinned and contact points held.
    t = Clock::now();
    if (mSet.projectVolume && mCells.size() > 0) projectChainVolumes(colliders, responders, xNew, report);
    if (!colliders.empty())
        report.maxPenetration = parallelReduce(
            n, Real(0),
            [&](Real& acc, Index p) {
                for (const Collider& col : colliders) {
                    if (col.object) continue;  // measured by the caller once both bodies moved
                    Vec3 g;
                    const Real phi = col.evaluate(xNew[at(p)], g);
                    const Real gn = g.norm();
                    if (phi < 0 && gn > 0) acc = std::max(acc, -phi / gn);
                }
            },
            [](Real a, Real b) { return std::max(a, b); });
    report.volumeSeconds = since(t);

    // 7. Body and flex after constraints (position-based), velocities, the new state.
    t = Clock::now();
    if (mAnyPinned || report.contacts > 0) {
        Vec3 c1;
        Mat3 A1;
        fitAffine(xNew, c1, A1);
        // The flex is the fit's SL(3) part, A1 / (det A1)^(1/3), as the gauge of a free step
        // makes it ("The gauge keeps the volume"). The nearest SL(3) matrix differs from it where
        // the fit is anisotropic and det A1 ≠ 1 (a jelly resting on the ground: det 0.996), and a
        // body whose steps alternate between contact and none would switch between the two
        // definitions, their difference showing as a flex rate.
        const Sl3Result r1 = projectToSL3Scale(A1);
        if (r1.ok) A1 = r1.matrix;
        mVc = (c1 - mC) / dt;
        mAdot = (A1 - mA) / dt;
        // A jelly lands elastically while its squash is within maxLandingStrain
        // (DynamicsSettings::elasticLanding): its centre and flex keep what the push left them.
        Real landingStrain = 0;
        if (report.contacts > 0 && mSet.elasticLanding && mSet.shapeStiffness > 0 && mSet.yieldStrain == 0) {
            Eigen::SelfAdjointEigenSolver<Mat3> es;
            es.computeDirect(A1.transpose() * A1);
            const Vec3 l = es.eigenvalues();
            landingStrain = l.minCoeff() > 0 ? (Real(0.5) * l.array().log()).abs().maxCoeff()
                                             : std::numeric_limits<Real>::infinity();
        }
        // The inelastic rule's share: 0 for a jelly squashed up to the bound, rising to 1 at 1.5 times
        // it (a blend: a switch at the bound made a landing that crossed it kick); 1 for goo, putty
        // and with elasticLanding off.
        const bool jellyLanding = mSet.elasticLanding && mSet.shapeStiffness > 0 && mSet.yieldStrain == 0;
        const Real inelastic =
            !jellyLanding ? Real(1)
                          : std::clamp((landingStrain - mSet.maxLandingStrain) / (Real(0.5) * mSet.maxLandingStrain),
                                       Real(0), Real(1));
        if (report.contacts > 0) landOnColliders(colliders, xNew, A1, vcBefore, inelastic, jellyLanding);
        mC = c1;
        mA = A1;
    } else {
        mC = cNew;
        mAdot = (aNew - mA) / dt;  // SHAKE: the velocity of the step taken (docs/math.md, "The flex keeps its spin")
        mA = aNew;
    }
    parallelFor(n, [&](Index p) { mV[at(p)] = (xNew[at(p)] - mX[at(p)]) / dt; });
    report.kineticEnergy = parallelReduce(
        n, Real(0), [&](Real& acc, Index p) { acc += Real(0.5) * mMass[at(p)] * mV[at(p)].squaredNorm(); },
        [](Real a, Real b) { return a + b; });
    mTangentPrev = mState.tangent;
    mHavePrev = true;
    mDtLast = dt;
    mFreeFlight = report.contacts > 0 ? Real(0) : mFreeFlight + dt;
    mX.swap(xNew);
    std::array<std::vector<Mat3>, 3> gammaOld;
    const bool antiWindup = mSet.antiWindup && !mSet.realizedRate && report.contacts > 0;
    if (mSet.realizedRate || antiWindup) gammaOld = mState.christoffel;
    computeGeometricState(mLat, mX, mState, BoundaryStencils::Realisable);
    carryRate(antiWindup, gammaOld);
    if (mSet.yieldStrain > 0) yieldRestShape();
    report.stateSeconds = since(t);
    volumeFigures(report.maxCellVolumeError, report.totalVolumeDrift, report.invertedCells);
    if (report.invertedCells > 0 && report.fault.empty()) {
        report.fault = std::to_string(report.invertedCells) +
                       " lattice cells inverted (the shape folded): use more damping, stiffness or substeps";
        report.faultKind = FaultKind::CellsInverted;
    }
    report.totalSeconds = mPredReport.totalSeconds + since(tStart);
    return report;
}

}  // namespace dgv
