// The one-solve step's minimisation (cell_solve.hpp; docs/math.md, "The one-solve step").

#include "dynamics/cell_solve.hpp"

#include "base/parallel.hpp"
#include "dynamics/stepper.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>

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

CellSolveReport CellSolver::solve(const CellSolveInput& in, const CellSolveSettings& set, std::vector<Vec3>& x,
                                  std::vector<Real>& lambda, std::vector<unsigned char>& contact,
                                  std::vector<Real>& depth) const {
    const LatticeCells& cells = *mCells;
    const UnitCube& cube = unitCube();
    const Index n = static_cast<Index>(mMass.size()), nc = cells.size();
    const Real h = mH, h3 = h * h * h, dt = in.dt;
    const std::vector<Vec3>& x0 = *in.start;
    const std::vector<Vec3>& xt = *in.inertial;
    const std::vector<Real>& v0 = *in.restVolumes;
    const std::vector<Collider> noColliders;
    const std::vector<Collider>& colliders = in.colliders ? *in.colliders : noColliders;
    const Real mu = set.shearModulus, eta = set.viscosity / dt;
    const Real scale = mu + eta + set.density * h * h / (dt * dt);  // Pa: the stiffest term at the lattice scale
    const Barrier barrier{set.cornerFloor};
    if (lambda.size() != at(nc)) lambda.assign(at(nc), 0);
    Real meanMass = 0;
    for (Real m : mMass) meanMass += m / static_cast<Real>(std::max<Index>(n, 1));
    auto marginOf = [&](std::size_t ci) { return in.margins && ci < in.margins->size() ? (*in.margins)[ci] : Real(0); };
    auto massOf = [&](Index p) { return mMass[at(p)] > 0 ? mMass[at(p)] : Real(1e-3) * meanMass; };

    // Per cell, constant over the solve: the metric M = P⁻¹P⁻ᵀ of the rest shape, and the
    // start's Σ_j L̂_jk x⁻_j per corner (the viscous term's reference).
    std::vector<Mat3> pInv(in.restStretch ? at(nc) : 0), metric(in.restStretch ? at(nc) : 0);
    if (in.restStretch)
        parallelFor(nc, [&](Index c) {
            pInv[at(c)] = (*in.restStretch)[at(c)].inverse();
            metric[at(c)] = pInv[at(c)] * pInv[at(c)].transpose();
        });
    std::vector<std::array<Vec3, 8>> startLap(eta > 0 ? at(nc) : 0);
    std::vector<Mat3> startFrame(eta > 0 ? at(nc) : 0);
    if (eta > 0)
        parallelFor(nc, [&](Index c) {
            const std::array<Vec3, 8> xc = gather(cells, x0, c);
            for (std::size_t k = 0; k < 8; ++k) {
                Vec3 s = Vec3::Zero();
                for (std::size_t j = 0; j < 8; ++j) s += cube.L[j][k] * xc[j];
                startLap[at(c)][k] = s;
            }
            startFrame[at(c)] = centreFrame(xc, h);
        });

    // The first guess must keep every corner right-handed where the start had it so (the
    // barrier's domain): x̃ where it does, else the start.
    {
        const bool ok = parallelReduce(
            nc, true,
            [&](bool& acc, Index c) {
                if (!acc) return;
                const Real j0 = minCornerJacobian(gather(cells, in.feasible ? *in.feasible : x0, c), h);
                if (j0 > 0 && !(minCornerJacobian(gather(cells, x, c), h) > 0)) acc = false;
            },
            [](bool a, bool b) { return a && b; });
        if (!ok) x = in.feasible ? *in.feasible : x0;
    }
    for (Index p = 0; p < n; ++p)
        if (mPinned[at(p)]) x[at(p)] = x0[at(p)];

    // Filled at the end: the points a collider holds, and how deep they were at x̃ (the renderer's ramp).
    depth.assign(at(n), 0);
    contact.assign(at(n), 0);

    std::vector<Mat3> rotP(at(nc)), rotV(eta > 0 ? at(nc) : 0);  // R_c P_c⁻ᵀ and R̃_c
    std::vector<Eigen::Quaternion<Real>> qP(at(nc)), qV(eta > 0 ? at(nc) : 0);
    std::vector<Real> kappa(at(nc));
    parallelFor(nc, [&](Index c) { kappa[at(c)] = set.volumeStiffness * scale * v0[at(c)]; });

    // One point's Newton step (file comment); returns how far it moved.
    auto update = [&](Index p) -> Real {
        const Real m = massOf(p), inert = m / (dt * dt);
        Vec3 g = inert * (x[at(p)] - xt[at(p)]);
        Mat3 H = inert * Mat3::Identity();
        struct Guard {
            Real j0;
            Vec3 dj;
        };
        std::array<Guard, 32> guards;
        int guarded = 0;
        for (const Slot& s : mSlots[at(p)]) {
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
                const Real V0 = v0[at(c)], C = V / V0 - 1;
                const Vec3 gk = grad[k] / V0;
                g += (kappa[at(c)] * C + lambda[at(c)]) * gk;
                H += kappa[at(c)] * gk * gk.transpose();
            }
            // The four corner Jacobians this point enters: its own corner's and, as their
            // neighbour, those of the corners beside it.
            const Real kb = set.cornerStiffness * scale * v0[at(c)];
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
        // Colliders: a stiff penalty on the depth beyond what the point may keep, with lagged
        // Coulomb friction (IPC's smoothed static-to-kinetic transition over eps).
        const Real kc = set.contactStiffness * inert;
        const Real eps = Real(1e-3) * h;
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
            const Real fn = kc * d;
            if (col.friction > 0) {
                Vec3 u = x[at(p)] - x0[at(p)] - dt * col.velocity;
                u -= u.dot(nrm) * nrm;
                const Real un = u.norm();
                const Real f1 = un < eps ? (2 * un / eps - un * un / (eps * eps)) : Real(1);
                const Real stiff = un > 0 ? col.friction * fn * f1 / un : col.friction * fn * 2 / eps;
                g += stiff * u;
                H += stiff * (Mat3::Identity() - nrm * nrm.transpose());
            }
        }
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
    };

    CellSolveReport report;
    const Index grain = 64;
    for (int it = 0; it < set.maxIterations; ++it) {
        // The cells' rotations: from the polar decomposition (SVD) on the first sweep, then turned
        // toward the current frames by the warm-started iteration, as the sweeps move them little.
        parallelFor(
            nc,
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
            grain);
        Real moved = 0;
        for (const std::vector<Index>& colour : mColour) {
            const Index count = static_cast<Index>(colour.size());
            std::vector<Real> move(at(count));
            parallelFor(count, [&](Index i) { move[at(i)] = update(colour[at(i)]); }, grain);
            for (Real v : move) moved = std::max(moved, v);
        }
        // The multipliers take each cell's remaining volume error (augmented Lagrangian).
        const Real worst = parallelReduce(
            nc, Real(0),
            [&](Real& acc, Index c) {
                const Real C = hexVolume(gather(cells, x, c)) / v0[at(c)] - 1;
                lambda[at(c)] += kappa[at(c)] * C;
                acc = std::max(acc, std::abs(C));
            },
            [](Real a, Real b) { return std::max(a, b); }, grain);
        report.iterations = it + 1;
        report.lastMove = moved / h;
        report.maxVolumeError = worst;
        if (moved <= set.tolerance * h && worst <= set.volumeTolerance) {
            report.converged = true;
            break;
        }
    }
    // The points held by a collider at the end, and how deep they were at x̃.
    parallelFor(n, [&](Index p) {
        for (std::size_t ci = 0; ci < colliders.size(); ++ci) {
            const Collider& col = colliders[ci];
            Vec3 grad;
            Real gn;
            Real phi = col.evaluate(x[at(p)], grad);
            gn = grad.norm();
            if (gn > 0 && marginOf(ci) - phi / gn > -Real(1e-6) * h) contact[at(p)] = 1;
            phi = col.evaluate(xt[at(p)], grad);
            gn = grad.norm();
            if (gn > 0) depth[at(p)] = std::max(depth[at(p)], marginOf(ci) - phi / gn);
        }
        if (!contact[at(p)]) depth[at(p)] = 0;
    });
    report.contacts = std::count(contact.begin(), contact.end(), 1);
    report.minCornerJacobian = parallelReduce(
        nc, Real(1), [&](Real& acc, Index c) { acc = std::min(acc, minCornerJacobian(gather(cells, x, c), h)); },
        [](Real a, Real b) { return std::min(a, b); });
    return report;
}

}  // namespace dgv
