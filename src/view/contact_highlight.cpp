#include "view/contact_highlight.hpp"

#include "base/image.hpp"
#include "base/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace dgv {

HighlightColours contrastingHighlight(const Vec3& surface) {
    static const HighlightColours kPairs[] = {
        {Vec3(1.0, 0.85, 0.1), Vec3(0.9, 0.05, 0.02)},  // warm
        {Vec3(0.55, 0.95, 1.0), Vec3(0.0, 0.25, 1.0)},  // cool
        {Vec3(0.75, 1.0, 0.2), Vec3(0.02, 0.6, 0.05)},  // green
        {Vec3(1.0, 0.6, 1.0), Vec3(0.75, 0.0, 0.8)},    // magenta
    };
    auto encoded = [](const Vec3& c) { return Vec3(encodeSrgb(c.x()), encodeSrgb(c.y()), encodeSrgb(c.z())); };
    const Vec3 s = encoded(surface);
    const HighlightColours* best = &kPairs[0];
    Real bestDistance = -1;
    for (const HighlightColours& pair : kPairs) {
        const Real d = (encoded(pair.high) - s).norm();
        if (d > bestDistance + 1e-9) {
            bestDistance = d;
            best = &pair;
        }
    }
    return *best;
}

void ContactHistory::observe(const std::vector<unsigned char>& contact) {
    if (mAge.size() != contact.size()) mAge.assign(contact.size(), kNever);
    for (std::size_t p = 0; p < contact.size(); ++p) {
        if (contact[p])
            mAge[p] = 0;
        else if (mAge[p] < kNever)
            ++mAge[p];
    }
}

std::vector<Real> contactPointScalar(ContactHighlightMode mode, const std::vector<unsigned char>& contact,
                                     const std::vector<Real>& depth, const std::vector<int>& age, int fadeFrames,
                                     Real edge) {
    std::vector<Real> s(contact.size(), Real(0));
    if (mode == ContactHighlightMode::Depth) {
        constexpr Real kTiny = 1e-12;
        const Real e = std::max(edge, kTiny);
        for (std::size_t p = 0; p < contact.size(); ++p)
            s[p] = contact[p] ? std::max(p < depth.size() ? depth[p] : Real(0), Real(0)) + e : -e;
    } else if (mode == ContactHighlightMode::Recent) {
        const int fade = std::max(fadeFrames, 1);
        for (std::size_t p = 0; p < contact.size(); ++p)
            s[p] = (p < age.size() && age[p] < fade) ? Real(fade - age[p]) / Real(fade) : Real(-1);
    }
    return s;
}

void spreadPointScalar(const Lattice& lat, std::vector<Real>& scalar, int rings) {
    if (rings <= 0 || scalar.size() != static_cast<std::size_t>(lat.size()) || lat.neighbours.size() != scalar.size())
        return;
    const std::size_t n = scalar.size();
    // Each point keeps its best source (value, hops); one Jacobi sweep per ring, so the
    // result does not depend on the visiting order.
    std::vector<Real> src(n, 0);
    std::vector<int> hops(n, 0);
    std::vector<unsigned char> seed(n, 0);
    for (std::size_t p = 0; p < n; ++p)
        if (scalar[p] > 0) {
            src[p] = scalar[p];
            seed[p] = 1;
        }
    const Real denom = Real(rings + 1);
    auto weight = [&](Real a, int d) { return a * (1 - Real(d) / denom); };
    for (int ring = 1; ring <= rings; ++ring) {
        std::vector<Real> nextSrc = src;
        std::vector<int> nextHops = hops;
        parallelFor(static_cast<Index>(n), [&](Index pi) {
            const std::size_t p = static_cast<std::size_t>(pi);
            if (seed[p]) return;
            Real best = src[p] > 0 ? weight(src[p], hops[p]) : Real(0);
            for (const Index q : lat.neighbours[p]) {
                if (q == kNoPoint) continue;
                const std::size_t qi = static_cast<std::size_t>(q);
                if (!(src[qi] > 0) || hops[qi] + 1 > rings) continue;
                const Real w = weight(src[qi], hops[qi] + 1);
                if (w > best) {
                    best = w;
                    nextSrc[p] = src[qi];
                    nextHops[p] = hops[qi] + 1;
                }
            }
        });
        src.swap(nextSrc);
        hops.swap(nextHops);
    }
    for (std::size_t p = 0; p < n; ++p)
        if (!seed[p] && src[p] > 0) scalar[p] = weight(src[p], hops[p]);
    // Just beyond the reach the value stays below zero, but only by a quarter of the last ring's:
    // the interpolated value then crosses zero four fifths of a cell out instead of a few
    // percent, so the highlight fades over the whole cell rather than stepping at the cells.
    std::vector<Real> rim(n, 0);
    parallelFor(static_cast<Index>(n), [&](Index pi) {
        const std::size_t p = static_cast<std::size_t>(pi);
        if (scalar[p] > 0) return;
        Real best = 0;
        for (const Index q : lat.neighbours[p])
            if (q != kNoPoint && !seed[static_cast<std::size_t>(q)] && scalar[static_cast<std::size_t>(q)] > 0)
                best = std::max(best, scalar[static_cast<std::size_t>(q)]);
        if (best > 0) rim[p] = -0.25 * best;
    });
    for (std::size_t p = 0; p < n; ++p)
        if (rim[p] < 0) scalar[p] = std::max(scalar[p], rim[p]);
}

