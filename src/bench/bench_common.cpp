// Helpers shared by the benchmarks.
#include "bench/bench.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

namespace dgv::bench {

double peakRssMiB() {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return -1;
}

void resetPeakRss() {
    std::ofstream clear("/proc/self/clear_refs");
    if (clear) clear << "5";
}

ForceField gentleVortex() {
    ForceField f;
    ForceTerm t;
    t.kind = ForceKind::Vortex;
    t.centre = Vec3(-0.2, 0, 0);
    t.axis = Vec3::UnitY();
    t.radius = 0.6;
    t.strength = Keyframes::constant(0.6);
    f.add(t);
    return f;
}

Lattice ballLattice(Real radius, Real h) {
    const int n = static_cast<int>(std::ceil(2 * radius)) + 3;
    const Vec3i dims(n, n, n);
    const Vec3 c = Vec3::Constant(Real(n - 1) / 2);
    std::vector<unsigned char> mask(static_cast<std::size_t>(dims.prod()), 0);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if ((Vec3(i, j, k) - c).norm() <= radius) mask[static_cast<std::size_t>(i + n * (j + n * k))] = 1;
    return buildLattice(-h * c, h, dims, mask);
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace dgv::bench
