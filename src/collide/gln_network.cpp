// GLN collision networks and the contact set R (gln_network.hpp; docs/gln.md).

#include "collide/gln_network.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"
#include "collide/box_tree.hpp"
#include "collide/gln_farfield.hpp"

#include <algorithm>
#include <cmath>

namespace dgv {

namespace {

/// Outward rest normal of a boundary point: away from the centroid of the material points in
/// the 5×5×5 block around it (voxel units); the missing 6-neighbour directions if that is zero.
Vec3 restNormal(const Lattice& lat, Index p) {
    const Vec3i& u = lat.coords[at(p)];
    Vec3 s = Vec3::Zero();
    for (int k = -2; k <= 2; ++k)
        for (int j = -2; j <= 2; ++j)
            for (int i = -2; i <= 2; ++i) {
                const Vec3i v = u + Vec3i(i, j, k);
                if (lat.pointAt(v) != kNoPoint) s -= Vec3(i, j, k);
            }
    if (s.norm() < 1e-9) {
        static const Vec3i dirs[6] = {Vec3i(-1, 0, 0), Vec3i(1, 0, 0),  Vec3i(0, -1, 0),
                                      Vec3i(0, 1, 0),  Vec3i(0, 0, -1), Vec3i(0, 0, 1)};
        for (int d = 0; d < 6; ++d)
            if (lat.neighbours[at(p)][static_cast<std::size_t>(d)] == kNoPoint) s += dirs[d].cast<Real>();
    }
    if (s.norm() < 1e-9) s = Vec3::UnitZ();
    return s.normalized();
}

/// A unit vector normal to unit n: n × (the axis least aligned with n).
Vec3 tangentOf(const Vec3& n) {
    int k = 0;
    for (int i = 1; i < 3; ++i)
        if (std::abs(n[i]) < std::abs(n[k])) k = i;
    return n.cross(Vec3::Unit(k)).normalized();
}

Box3 boxOf(const ClosedCurve& c) {
    Box3 b;
    for (const Vec3& p : c) b.extend(p);
    return b;
}

}  // namespace

ContactSetReport& ContactSetReport::operator+=(const ContactSetReport& o) {
    colliderLoops += o.colliderLoops;
    coarseRings += o.coarseRings;
    coarseLinked += o.coarseLinked;
    fineRings += o.fineRings;
    candidatePairs += o.candidatePairs;
    linkedPairs += o.linkedPairs;
    undecidedPairs += o.undecidedPairs;
    contacts += o.contacts;
    return *this;
}

bool loopsLinked(const ClosedCurve& a, const ClosedCurve& b, bool* undecided) {
    if (undecided) *undecided = false;
    GlnSettings st;
    st.farField = false;
    const GlnResult r = linkingNumber(a, b, st);
    if (r.status != GlnStatus::Certified) {
        if (undecided) *undecided = true;
        return true;
    }
    return r.linking != 0;
}

std::vector<ClosedCurve> needleLoops(const std::vector<Vec3>& x, const std::vector<Index>& points,
                                     const SignedDistance& phi, Real h, const GlnNetworkSettings& st,
                                     std::vector<Index>* owner) {
    const Index m = static_cast<Index>(points.size());
    std::vector<ClosedCurve> loops(at(4 * m));
    parallelFor(4 * m, [&](Index k) {
        const Vec3& xp = x[at(points[at(k / 4)])];
        Vec3 g;
        const Real v = phi(xp, &g);
        const Real gn = g.norm();
        if (!(gn > 0) || !std::isfinite(v)) return;
        const Real d = v / gn;
        if (!(d < st.needleMargin * h)) return;
        const Vec3 n = g / gn;
        const Vec3 s = xp - d * n;  // foot on the collider surface
        // a loop on each side along two tangents: t, −t, n × t, −n × t
        const Vec3 t0 = tangentOf(n);
        const Vec3 t1 = k % 4 < 2 ? t0 : Vec3(n.cross(t0));
        const Vec3 t = (k % 2 == 0 ? Real(1) : Real(-1)) * t1;
        const Real eps = st.needleTop * h, depth = st.needleDepth * h;
        // the far side follows the surface (its own foot), so a curved collider keeps the whole
        // rectangle inside
        const Vec3 f = s + st.needleWidth * h * t;
        Vec3 gf;
        const Real vf = phi(f, &gf);
        const Real gfn = gf.norm();
        Vec3 nf = n, sf = f;
        if (gfn > 0 && std::isfinite(vf)) {
            nf = gf / gfn;
            sf = f - (vf / gfn) * nf;
        }
        loops[at(k)] = {s - eps * n, s - depth * n, sf - depth * nf, sf - eps * nf};
    });
    std::vector<ClosedCurve> out;
    if (owner) owner->clear();
    for (Index k = 0; k < 4 * m; ++k) {
        if (loops[at(k)].empty()) continue;
        out.push_back(std::move(loops[at(k)]));
        if (owner) owner->push_back(points[at(k / 4)]);
    }
    return out;
}

GlnNetwork::GlnNetwork(const Lattice& lat, const GlnNetworkSettings& st) : mLat(lat), mSet(st) {
    const Index n = lat.size();
    mFineOf.assign(at(n), -1);
    const std::vector<Index> bpoints = boundaryPoints(lat);
    std::vector<unsigned char> boundary(at(n), 0);
    for (Index p : bpoints) boundary[at(p)] = 1;
    std::vector<Vec3> normal(bpoints.size());
    parallelFor(static_cast<Index>(bpoints.size()), [&](Index k) { normal[at(k)] = restNormal(lat, bpoints[at(k)]); });

    // Fine rings: one boundary neighbour per 45° sector of the rest tangent plane, the one
    // closest to the plane (then the nearer one).
    std::vector<NetworkRing> fine(bpoints.size());
    std::vector<unsigned char> ok(bpoints.size(), 0);
    parallelFor(static_cast<Index>(bpoints.size()), [&](Index k) {
        const Index p = bpoints[at(k)];
        const Vec3 nrm = normal[at(k)];
        const Vec3 e1 = tangentOf(nrm), e2 = nrm.cross(e1);
        const Vec3i& u = lat.coords[at(p)];
        Index best[8];
        Real bestScore[8];
        Real angle[8];
        for (int s = 0; s < 8; ++s) best[s] = kNoPoint, bestScore[s] = HUGE_VAL, angle[s] = 0;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    if (dx == 0 && dy == 0 && dz == 0) continue;
                    const Index q = lat.pointAt(u + Vec3i(dx, dy, dz));
                    if (q == kNoPoint || !boundary[at(q)]) continue;
                    const Vec3 d(dx, dy, dz);
                    const Real dn = d.dot(nrm);
                    const Vec3 dt = d - dn * nrm;
                    if (dt.norm() < 0.5 * d.norm()) continue;  // mostly along the normal
                    const Real th = std::atan2(dt.dot(e2), dt.dot(e1));
                    int sector = static_cast<int>(std::lround(th / (M_PI / 4)));
                    sector = ((sector % 8) + 8) % 8;
                    const Real score = std::abs(dn) / dt.norm() + 1e-3 * d.squaredNorm();
                    if (score < bestScore[sector]) {
                        bestScore[sector] = score;
                        best[sector] = q;
                        angle[sector] = th;
                    }
                }
        std::vector<std::pair<Real, Index>> ring;
        for (int s = 0; s < 8; ++s)
            if (best[s] != kNoPoint) ring.emplace_back(angle[s], best[s]);
        if (ring.size() < 3) return;
        std::sort(ring.begin(), ring.end());
        Real gap = 0;  // the centre is enclosed when no angular gap reaches π
        for (std::size_t i = 0; i < ring.size(); ++i) {
            const Real a0 = ring[i].first;
            const Real a1 = i + 1 < ring.size() ? ring[i + 1].first : ring[0].first + 2 * M_PI;
            gap = std::max(gap, a1 - a0);
        }
        if (!(gap < M_PI - 1e-9)) return;
        NetworkRing r;
        r.centre = p;
        for (const auto& e : ring) r.points.push_back(e.second);
        r.interior = {p};
        fine[at(k)] = std::move(r);
        ok[at(k)] = 1;
    });
    for (std::size_t k = 0; k < bpoints.size(); ++k) {
        if (!ok[k]) {
            ++mWithoutRing;
            continue;
        }
        mFineOf[at(bpoints[k])] = static_cast<Index>(mFine.size());
        mFine.push_back(std::move(fine[k]));
    }

