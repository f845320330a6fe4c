// libFuzzer target: the curve file reader (`dgv gln A B`). Any input either parses into at
// least three finite vertices or throws dgv::InputError naming the line; nothing else.
#include "io/curve_file.hpp"
#include "base/errors.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        const auto curve = dgv::parseCurveText(text, "fuzz.curve");
        if (curve.size() < 3) std::abort();  // the reader promises a closed polyline
        for (const auto& v : curve)
            if (!std::isfinite(v.x()) || !std::isfinite(v.y()) || !std::isfinite(v.z())) std::abort();
    } catch (const dgv::InputError&) {
    }
    return 0;
}
