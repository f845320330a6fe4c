// Placeholder until the work behind 'dgv bench gln' lands.
#include "app/bench.hpp"
#include "base/errors.hpp"

namespace dgv::bench {
void gln(std::ostream&, const BenchOptions&) { throw RuntimeError("dgv bench gln: not built yet"); }
}  // namespace dgv::bench
