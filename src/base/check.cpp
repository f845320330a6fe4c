#include "base/check.hpp"

#include <cstdio>
#include <cstdlib>

namespace dgv::detail {

void checkFailed(const char* file, int line, const std::string& message) {
    std::fprintf(stderr, "dgv: internal error at %s:%d: %s\n", file, line, message.c_str());
    std::fflush(stderr);
    std::abort();
}

}  // namespace dgv::detail
