// Helpers shared by the benchmarks.
#include "app/bench.hpp"

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

}  // namespace dgv::bench
