// The one-solve step's minimisation (cell_solve.hpp; docs/math.md, "The one-solve step").

#include "dynamics/cell_solve.hpp"

#include "base/parallel.hpp"
#include "dynamics/stepper.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <tuple>

namespace dgv {

namespace {

/// Corner k's offset along axis a (volume.hpp's order) and its sign s = 2 o − 1.
int offset(int k, int a) { return (k >> a) & 1; }
Real sign(int k, int a) { return offset(k, a) ? Real(1) : Real(-1); }

/// The unit cube's integrals Î^{ab}_jk = ∫ ∂_a N_j ∂_b N_k dξ (trilinear N, exact at 2×2×2 Gauss
/// points), and L̂ = Σ_a Î^{aa}, the cube's scalar stiffness.
struct UnitCube {
    std::array<std::array<std::array<std::array<Real, 8>, 8>, 3>, 3> I{};
    std::array<std::array<Real, 8>, 8> L{};
    UnitCube() {
        const Real q[2] = {Real(0.5) - Real(0.5) / std::sqrt(Real(3)), Real(0.5) + Real(0.5) / std::sqrt(Real(3))};
        auto phi = [](int o, Real t) { return o ? t : 1 - t; };
        for (int g = 0; g < 8; ++g) {
            const Real xi[3] = {q[g & 1], q[(g >> 1) & 1], q[(g >> 2) & 1]};
            std::array<Vec3, 8> grad;
            for (int k = 0; k < 8; ++k)
                for (int a = 0; a < 3; ++a) {
                    Real v = sign(k, a);
                    for (int i = 0; i < 3; ++i)
                        if (i != a) v *= phi(offset(k, i), xi[i]);
                    grad[static_cast<std::size_t>(k)][a] = v;
                }
            for (std::size_t a = 0; a < 3; ++a)
                for (std::size_t b = 0; b < 3; ++b)
                    for (std::size_t j = 0; j < 8; ++j)
                        for (std::size_t k = 0; k < 8; ++k)
                            I[a][b][j][k] += Real(0.125) * grad[j][static_cast<Index>(a)] * grad[k][static_cast<Index>(b)];
        }
        for (std::size_t j = 0; j < 8; ++j)
            for (std::size_t k = 0; k < 8; ++k) L[j][k] = I[0][0][j][k] + I[1][1][j][k] + I[2][2][j][k];
    }
};

const UnitCube& unitCube() {
    static const UnitCube cube;
    return cube;
}

/// IPC's clamped log barrier on (0, ĵ): b = −(J − ĵ)² ln(J/ĵ), C² at ĵ; below jLo its quadratic
/// continuation (a corner that starts inverted is pushed back, finitely).
struct Barrier {
    Real jHat;
    void eval(Real J, Real& d1, Real& d2) const {
        const Real jLo = Real(0.01) * jHat;
        const Real j = std::max(J, jLo);
        const Real l = std::log(j / jHat), e = j - jHat;
        d1 = -2 * e * l - e * e / j;
        d2 = -2 * l - 4 * e / j + e * e / (j * j);
        if (J < jLo) d1 += d2 * (J - jLo);
    }
};

/// Corner k's Jacobian relative to rest and its gradients: dCorner with respect to corner k,
/// dNbr[a] with respect to its neighbour along axis a.
Real cornerJacobian(const std::array<Vec3, 8>& x, int k, Real h3, Vec3& dCorner, std::array<Vec3, 3>& dNbr) {
    std::array<Vec3, 3> e;
    Real s = 1;
    for (int a = 0; a < 3; ++a) {
        e[static_cast<std::size_t>(a)] = x[static_cast<std::size_t>(k ^ (1 << a))] - x[static_cast<std::size_t>(k)];
        s *= -sign(k, a);  // the edge points along −axis where the corner's offset is 1
    }
    const Real f = s / h3;
    dNbr[0] = f * e[1].cross(e[2]);
    dNbr[1] = f * e[2].cross(e[0]);
    dNbr[2] = f * e[0].cross(e[1]);
    dCorner = -(dNbr[0] + dNbr[1] + dNbr[2]);
    return f * e[0].dot(e[1].cross(e[2]));
}

std::array<Vec3, 8> gather(const LatticeCells& cells, const std::vector<Vec3>& x, Index c) {
    std::array<Vec3, 8> out;
    for (std::size_t k = 0; k < 8; ++k) out[k] = x[at(cells.corners[at(c)][k])];
    return out;
}

/// Turns the rotation q toward the polar rotation of M (Müller, Bender, Chentanez and Macklin's
/// iteration: the rotation whose columns best align with M's, a few steps from a warm start).
void turnToward(const Mat3& M, Eigen::Quaternion<Real>& q) {
    for (int i = 0; i < 3; ++i) {
        const Mat3 R = q.toRotationMatrix();
        const Vec3 w = (R.col(0).cross(M.col(0)) + R.col(1).cross(M.col(1)) + R.col(2).cross(M.col(2))) /
                       (std::abs(R.col(0).dot(M.col(0)) + R.col(1).dot(M.col(1)) + R.col(2).dot(M.col(2))) + Real(1e-12));
        const Real angle = w.norm();
        if (angle < Real(1e-12)) break;
        q = Eigen::Quaternion<Real>(Eigen::AngleAxis<Real>(angle, w / angle)) * q;
        q.normalize();
    }
}

}  // namespace

Mat3 polarRotationOf(const Mat3& m) {
    const Eigen::JacobiSVD<Mat3> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 u = svd.matrixU();
    const Mat3 v = svd.matrixV();
    if ((u * v.transpose()).determinant() < 0) u.col(2) = -u.col(2);
    return u * v.transpose();
}

Mat3 CellSolver::centreFrame(const std::array<Vec3, 8>& x, Real h) {
    Mat3 f = Mat3::Zero();
    for (int k = 0; k < 8; ++k)
        f += x[static_cast<std::size_t>(k)] * Vec3(sign(k, 0), sign(k, 1), sign(k, 2)).transpose();
    return f / (4 * h);
}

Real CellSolver::minCornerJacobian(const std::array<Vec3, 8>& x, Real h) {
    Real j = std::numeric_limits<Real>::infinity();
    Vec3 dc;
    std::array<Vec3, 3> dn;
    for (int k = 0; k < 8; ++k) j = std::min(j, cornerJacobian(x, k, h * h * h, dc, dn));
    return j;
}

CellSolver::CellSolver(const Lattice& lat, const LatticeCells& cells, std::vector<Real> mass,
                       std::vector<unsigned char> pinned)
    : mCells(&cells), mH(lat.spacing), mMass(std::move(mass)), mPinned(std::move(pinned)) {
    const Index n = lat.size();
    if (mPinned.size() != at(n)) mPinned.assign(at(n), 0);
    mSlots.assign(at(n), {});
    for (auto& s : mSlots) s.fill(Slot{-1, 0});
    for (Index c = 0; c < cells.size(); ++c)
        for (int k = 0; k < 8; ++k) {
            const Index p = cells.corners[at(c)][static_cast<std::size_t>(k)];
            mSlots[at(p)][static_cast<std::size_t>(k)] = Slot{c, k};  // a point is corner k of at most one cell
        }
    for (Index p = 0; p < n; ++p) {
        if (mPinned[at(p)]) continue;
        const Vec3i& u = lat.coords[at(p)];
        const int colour = (u.x() & 1) | ((u.y() & 1) << 1) | ((u.z() & 1) << 2);
        mColour[static_cast<std::size_t>(colour)].push_back(p);
    }
}

/// One member's state over a solve: what is constant over it (per cell: the rest metric, the
/// start's reference for the viscosity, the volume stiffness), the cells' rotations, and the
/// body contacts each point enters.
struct CellSolver::Run {
    const CellSolver& solver;
    const CellSolveInput& in;
    const CellSolveSettings& set;
    std::vector<Vec3>& x;
    std::vector<Real>& lambda;
    const std::vector<Collider>& colliders;
    Real h, h3, dt, mu, eta, scale, meanMass = 0;
    std::vector<Mat3> pInv, metric;
    std::vector<std::array<Vec3, 8>> startLap;
    std::vector<Mat3> startFrame;
    std::vector<Mat3> rotP, rotV;  ///< R_c P_c⁻ᵀ and R̃_c
    std::vector<Eigen::Quaternion<Real>> qP, qV;
    std::vector<Real> kappa;
    /// The body contacts point p enters (CSR over the points): the contact's index, and the
    /// point's role in it, e: 1 for the contact's own point, −w_j for the surface's vertex j
    /// (the contact's gap d falls by e n · dx when the point moves by dx).
    std::vector<Index> linkStart;
    std::vector<std::pair<Index, Real>> links;