    // Coarse rings: a greedy cover of the boundary by centres coarseSpacing apart (index order).
    const Real R = st.coarseRadius, spacing2 = st.coarseSpacing * st.coarseSpacing;
    std::vector<std::size_t> centres;
    for (std::size_t k = 0; k < bpoints.size(); ++k) {
        const Vec3 u = lat.coords[at(bpoints[k])].cast<Real>();
        bool covered = false;
        for (std::size_t c = centres.size(); c-- > 0 && !covered;)
            covered = (lat.coords[at(bpoints[centres[c]])].cast<Real>() - u).squaredNorm() < spacing2;
        if (!covered) centres.push_back(k);
    }
    std::vector<NetworkRing> coarse(centres.size());
    std::vector<unsigned char> cok(centres.size(), 0);
    const int reach = static_cast<int>(std::ceil(R + 0.5));
    parallelFor(static_cast<Index>(centres.size()), [&](Index c) {
        const std::size_t k = centres[at(c)];
        const Index p = bpoints[k];
        const Vec3 nrm = normal[k];
        const Vec3 e1 = tangentOf(nrm), e2 = nrm.cross(e1);
        const Vec3 u = lat.coords[at(p)].cast<Real>();
        NetworkRing r;
        r.centre = p;
        constexpr int kAngles = 16;
        for (int a = 0; a < kAngles; ++a) {
            const Real th = 2 * M_PI * a / kAngles;
            const Vec3 target = u + R * (std::cos(th) * e1 + std::sin(th) * e2);
            const Vec3i t0(static_cast<int>(std::lround(target.x())), static_cast<int>(std::lround(target.y())),
                           static_cast<int>(std::lround(target.z())));
            Index bestQ = kNoPoint;
            Real bestD = HUGE_VAL;
            for (int dz = -2; dz <= 2; ++dz)
                for (int dy = -2; dy <= 2; ++dy)
                    for (int dx = -2; dx <= 2; ++dx) {
                        const Index q = lat.pointAt(t0 + Vec3i(dx, dy, dz));
                        if (q == kNoPoint || !boundary[at(q)] || q == p) continue;
                        const Real d = (lat.coords[at(q)].cast<Real>() - target).squaredNorm();
                        if (d < bestD) bestD = d, bestQ = q;
                    }
            if (bestQ == kNoPoint) continue;
            if (!r.points.empty() && (r.points.back() == bestQ)) continue;
            r.points.push_back(bestQ);
        }
        while (r.points.size() > 1 && r.points.front() == r.points.back()) r.points.pop_back();
        if (r.points.size() < 3) return;
        const Vec3i& uc = lat.coords[at(p)];
        for (int dz = -reach; dz <= reach; ++dz)
            for (int dy = -reach; dy <= reach; ++dy)
                for (int dx = -reach; dx <= reach; ++dx) {
                    const Index q = lat.pointAt(uc + Vec3i(dx, dy, dz));
                    if (q == kNoPoint || !boundary[at(q)]) continue;
                    if (Vec3(dx, dy, dz).norm() <= R + 0.5) r.interior.push_back(q);
                }
        std::sort(r.interior.begin(), r.interior.end());
        coarse[at(c)] = std::move(r);
        cok[at(c)] = 1;
    });
    for (std::size_t c = 0; c < centres.size(); ++c)
        if (cok[c]) mCoarse.push_back(std::move(coarse[c]));
}

