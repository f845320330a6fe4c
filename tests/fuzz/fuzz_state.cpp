// libFuzzer target: the state checkpoint reader (io/state_file.hpp; `dgv render/simulate
// --resume` read these). Any input is either a complete checkpoint, which serialises back to
// exactly the same bytes, or a reason in words; never a crash, an exception or a huge allocation.
// First byte 0: the rest is the file as is. Otherwise the rest is a payload, wrapped in a valid
// header with its size and checksum, so that mutations reach the payload parser instead of
// failing the checksum.
#include "io/state_file.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

namespace {

template <typename T>
void put(std::string& s, const T& v) {
    s.append(reinterpret_cast<const char*>(&v), sizeof v);
}

std::string wrap(const std::string& payload) {
    const std::uint64_t h = dgv::stateChecksum(payload.data(), payload.size());
    std::string s = "DGVSTATE";
    put(s, dgv::kStateFormatVersion);
    put(s, std::uint32_t(0x01020304u));
    put(s, std::uint32_t(sizeof(dgv::Real)));
    put(s, std::uint32_t(5));
    s += "0.1.0";
    put(s, std::uint64_t(42));
    put(s, std::int32_t(7));
    put(s, std::uint64_t(payload.size()));
    put(s, h);
    return s + payload;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
    const std::string bytes = data[0] == 0 ? rest : wrap(rest);
    dgv::StateCheckpoint c;
    const std::string why = dgv::parseState(bytes, c);
    if (why.empty() && dgv::serializeState(c) != bytes) std::abort();  // a lossless round trip
    return 0;
}
