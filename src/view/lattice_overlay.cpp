#include "view/lattice_overlay.hpp"

namespace dgv {

Vec3 latticeOutward(const Lattice& lat, const std::vector<Vec3>& x, Index p) {
    const auto& nb = lat.neighbours[static_cast<std::size_t>(p)];
    Vec3 out = Vec3::Zero();
    for (int slot = 0; slot < 6; ++slot) {
        if (nb[static_cast<std::size_t>(slot)] != kNoPoint) continue;
        const Index opposite = nb[static_cast<std::size_t>(slot ^ 1)];  // slots pair as -i/+i, -j/+j, -k/+k
        if (opposite != kNoPoint) out += x[static_cast<std::size_t>(p)] - x[static_cast<std::size_t>(opposite)];
    }
    return out;
}

std::vector<Vec3> latticeOverlayPoints(const Lattice& lat, const std::vector<Vec3>& x,
                                       const std::vector<Index>& candidates, const Vec3* eye) {
    std::vector<Vec3> dots;
    dots.reserve(candidates.size());
    for (Index p : candidates) {
        const Vec3& xp = x[static_cast<std::size_t>(p)];
        if (eye && latticeOutward(lat, x, p).dot(*eye - xp) < 0) continue;
        dots.push_back(xp);
    }
    return dots;
}

}  // namespace dgv
