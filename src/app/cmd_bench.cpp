// dgv bench: runs the named benchmarks (bench/bench_<name>.cpp), each printing
// "name: value unit" lines.

#include "bench/bench.hpp"
#include "app/commands.hpp"
#include "base/errors.hpp"

#include <tbb/global_control.h>

#include <functional>
#include <iostream>
#include <map>

namespace dgv::app {

int runBench(const BenchCommandOptions& options) {
    using Fn = std::function<void(std::ostream&, const bench::BenchOptions&)>;
    const std::map<std::string, Fn> built = {{"geometry", bench::geometry},
                                             {"voxelise", bench::voxelise},
                                             {"render", bench::render},
                                             {"gln", bench::gln},
                                             {"reconstruct", bench::reconstruct},
                                             {"volume", bench::volume},
                                             {"vdb", bench::vdb},
                                             {"step", bench::step},
                                             {"reparametrise", bench::reparametrise},
                                             {"contact", bench::contact}};
    std::string all;  // the names, for the error below
    for (const auto& [name, fn] : built) all += (all.empty() ? "" : ", ") + name;
    std::vector<std::string> names = options.names;
    if (names.empty())
        for (const auto& [name, fn] : built) names.push_back(name);
    for (const std::string& n : names)
        if (!built.count(n)) throw InputError("bench", n, "unknown benchmark; choose from " + all);
    bench::BenchOptions bo;
    bo.repeats = options.repeats;
    bo.quick = options.quick;
    std::cout << "bench.threads: " << tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)
              << " threads" << std::endl;
    for (const std::string& n : names) {
        std::cout.flags(std::ios::fmtflags{});  // each benchmark starts with default formatting
        std::cout.precision(6);
        bench::resetPeakRss();
        built.at(n)(std::cout, bo);
    }
    return kExitOk;
}

}  // namespace dgv::app