ClosedCurve GlnNetwork::fineCurve(std::size_t k, const std::vector<Vec3>& x) const {
    const NetworkRing& r = mFine[k];
    const Vec3& c = x[at(r.centre)];
    ClosedCurve out;
    out.reserve(r.points.size());
    for (Index q : r.points) out.push_back(c + mSet.fineRadius * (x[at(q)] - c));
    return out;
}

ClosedCurve GlnNetwork::coarseCurve(std::size_t k, const std::vector<Vec3>& x) const {
    const NetworkRing& r = mCoarse[k];
    ClosedCurve out;
    out.reserve(r.points.size());
    for (std::size_t i = 0; i < r.points.size(); ++i) {
        const Vec3& a = x[at(r.points[i])];
        const Vec3& b = x[at(r.points[(i + 1) % r.points.size()])];
        out.push_back(0.5 * (a + b));  // midpoints: never a lattice point's image under an affine map
    }
    return out;
}

ContactSetReport GlnNetwork::contactSet(const std::vector<Vec3>& x, const SignedDistance& phi,
                                        std::vector<unsigned char>& R) const {
    DGV_CHECK_EQ(static_cast<Index>(x.size()), mLat.size());
    ContactSetReport rep;
    R.assign(x.size(), 0);
    std::vector<Index> pts;
    pts.reserve(mFine.size());
    for (const NetworkRing& r : mFine) pts.push_back(r.centre);
    const std::vector<ClosedCurve> loops = needleLoops(x, pts, phi, mLat.spacing, mSet);
    rep.colliderLoops = static_cast<Index>(loops.size());
    if (loops.empty()) return rep;
    std::vector<Box3> boxes(loops.size());
    for (std::size_t i = 0; i < loops.size(); ++i) boxes[i] = boxOf(loops[i]);
    const BoxTree tree(boxes);

    struct RingResult {
        unsigned char linked = 0;
        Index pairs = 0, linkedPairs = 0, undecided = 0;
    };
    // One ring against the collider loops whose boxes overlap its own: linked at the first
    // linked pair (the rules only need "some loop links it").
    auto evaluate = [&](const ClosedCurve& ring, RingResult& res) {
        std::vector<Index> cand;
        tree.overlapping(boxOf(ring), cand);  // the root's box first: most rings stop there
        for (Index j : cand) {
            bool und = false;
            ++res.pairs;
            if (loopsLinked(ring, loops[at(j)], &und)) {
                res.linked = 1;
                ++res.linkedPairs;
                if (und) ++res.undecided;
                return;
            }
        }
    };

    std::vector<unsigned char> candidate;  // fine rings to evaluate
    if (mSet.coarseToFine) {
        std::vector<RingResult> cr(mCoarse.size());
        parallelFor(static_cast<Index>(mCoarse.size()), [&](Index k) { evaluate(coarseCurve(at(k), x), cr[at(k)]); });
        // eq 91 for every unlinked coarse ring, then eq 90 for every linked one
        std::vector<unsigned char> inR(x.size(), 0);
        for (std::size_t k = 0; k < mCoarse.size(); ++k)
            if (!cr[k].linked)
                for (Index q : mCoarse[k].interior) inR[at(q)] = 0;
        for (std::size_t k = 0; k < mCoarse.size(); ++k) {
            rep.candidatePairs += cr[k].pairs;
            rep.linkedPairs += cr[k].linkedPairs;
            rep.undecidedPairs += cr[k].undecided;
            if (!cr[k].linked) continue;
            ++rep.coarseLinked;
            for (Index q : mCoarse[k].interior) inR[at(q)] = 1;
        }
        rep.coarseRings = static_cast<Index>(mCoarse.size());
        candidate.assign(mFine.size(), 0);
        for (std::size_t k = 0; k < mFine.size(); ++k) candidate[k] = inR[at(mFine[k].centre)];
        R = inR;  // points of linked coarse rings without a fine ring stay in R (eq 90)
    } else {
        candidate.assign(mFine.size(), 1);
    }
    std::vector<RingResult> fr(mFine.size());
    parallelFor(static_cast<Index>(mFine.size()), [&](Index k) {
        if (candidate[at(k)]) evaluate(fineCurve(at(k), x), fr[at(k)]);
    });
    // eqs 91 then 90 at the fine level; Interior = {centre}, so the order within the level is moot
    for (std::size_t k = 0; k < mFine.size(); ++k) {
        if (!candidate[k]) continue;
        ++rep.fineRings;
        rep.candidatePairs += fr[k].pairs;
        rep.linkedPairs += fr[k].linkedPairs;
        rep.undecidedPairs += fr[k].undecided;
        R[at(mFine[k].centre)] = fr[k].linked;
    }
    for (unsigned char f : R) rep.contacts += f ? 1 : 0;
    return rep;
}

}  // namespace dgv
