#pragma once
/// @file checksum.hpp
/// @brief The 64-bit checksum of dgv's files, and the seal a cache file carries inside itself.
///
/// A state checkpoint stores its payload's checksum in its header. A cache file (VDB, PLY, OBJ,
/// glTF) stores its own: a tag, "dgvsum:", followed by 16 hex digits, where the format allows
/// text (the VDB file's metadata, a PLY or OBJ comment, the glTF asset's extras). The digits are
/// the checksum of the whole file with the digits themselves read as '0', so a writer puts the
/// tag and 16 zeros in the file, hashes what it wrote and patches the digits in place, and a
/// reader checks a file before any decoder sees it: a flipped bit anywhere, a truncation or a
/// foreign block is found by the bytes alone (docs/robustness.md, "Seals").

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace dgv {

/// FNV-1a's step on four lanes of little-endian 64-bit words, folded with the tail bytes and the
/// length and finished with splitmix64's mixer: 3.5 ms for 14 MB (byte-wise FNV-1a: 17 ms).
class Checksum64 {
public:
    void add(const char* data, std::size_t n);
    std::uint64_t finish() const;

private:
    void block(const char* p);
    static constexpr std::uint64_t kBasis = 1469598103934665603ull;  // FNV-1a's offset basis
    std::uint64_t lane_[4] = {kBasis, kBasis ^ 1, kBasis ^ 2, kBasis ^ 3};
    char carry_[32] = {};
    std::size_t carried_ = 0;
    std::uint64_t length_ = 0;
};

/// Checksum64 of n bytes.
std::uint64_t checksum64(const char* data, std::size_t n);

/// "dgvsum:" and 16 zeros: what a writer puts where the seal goes.
std::string checksumPlaceholder();

/// The offset of the first seal's digits in `data` (after "dgvsum:"), or npos when there is none.
std::size_t findChecksumDigits(const char* data, std::size_t n);

/// The 16 lower-case hex digits of `sum`.
std::string checksumDigits(std::uint64_t sum);

/// The checksum of `data` with the 16 bytes at `digits` read as '0'.
std::uint64_t sealedChecksum(const char* data, std::size_t n, std::size_t digits);

/// Patches the first placeholder in `bytes` with the checksum of the whole. std::logic_error when
/// it holds no placeholder (a writer's bug).
void sealChecksum(std::string& bytes);

/// Patches the placeholder of the file at `path`, written with one in its first MiB, in place:
/// reads the file back in chunks, hashes it and writes the 16 digits (the caller syncs and
/// renames it). RuntimeError naming the file when it cannot be read or written.
void sealFileChecksum(const std::filesystem::path& path);

/// checksumProblem of the file at `path`, read in chunks (a seal is looked for in its first MiB,
/// where every writer puts it), or "cannot be read: <errno's text>".
std::string fileChecksumProblem(const std::filesystem::path& path);

/// Why n bytes are not a sealed file whose seal matches ("" when they are): "has no checksum"
/// (written before dgv sealed its files, or the tag itself damaged) or "is corrupt (its checksum
/// does not match)".
std::string checksumProblem(const char* data, std::size_t n);

}  // namespace dgv
