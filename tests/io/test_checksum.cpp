// The files' checksum and seal (io/checksum.hpp): the streamed checksum equals the one-shot one
// however the bytes are split, and equals the four-lane word hash that state checkpoints have
// always carried (written out here from its definition), so older checkpoints still read; a
// sealed buffer verifies, every single-bit flip anywhere in it is found, and a file without a
// seal is named as such.
#include "io/checksum.hpp"

#include "io/state_file.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <fstream>
#include <random>

using namespace dgv;

namespace {

/// The checksum's definition, word by word (little-endian hosts).
std::uint64_t reference(const std::string& s) {
    constexpr std::uint64_t kBasis = 1469598103934665603ull, kPrime = 1099511628211ull;
    std::uint64_t lane[4] = {kBasis, kBasis ^ 1, kBasis ^ 2, kBasis ^ 3};
    std::size_t i = 0;
    for (; i + 32 <= s.size(); i += 32)
        for (int l = 0; l < 4; ++l) {
            std::uint64_t w;
            std::memcpy(&w, s.data() + i + 8 * l, 8);
            const std::uint64_t x = (lane[l] ^ w) * kPrime;
            lane[l] = x ^ (x >> 29);
        }
    std::uint64_t h = kBasis;
    for (std::uint64_t l : lane) h = (h ^ l) * kPrime;
    for (; i < s.size(); ++i) h = (h ^ static_cast<unsigned char>(s[i])) * kPrime;
    h = (h ^ s.size()) * kPrime;
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebull;
    return h ^ (h >> 31);
}

std::string randomBytes(std::mt19937& rng, std::size_t n) {
    std::string s(n, '\0');
    for (char& c : s) c = static_cast<char>(rng() & 255);
    return s;
}

}  // namespace

TEST_CASE("checksum: streamed in any pieces it equals the one-shot sum and its definition", "[io][checksum]") {
    std::mt19937 rng(7);
    for (std::size_t n : {0u, 1u, 31u, 32u, 33u, 63u, 64u, 65u, 200u, 1000u}) {
        const std::string s = randomBytes(rng, n);
        const std::uint64_t whole = checksum64(s.data(), s.size());
        CHECK(whole == reference(s));
        CHECK(whole == stateChecksum(s.data(), s.size()));
        for (int trial = 0; trial < 20; ++trial) {
            Checksum64 c;
            std::size_t at = 0;
            while (at < n) {
                const std::size_t k = std::min<std::size_t>(n - at, rng() % 40);
                c.add(s.data() + at, k);
                at += k;
            }
            CHECK(c.finish() == whole);
        }
    }
}

TEST_CASE("checksum: a sealed buffer verifies and every single-bit flip in it is found", "[io][checksum]") {
    std::mt19937 rng(11);
    std::string bytes = randomBytes(rng, 100) + "comment " + checksumPlaceholder() + "\n" + randomBytes(rng, 150);
    CHECK(checksumProblem(bytes.data(), bytes.size()) == "is corrupt (its checksum does not match)");
    sealChecksum(bytes);
    CHECK(bytes.find(checksumPlaceholder()) == std::string::npos);
    CHECK(checksumProblem(bytes.data(), bytes.size()).empty());
    const std::size_t digits = findChecksumDigits(bytes.data(), bytes.size());
    REQUIRE(digits == 100 + 8 + 7);
    int found = 0, untagged = 0;
    for (std::size_t i = 0; i < bytes.size(); ++i)
        for (int bit = 0; bit < 8; ++bit) {
            std::string flipped = bytes;
            flipped[i] = static_cast<char>(flipped[i] ^ (1 << bit));
            const std::string why = checksumProblem(flipped.data(), flipped.size());
            found += why == "is corrupt (its checksum does not match)";
            untagged += why == "has no checksum";  // the tag itself hit
        }
    CHECK(untagged == 7 * 8);
    CHECK(found + untagged == static_cast<int>(bytes.size()) * 8);
    // Cut short or lengthened by a byte: found too.
    CHECK(!checksumProblem(bytes.data(), bytes.size() - 1).empty());
    const std::string longer = bytes + "x";
    CHECK(!checksumProblem(longer.data(), longer.size()).empty());
    const std::string plain = randomBytes(rng, 64);
    CHECK(checksumProblem(plain.data(), plain.size()) == "has no checksum");
}

TEST_CASE("checksum: a file is sealed in place as its bytes would be", "[io][checksum]") {
    test::TempDir dir("checksum_file");
    std::string bytes = "header " + checksumPlaceholder() + "\n" + std::string(100000, 'a') + "end\n";
    const auto path = dir.path() / "f.bin";
    std::ofstream(path, std::ios::binary) << bytes;
    sealFileChecksum(path);
    sealChecksum(bytes);
    std::ifstream in(path, std::ios::binary);
    const std::string back((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(back == bytes);
    CHECK(checksumProblem(back.data(), back.size()).empty());
}