    Run(const CellSolver& s, const CellSolveMember& m, const std::vector<Collider>& noColliders)
        : solver(s), in(m.in), set(m.settings), x(*m.x), lambda(*m.lambda),
          colliders(m.in.colliders ? *m.in.colliders : noColliders) {
        const LatticeCells& cells = *solver.mCells;
        const UnitCube& cube = unitCube();
        const Index n = static_cast<Index>(solver.mMass.size()), nc = cells.size();
        h = solver.mH;
        h3 = h * h * h;
        dt = in.dt;
        mu = set.shearModulus;
        eta = set.viscosity / dt;
        scale = mu + eta + set.density * h * h / (dt * dt);  // Pa: the stiffest term at the lattice scale
        if (lambda.size() != at(nc)) lambda.assign(at(nc), 0);
        for (Real mass : solver.mMass) meanMass += mass / static_cast<Real>(std::max<Index>(n, 1));
        const std::vector<Vec3>& x0 = *in.start;
        if (in.restStretch) {
            pInv.resize(at(nc));
            metric.resize(at(nc));
            parallelFor(nc, [&](Index c) {
                pInv[at(c)] = (*in.restStretch)[at(c)].inverse();
                metric[at(c)] = pInv[at(c)] * pInv[at(c)].transpose();
            });
        }
        if (eta > 0) {
            startLap.resize(at(nc));
            startFrame.resize(at(nc));
            parallelFor(nc, [&](Index c) {
                const std::array<Vec3, 8> xc = gather(cells, x0, c);
                for (std::size_t k = 0; k < 8; ++k) {
                    Vec3 sum = Vec3::Zero();
                    for (std::size_t j = 0; j < 8; ++j) sum += cube.L[j][k] * xc[j];
                    startLap[at(c)][k] = sum;
                }
                startFrame[at(c)] = centreFrame(xc, h);
            });
        }
        // The first guess must keep every corner right-handed where the start had it so (the
        // barrier's domain): x̃ where it does, else the start.
        const bool ok = parallelReduce(
            nc, true,
            [&](bool& acc, Index c) {
                if (!acc) return;
                const Real j0 = minCornerJacobian(gather(cells, in.feasible ? *in.feasible : x0, c), h);
                if (j0 > 0 && !(minCornerJacobian(gather(cells, x, c), h) > 0)) acc = false;
            },
            [](bool a, bool b) { return a && b; });
        if (!ok) x = in.feasible ? *in.feasible : x0;
        for (Index p = 0; p < n; ++p)
            if (solver.mPinned[at(p)]) x[at(p)] = x0[at(p)];
        rotP.resize(at(nc));
        qP.resize(at(nc));
        rotV.resize(eta > 0 ? at(nc) : 0);
        qV.resize(eta > 0 ? at(nc) : 0);
        kappa.resize(at(nc));
        parallelFor(nc, [&](Index c) { kappa[at(c)] = set.volumeStiffness * scale * (*in.restVolumes)[at(c)]; });
        linkStart.assign(at(n) + 1, 0);
    }

