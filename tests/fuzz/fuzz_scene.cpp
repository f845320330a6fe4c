// libFuzzer target: the scene parser. Any input must either parse or throw dgv::InputError
// (one clear line); anything else (a crash, another exception, a sanitizer report) is a bug.
#include "io/scene_json.hpp"
#include "base/errors.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        (void)dgv::parseScene(text, "fuzz/scene.json");
    } catch (const dgv::InputError&) {
    }
    return 0;
}