void smoothVertexScalar(const std::vector<std::array<int, 3>>& triangles, std::vector<Real>& value, int passes) {
    const std::size_t n = value.size();
    if (passes <= 0 || n == 0) return;
    // Edge neighbours in CSR form (each edge once per direction; shared edges of two triangles
    // counted twice, which only weights them more, the same way every pass).
    std::vector<int> count(n + 1, 0);
    for (const auto& t : triangles)
        for (int k = 0; k < 3; ++k)
            if (t[k] >= 0 && static_cast<std::size_t>(t[k]) < n) count[static_cast<std::size_t>(t[k]) + 1] += 2;
    for (std::size_t v = 0; v < n; ++v) count[v + 1] += count[v];
    std::vector<int> next(count.begin(), count.end() - 1), nb(static_cast<std::size_t>(count[n]));
    for (const auto& t : triangles)
        for (int k = 0; k < 3; ++k) {
            const int a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
            if (a < 0 || static_cast<std::size_t>(a) >= n) continue;
            nb[static_cast<std::size_t>(next[static_cast<std::size_t>(a)]++)] = b;
            nb[static_cast<std::size_t>(next[static_cast<std::size_t>(a)]++)] = c;
        }
    std::vector<Real> out(n);
    for (int pass = 0; pass < passes; ++pass) {
        parallelFor(static_cast<Index>(n), [&](Index vi) {
            const std::size_t v = static_cast<std::size_t>(vi);
            out[v] = value[v];
            if (!(value[v] > 0)) return;
            Real sum = value[v];
            int m = 1;
            for (int k = count[v]; k < count[v + 1]; ++k) {
                const int q = nb[static_cast<std::size_t>(k)];
                if (q < 0 || static_cast<std::size_t>(q) >= n) continue;
                sum += std::max(value[static_cast<std::size_t>(q)], Real(0));
                ++m;
            }
            out[v] = std::max(sum / m, Real(1e-12));
        });
        value.swap(out);
    }
}

void footprintScalar(const std::vector<Vec3>& vertices, const std::vector<Vec3>& points,
                     const std::vector<Real>& pointValue, Real radius, Real edge, std::vector<Real>& vertexValue) {
    vertexValue.assign(vertices.size(), -std::max(edge, Real(1e-12)));
    if (!(radius > 0)) return;
    // The highlighted points in a hash grid of cells one radius wide: a vertex looks at the
    // 27 cells around its own.
    struct KeyHash {
        std::size_t operator()(const Vec3i& k) const {
            return static_cast<std::size_t>(k.x()) * 73856093u ^ static_cast<std::size_t>(k.y()) * 19349663u ^
                   static_cast<std::size_t>(k.z()) * 83492791u;
        }
    };
    auto cellOf = [&](const Vec3& x) {
        return Vec3i(static_cast<int>(std::floor(x.x() / radius)), static_cast<int>(std::floor(x.y() / radius)),
                     static_cast<int>(std::floor(x.z() / radius)));
    };
    std::unordered_map<Vec3i, std::vector<std::size_t>, KeyHash> grid;
    for (std::size_t p = 0; p < points.size() && p < pointValue.size(); ++p)
        if (pointValue[p] > 0 && points[p].allFinite()) grid[cellOf(points[p])].push_back(p);
    if (grid.empty()) return;
    parallelFor(static_cast<Index>(vertices.size()), [&](Index vi) {
        const std::size_t v = static_cast<std::size_t>(vi);
        const Vec3i c = cellOf(vertices[v]);
        Real best = 0;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const auto it = grid.find(c + Vec3i(dx, dy, dz));
                    if (it == grid.end()) continue;
                    for (std::size_t p : it->second) {
                        const Real d = (points[p] - vertices[v]).norm();
                        if (d < radius) best = std::max(best, pointValue[p] * (1 - d / radius));
                    }
                }
        if (best > 0) vertexValue[v] = best;
    });
}

void pointScalarToVertices(const MeshEmbedding& emb, const std::vector<Real>& pointValue,
                           std::vector<Real>& vertexValue) {
    const std::size_t nv = emb.size();
    vertexValue.resize(nv);
    if (pointValue.empty()) {
        std::fill(vertexValue.begin(), vertexValue.end(), Real(0));
        return;
    }
    parallelFor(static_cast<Index>(nv), [&](Index vi) {
        const std::size_t v = static_cast<std::size_t>(vi);
        if (emb.trilinear(v)) {
            Real s = 0;
            for (std::size_t k = 0; k < 8; ++k)
                s += emb.weights[v][k] * pointValue[static_cast<std::size_t>(emb.corners[v][k])];
            vertexValue[v] = s;
        } else {
            vertexValue[v] = pointValue[static_cast<std::size_t>(emb.anchor[v])];
        }
    });
}

}  // namespace dgv