    Real massOf(Index p) const {
        return solver.mMass[at(p)] > 0 ? solver.mMass[at(p)] : Real(1e-3) * meanMass;
    }
    Real marginOf(std::size_t ci) const {
        return in.margins && ci < in.margins->size() ? (*in.margins)[ci] : Real(0);
    }

    /// The cells' rotations: from the polar decomposition (SVD) on the first sweep, then turned
    /// toward the current frames by the warm-started iteration, as the sweeps move them little.
    void rotations(int it) {
        const LatticeCells& cells = *solver.mCells;
        parallelFor(
            cells.size(),
            [&](Index c) {
                const Mat3 F = centreFrame(gather(cells, x, c), h);
                if (mu > 0) {
                    const Mat3 M = in.restStretch ? Mat3(F * pInv[at(c)]) : F;
                    if (it == 0) qP[at(c)] = Eigen::Quaternion<Real>(polarRotationOf(M));
                    else turnToward(M, qP[at(c)]);
                    rotP[at(c)] = in.restStretch ? Mat3(qP[at(c)].toRotationMatrix() * pInv[at(c)].transpose())
                                                 : qP[at(c)].toRotationMatrix();
                }
                if (eta > 0) {
                    const Mat3& F0 = startFrame[at(c)];
                    const Real det0 = F0.determinant();
                    // the rotation over the step: of F F⁻⁻¹ (its adjugate: the same rotation)
                    const Mat3 M = det0 > 0 ? Mat3(F * (det0 * F0.inverse())) : F;
                    if (it == 0 || !(det0 > 0)) {
                        qV[at(c)] = Eigen::Quaternion<Real>(
                            det0 > 0 ? polarRotationOf(M) : Mat3(polarRotationOf(F) * polarRotationOf(F0).transpose()));
                    } else {
                        turnToward(M, qV[at(c)]);
                    }
                    rotV[at(c)] = qV[at(c)].toRotationMatrix();
                }
            },
            64);
    }

