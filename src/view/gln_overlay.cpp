#include "view/gln_overlay.hpp"

namespace dgv {

bool loopFacesPoint(const ClosedCurve& c, const Vec3& eye) {
    if (c.empty()) return false;
    Vec3 area = Vec3::Zero(), centroid = Vec3::Zero();
    for (std::size_t i = 0; i < c.size(); ++i) {
        area += c[i].cross(c[(i + 1) % c.size()]);
        centroid += c[i];
    }
    centroid /= static_cast<Real>(c.size());
    return area.dot(eye - centroid) > 0;
}

std::vector<ClosedCurve> glnOverlayLoops(const GlnNetwork& network, GlnLoopSet set, const std::vector<Vec3>& x,
                                         const std::vector<unsigned char>& contact, const Vec3* eye) {
    std::vector<ClosedCurve> loops;
    auto keep = [&](ClosedCurve&& c) {
        if (set == GlnLoopSet::Contact || !eye || loopFacesPoint(c, *eye)) loops.push_back(std::move(c));
    };
    if (set == GlnLoopSet::Coarse) {
        for (std::size_t k = 0; k < network.coarse().size(); ++k) keep(network.coarseCurve(k, x));
        return loops;
    }
    for (std::size_t k = 0; k < network.fine().size(); ++k) {
        const std::size_t centre = static_cast<std::size_t>(network.fine()[k].centre);
        if (set == GlnLoopSet::Contact && (centre >= contact.size() || !contact[centre])) continue;
        keep(network.fineCurve(k, x));
    }
    return loops;
}

}  // namespace dgv
