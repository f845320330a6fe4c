// dgv gln: placeholder until the linking-number work lands.
#include "app/commands.hpp"
#include "base/errors.hpp"

namespace dgv::app {
int runGln(const GlnOptions&) { throw RuntimeError("dgv gln: not built yet: linking numbers are a coming milestone"); }
}  // namespace dgv::app