    /// The cell terms of point p's gradient and Hessian (file comment), and the corners its move
    /// must keep right-handed.
    struct Guard {
        Real j0;
        Vec3 dj;
    };
    void addCells(Index p, Vec3& g, Mat3& H, std::array<Guard, 32>& guards, int& guarded) const {
        const LatticeCells& cells = *solver.mCells;
        const UnitCube& cube = unitCube();
        const Barrier barrier{set.cornerFloor};
        for (const Slot& s : solver.mSlots[at(p)]) {
            if (s.cell < 0) continue;
            const Index c = s.cell;
            const std::size_t k = static_cast<std::size_t>(s.corner);
            const std::array<Vec3, 8> xc = gather(cells, x, c);
            if (mu > 0) {
                Vec3 lap = Vec3::Zero();
                Real lkk;
                if (in.restStretch) {
                    const Mat3& M = metric[at(c)];
                    std::array<Real, 8> l{};
                    for (std::size_t a = 0; a < 3; ++a)
                        for (std::size_t b = 0; b < 3; ++b) {
                            const Real w = M(static_cast<Index>(a), static_cast<Index>(b));
                            for (std::size_t j = 0; j < 8; ++j) l[j] += w * cube.I[a][b][j][k];
                        }
                    for (std::size_t j = 0; j < 8; ++j) lap += l[j] * xc[j];
                    lkk = l[k];
                } else {
                    for (std::size_t j = 0; j < 8; ++j) lap += cube.L[j][k] * xc[j];
                    lkk = cube.L[k][k];
                }
                const Vec3 b = Real(0.25) * Vec3(sign(s.corner, 0), sign(s.corner, 1), sign(s.corner, 2));
                g += 2 * mu * h * (lap - h * (rotP[at(c)] * b));
                H.diagonal().array() += 2 * mu * h * lkk;
            }
            if (eta > 0) {
                Vec3 lap = Vec3::Zero();
                for (std::size_t j = 0; j < 8; ++j) lap += cube.L[j][k] * xc[j];
                g += 2 * eta * h * (lap - rotV[at(c)] * startLap[at(c)][k]);
                H.diagonal().array() += 2 * eta * h * cube.L[k][k];
            }
            {
                std::array<Vec3, 8> grad;
                const Real V = hexVolumeGradient(xc, grad);
                const Real V0 = (*in.restVolumes)[at(c)], C = V / V0 - 1;
                const Vec3 gk = grad[k] / V0;
                g += (kappa[at(c)] * C + lambda[at(c)]) * gk;
                H += kappa[at(c)] * gk * gk.transpose();
            }
            // The four corner Jacobians this point enters: its own corner's and, as their
            // neighbour, those of the corners beside it.
            const Real kb = set.cornerStiffness * scale * (*in.restVolumes)[at(c)];
            for (int role = 0; role < 4; ++role) {
                const int corner = role == 0 ? s.corner : (s.corner ^ (1 << (role - 1)));
                Vec3 dc;
                std::array<Vec3, 3> dn;
                const Real J = cornerJacobian(xc, corner, h3, dc, dn);
                const Vec3 dj = role == 0 ? dc : dn[static_cast<std::size_t>(role - 1)];
                if (J > 0) guards[static_cast<std::size_t>(guarded++)] = Guard{J, dj};
                if (!(J < set.cornerFloor)) continue;
                Real d1, d2;
                barrier.eval(J, d1, d2);
                g += kb * d1 * dj;
                H += kb * d2 * dj * dj.transpose();
            }
        }
    }

