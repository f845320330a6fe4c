#include "sim/contact_highlight.hpp"

#include "base/parallel.hpp"

#include <algorithm>

namespace dgv {

void ContactHistory::observe(const std::vector<unsigned char>& contact) {
    if (mAge.size() != contact.size()) mAge.assign(contact.size(), kNever);
    for (std::size_t p = 0; p < contact.size(); ++p) {
        if (contact[p]) mAge[p] = 0;
        else if (mAge[p] < kNever) ++mAge[p];
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
