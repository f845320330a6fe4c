// Placeholder until the work behind 'dgv bench reconstruct' lands.
#include "app/bench.hpp"
#include "base/errors.hpp"

namespace dgv::bench {
void reconstruct(std::ostream&, const BenchOptions&) { throw RuntimeError("dgv bench reconstruct: not built yet"); }
}  // namespace dgv::bench