    /// Colliders: a stiff penalty on the depth beyond what the point may keep, with lagged
    /// Coulomb friction (IPC's smoothed static-to-kinetic transition over eps).
    void addColliders(Index p, Vec3& g, Mat3& H) const {
        const std::vector<Vec3>& x0 = *in.start;
        const Real kc = set.contactStiffness * (massOf(p) / (dt * dt));
        for (std::size_t ci = 0; ci < colliders.size(); ++ci) {
            const Collider& col = colliders[ci];
            Vec3 grad;
            const Real phi = col.evaluate(x[at(p)], grad);
            const Real gn = grad.norm();
            if (!(gn > 0)) continue;
            const Vec3 nrm = grad / gn;
            Real allowed = 0;
            if (in.allowedDepth && !(*in.allowedDepth)[ci].empty()) allowed = (*in.allowedDepth)[ci][at(p)];
            const Real d = marginOf(ci) - phi / gn - allowed;
            if (!(d > 0)) continue;
            g -= kc * d * nrm;
            H += kc * nrm * nrm.transpose();
            if (col.friction > 0)
                addFriction(x[at(p)] - x0[at(p)] - dt * col.velocity, nrm, col.friction * (kc * d), 1, 1, g, H);
        }
    }

    /// Lagged Coulomb friction on a tangential motion u (of the contact point relative to what
    /// it touches, over the step) under the normal force limit; e: du/dx of this point, and the
    /// Hessian taken as `curvature` times the point's own (e² where it alone moves u).
    void addFriction(Vec3 u, const Vec3& nrm, Real limit, Real e, Real curvature, Vec3& g, Mat3& H) const {
        const Real eps = Real(1e-3) * h;
        u -= u.dot(nrm) * nrm;
        const Real un = u.norm();
        const Real f1 = un < eps ? (2 * un / eps - un * un / (eps * eps)) : Real(1);
        const Real stiff = un > 0 ? limit * f1 / un : limit * 2 / eps;
        g += e * stiff * u;
        H += curvature * stiff * (Mat3::Identity() - nrm * nrm.transpose());
    }

    /// The body contacts point p enters (BodyContact's energy).
    void addBodyContacts(Index p, const std::vector<BodyContact>& contacts,
                         const std::vector<std::unique_ptr<Run>>& runs, Vec3& g, Mat3& H) const {
        for (Index l = linkStart[at(p)]; l < linkStart[at(p) + 1]; ++l) {
            const BodyContact& bc = contacts[at(links[at(l)].first)];
            const Real e = links[at(l)].second;
            const Run& ra = *runs[static_cast<std::size_t>(bc.a)];
            const Run& rb = *runs[static_cast<std::size_t>(bc.b)];
            Vec3 surface = Vec3::Zero(), surfaceStart = Vec3::Zero();
            for (std::size_t j = 0; j < 3; ++j) {
                surface += bc.w[static_cast<Index>(j)] * rb.x[at(bc.q[j])];
                surfaceStart += bc.w[static_cast<Index>(j)] * (*rb.in.start)[at(bc.q[j])];
            }
            const Real d = bc.margin - bc.normal.dot(ra.x[at(bc.p)] - surface);
            if (!(d > 0)) continue;
            // The gradient is the energy's; the Hessian its separable bound over the four points
            // (Cauchy–Schwarz: (Σ_i c_i δ_i)² ≤ Σ|c_i| · Σ|c_i| δ_i², Σ|c_i| = 2), so each point's
            // step closes at most half the gap: the exact second derivative, e², sent a surface
            // vertex of weight w the gap over w (a jump of 4 voxels at w = 1/4), and the sweeps
            // of two balls meeting head-on never settled.
            const Real curvature = 2 * std::abs(e);
            g -= e * bc.stiffness * d * bc.normal;
            H += curvature * bc.stiffness * bc.normal * bc.normal.transpose();
            if (bc.friction > 0) {
                const Vec3 u = (ra.x[at(bc.p)] - (*ra.in.start)[at(bc.p)]) - (surface - surfaceStart);
                addFriction(u, bc.normal, bc.friction * bc.stiffness * d, e, curvature, g, H);
            }
        }
    }

    /// One point's Newton step (file comment); returns how far it moved.
    Real update(Index p, const std::vector<BodyContact>& contacts, const std::vector<std::unique_ptr<Run>>& runs) {
        const Real inert = massOf(p) / (dt * dt);
        Vec3 g = inert * (x[at(p)] - (*in.inertial)[at(p)]);
        Mat3 H = inert * Mat3::Identity();
        std::array<Guard, 32> guards;
        int guarded = 0;
        addCells(p, g, H, guards, guarded);
        addColliders(p, g, H);
        if (linkStart[at(p)] < linkStart[at(p) + 1]) addBodyContacts(p, contacts, runs, g, H);
        Vec3 dx = -H.ldlt().solve(g);
        if (!dx.allFinite()) return 0;
        Real alpha = 1;
        for (int i = 0; i < guarded; ++i) {
            const Real change = guards[static_cast<std::size_t>(i)].dj.dot(dx);
            const Real j0 = guards[static_cast<std::size_t>(i)].j0;
            if (j0 + change < Real(0.1) * j0) alpha = std::min(alpha, Real(0.9) * j0 / -change);
        }
        dx *= alpha;
        x[at(p)] += dx;
        return dx.norm();
    }

    /// The multipliers take each cell's remaining volume error (augmented Lagrangian); returns
    /// the largest.
    Real updateMultipliers() {
        const LatticeCells& cells = *solver.mCells;
        return parallelReduce(
            cells.size(), Real(0),
            [&](Real& acc, Index c) {
                const Real C = hexVolume(gather(cells, x, c)) / (*in.restVolumes)[at(c)] - 1;
                lambda[at(c)] += kappa[at(c)] * C;
                acc = std::max(acc, std::abs(C));
            },
            [](Real a, Real b) { return std::max(a, b); }, 64);
    }

    /// The points a collider holds at the end, and how deep they were at x̃.
    void finish(std::vector<unsigned char>& contact, std::vector<Real>& depth, CellSolveReport& report) const {
        const LatticeCells& cells = *solver.mCells;
        const std::vector<Vec3>& xt = *in.inertial;
        const Index n = static_cast<Index>(solver.mMass.size());
        std::vector<unsigned char> held(at(n), 0);  // by a collider other than a body's surface
        parallelFor(n, [&](Index p) {
            for (std::size_t ci = 0; ci < colliders.size(); ++ci) {
                const Collider& col = colliders[ci];
                Vec3 grad;
                Real phi = col.evaluate(x[at(p)], grad);
                Real gn = grad.norm();
                if (gn > 0 && marginOf(ci) - phi / gn > -Real(1e-6) * h) {
                    contact[at(p)] = 1;
                    if (!col.object) held[at(p)] = 1;
                }
                phi = col.evaluate(xt[at(p)], grad);
                gn = grad.norm();
                if (gn > 0) depth[at(p)] = std::max(depth[at(p)], marginOf(ci) - phi / gn);
            }
        });
        report.colliderContacts = std::count(held.begin(), held.end(), 1);
        report.minCornerJacobian = parallelReduce(
            cells.size(), Real(1),
            [&](Real& acc, Index c) { acc = std::min(acc, minCornerJacobian(gather(cells, x, c), h)); },
            [](Real a, Real b) { return std::min(a, b); });
    }
};

/// The contacts between the members of a solve, and each member's per-point lists of those its
/// points enter (Run::linkStart, links).
struct CellSolver::ContactSet {
    const std::vector<std::unique_ptr<Run>>& runs;
    std::vector<BodyContact> list;

    /// d: how far p is inside the margin (world units).
    Real gap(const BodyContact& bc) const {
        const Run& rb = *runs[static_cast<std::size_t>(bc.b)];
        Vec3 surface = Vec3::Zero();
        for (std::size_t j = 0; j < 3; ++j) surface += bc.w[static_cast<Index>(j)] * rb.x[at(bc.q[j])];
        return bc.margin - bc.normal.dot(runs[static_cast<std::size_t>(bc.a)]->x[at(bc.p)] - surface);
    }
    /// The largest gap, in voxels of the point's body.
    Real worstGap() const {
        Real worst = 0;
        for (const BodyContact& bc : list) worst = std::max(worst, gap(bc) / runs[static_cast<std::size_t>(bc.a)]->h);
        return worst;
    }

    /// Finds the contacts at positions x. first: at the start of the solve (and the depths at the
    /// first guess into depth, for the renderer's ramp); after: a point found inside the other
    /// body's surface keeps the contact it had (its nearest surface point now may be a side face
    /// of the other lattice's stair steps).
    void find(const BodyContactFinder& finder, const std::vector<const std::vector<Vec3>*>& x, bool first,
              std::vector<CellSolveMember>& members) {
        std::vector<BodyContact> before;
        before.swap(list);
        finder(x, list);
        auto key = [](const BodyContact& bc) { return std::make_tuple(bc.a, bc.b, bc.p); };
        auto less = [&](const BodyContact& l, const BodyContact& r) { return key(l) < key(r); };
        std::sort(before.begin(), before.end(), less);
        for (BodyContact& bc : list) {
            if (first || !(gap(bc) > bc.margin)) continue;
            const auto it = std::lower_bound(before.begin(), before.end(), bc, less);
            if (it != before.end() && key(*it) == key(bc)) bc = *it;
        }
        for (BodyContact& bc : list) {
            const Run& ra = *runs[static_cast<std::size_t>(bc.a)];
            bc.stiffness = ra.set.contactStiffness * ra.massOf(bc.p) / (ra.dt * ra.dt);
            if (first) {
                Real& depth = (*members[static_cast<std::size_t>(bc.a)].depth)[at(bc.p)];
                depth = std::max(depth, gap(bc));
            }
        }
        link();
    }

    /// Each member's lists: per point, the contacts it enters and its role e in each.
    void link() {
        for (const auto& r : runs) std::fill(r->linkStart.begin(), r->linkStart.end(), 0);
        auto each = [&](auto&& f) {
            for (std::size_t k = 0; k < list.size(); ++k) {
                const BodyContact& bc = list[k];
                f(bc.a, bc.p, static_cast<Index>(k), Real(1));
                for (std::size_t j = 0; j < 3; ++j)
                    if (bc.w[static_cast<Index>(j)] != 0) f(bc.b, bc.q[j], static_cast<Index>(k), -bc.w[static_cast<Index>(j)]);
            }
        };
        each([&](int m, Index p, Index, Real) { ++runs[static_cast<std::size_t>(m)]->linkStart[at(p) + 1]; });
        std::vector<std::vector<Index>> fill(runs.size());
        for (std::size_t i = 0; i < runs.size(); ++i) {
            Run& r = *runs[i];
            for (std::size_t p = 1; p < r.linkStart.size(); ++p) r.linkStart[p] += r.linkStart[p - 1];
            r.links.assign(at(r.linkStart.back()), {});
            fill[i].assign(r.linkStart.begin(), r.linkStart.end() - 1);
        }
        each([&](int m, Index p, Index k, Real e) {
            runs[static_cast<std::size_t>(m)]->links[at(fill[static_cast<std::size_t>(m)][at(p)]++)] = {k, e};
        });
    }

    /// Marks member i's points another body holds at the end.
    void mark(std::size_t i, std::vector<unsigned char>& contact) const {
        for (const BodyContact& bc : list)
            if (static_cast<std::size_t>(bc.a) == i && gap(bc) > -Real(1e-6) * runs[i]->h) contact[at(bc.p)] = 1;
    }
};

void solveTogether(std::vector<CellSolveMember>& members, const BodyContactFinder& find) {
    const std::vector<Collider> noColliders;
    const std::size_t count = members.size();
    std::vector<std::unique_ptr<CellSolver::Run>> runs;
    int maxIterations = 0;
    for (CellSolveMember& m : members) {
        runs.push_back(std::make_unique<CellSolver::Run>(*m.solver, m, noColliders));
        maxIterations = std::max(maxIterations, m.settings.maxIterations);
        m.depth->assign(m.solver->mMass.size(), 0);
        m.contact->assign(m.solver->mMass.size(), 0);
        m.report = CellSolveReport{};
    }
    CellSolver::ContactSet contacts{runs, {}};
    // The contacts between the bodies are found at the substep's start, where the bodies are
    // apart (found at x̃, where they overlap by their approach, a point at the rim of the overlap
    // finds a side face of the other lattice's stair steps nearest, and its push sideways tore
    // both surfaces: jelly_throw_pair's solve never converged). They are found again where the
    // bodies are after 4, 12 and every 30 sweeps, once the sweeps have pushed them about the
    // margin apart, and at convergence, the sweeps going on while one is violated: with the
    // start's alone, two 4-voxel balls meeting head-on ended 0.12 voxels inside the margin (a
    // plane's linearisation of a curved surface that squashes), 0.14 with a body in contact's
    // first guess; with these, 0.04 (every 10 sweeps: 1.4 times the time).
    constexpr int kRefinds = 2;                 // found again at convergence at most this often ...
    constexpr Real kGapTolerance = Real(0.02);  // ... while a contact is this many voxels inside its margin
    std::vector<const std::vector<Vec3>*> where(count);
    auto findWhereTheyAre = [&]() {
        for (std::size_t i = 0; i < count; ++i) where[i] = members[i].x;
        contacts.find(find, where, false, members);
    };
    int refinds = 0;
    const Index grain = 64;
    std::vector<Real> moved(count), worst(count);
    for (int it = 0; it < maxIterations; ++it) {
        if (find && it == 0) {
            for (std::size_t i = 0; i < count; ++i)
                where[i] = members[i].in.feasible ? members[i].in.feasible : members[i].in.start;
            contacts.find(find, where, true, members);
        }
        if (find && (it == 4 || it == 12 || (it > 0 && it % 30 == 0))) findWhereTheyAre();
        for (auto& r : runs) r->rotations(it);
        std::fill(moved.begin(), moved.end(), Real(0));
        for (std::size_t colour = 0; colour < 8; ++colour)
            for (std::size_t i = 0; i < count; ++i) {
                CellSolver::Run& r = *runs[i];
                const std::vector<Index>& points = r.solver.mColour[colour];
                const Index n = static_cast<Index>(points.size());
                std::vector<Real> move(at(n));
                parallelFor(n, [&](Index k) { move[at(k)] = r.update(points[at(k)], contacts.list, runs); }, grain);
                for (Real v : move) moved[i] = std::max(moved[i], v);
            }
        bool all = true;
        for (std::size_t i = 0; i < count; ++i) {
            worst[i] = runs[i]->updateMultipliers();
            CellSolveReport& rep = members[i].report;
            rep.iterations = it + 1;
            rep.lastMove = moved[i] / runs[i]->h;
            rep.maxVolumeError = worst[i];
            rep.converged = moved[i] <= members[i].settings.tolerance * runs[i]->h &&
                            worst[i] <= members[i].settings.volumeTolerance;
            all = all && rep.converged;
        }
        if (all && find && refinds < kRefinds) {
            ++refinds;
            findWhereTheyAre();
            if (contacts.worstGap() > kGapTolerance) {
                for (CellSolveMember& m : members) m.report.converged = false;
                continue;
            }
        }
        if (all) break;
    }
    for (std::size_t i = 0; i < count; ++i) {
        CellSolveMember& m = members[i];
        runs[i]->finish(*m.contact, *m.depth, m.report);
        contacts.mark(i, *m.contact);
        for (std::size_t p = 0; p < m.contact->size(); ++p)
            if (!(*m.contact)[p]) (*m.depth)[p] = 0;
        m.report.contacts = std::count(m.contact->begin(), m.contact->end(), 1);
    }
}

CellSolveReport CellSolver::solve(const CellSolveInput& in, const CellSolveSettings& set, std::vector<Vec3>& x,
                                  std::vector<Real>& lambda, std::vector<unsigned char>& contact,
                                  std::vector<Real>& depth) const {
    std::vector<CellSolveMember> one(1);
    one[0].solver = this;
    one[0].in = in;
    one[0].settings = set;
    one[0].x = &x;
    one[0].lambda = &lambda;
    one[0].contact = &contact;
    one[0].depth = &depth;
    solveTogether(one, {});
    return one[0].report;
}

}  // namespace dgv
