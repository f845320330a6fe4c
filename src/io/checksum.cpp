#include "io/checksum.hpp"

#include "base/errors.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <stdexcept>
#include <string_view>
#include <unistd.h>
#include <vector>

namespace dgv {

namespace {

constexpr std::uint64_t kPrime = 1099511628211ull;  // FNV-1a's prime
constexpr std::string_view kTag = "dgvsum:";
constexpr std::size_t kDigits = 16;

std::uint64_t littleEndianWord(const char* p) {
    std::uint64_t w;
    std::memcpy(&w, p, sizeof w);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    w = __builtin_bswap64(w);
#endif
    return w;
}

}  // namespace

void Checksum64::block(const char* p) {
    for (int l = 0; l < 4; ++l) {
        const std::uint64_t x = (lane_[l] ^ littleEndianWord(p + 8 * l)) * kPrime;
        lane_[l] = x ^ (x >> 29);
    }
}

void Checksum64::add(const char* data, std::size_t n) {
    length_ += n;
    if (carried_ > 0) {
        const std::size_t k = std::min(n, sizeof carry_ - carried_);
        std::memcpy(carry_ + carried_, data, k);
        carried_ += k;
        data += k;
        n -= k;
        if (carried_ < sizeof carry_) return;
        block(carry_);
        carried_ = 0;
    }
    for (; n >= 32; data += 32, n -= 32) block(data);
    std::memcpy(carry_, data, n);
    carried_ = n;
}

std::uint64_t Checksum64::finish() const {
    std::uint64_t h = kBasis;
    for (std::uint64_t l : lane_) h = (h ^ l) * kPrime;
    for (std::size_t i = 0; i < carried_; ++i) h = (h ^ static_cast<unsigned char>(carry_[i])) * kPrime;
    h = (h ^ length_) * kPrime;
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebull;
    return h ^ (h >> 31);
}

std::uint64_t checksum64(const char* data, std::size_t n) {
    Checksum64 c;
    c.add(data, n);
    return c.finish();
}

std::string checksumPlaceholder() { return std::string(kTag) + std::string(kDigits, '0'); }

std::size_t findChecksumDigits(const char* data, std::size_t n) {
    const std::string_view all(data, n);
    const std::size_t at = all.find(kTag);
    if (at == std::string_view::npos || at + kTag.size() + kDigits > n) return std::string::npos;
    return at + kTag.size();
}

std::string checksumDigits(std::uint64_t sum) {
    static const char* hex = "0123456789abcdef";
    std::string s(kDigits, '0');
    for (std::size_t i = 0; i < kDigits; ++i) s[kDigits - 1 - i] = hex[(sum >> (4 * i)) & 15];
    return s;
}

std::uint64_t sealedChecksum(const char* data, std::size_t n, std::size_t digits) {
    static const char zeros[kDigits] = {'0', '0', '0', '0', '0', '0', '0', '0',
                                        '0', '0', '0', '0', '0', '0', '0', '0'};
    Checksum64 c;
    c.add(data, digits);
    c.add(zeros, kDigits);
    c.add(data + digits + kDigits, n - digits - kDigits);
    return c.finish();
}

void sealChecksum(std::string& bytes) {
    const std::size_t at = findChecksumDigits(bytes.data(), bytes.size());
    if (at == std::string::npos) throw std::logic_error("sealChecksum: no placeholder in the bytes");
    const std::string digits = checksumDigits(sealedChecksum(bytes.data(), bytes.size(), at));
    bytes.replace(at, kDigits, digits);
}

namespace {

/// A sealed file read through once in chunks: where its seal's digits are (npos: none in its
/// first chunk, where every writer puts it), the digits stored there, and the checksum of the
/// whole with the digits read as '0'. errno's value in `error` when a read failed.
struct FileSeal {
    std::size_t digits = std::string::npos;
    std::string stored;
    std::uint64_t sum = 0;
    int error = 0;
};

FileSeal readSeal(int fd) {
    constexpr std::size_t kChunk = std::size_t(1) << 20;
    std::vector<char> buf(kChunk);
    FileSeal seal;
    Checksum64 c;
    for (bool first = true;; first = false) {
        std::size_t got = 0;
        while (got < kChunk) {  // whole chunks, so the first holds the header whatever read returns
            const ssize_t k = ::read(fd, buf.data() + got, kChunk - got);
            if (k < 0 && errno == EINTR) continue;
            if (k < 0) {
                seal.error = errno;
                return seal;
            }
            if (k == 0) break;
            got += static_cast<std::size_t>(k);
        }
        if (first) {
            seal.digits = findChecksumDigits(buf.data(), got);
            if (seal.digits == std::string::npos) return seal;
            seal.stored.assign(buf.data() + seal.digits, kDigits);
            std::memset(buf.data() + seal.digits, '0', kDigits);
        }
        c.add(buf.data(), got);
        if (got < kChunk) break;
    }
    seal.sum = c.finish();
    return seal;
}

}  // namespace

void sealFileChecksum(const std::filesystem::path& path) {
    auto fail = [&](const std::string& what) {
        throw RuntimeError(path.string() + ": cannot seal the file (" + what + ")");
    };
    const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) fail(std::strerror(errno));
    const FileSeal seal = readSeal(fd);
    if (seal.error != 0) {
        ::close(fd);
        fail(std::strerror(seal.error));
    }
    if (seal.digits == std::string::npos) {
        ::close(fd);
        throw std::logic_error("sealFileChecksum: " + path.string() + " holds no placeholder");
    }
    const std::string digits = checksumDigits(seal.sum);
    const ssize_t w = ::pwrite(fd, digits.data(), kDigits, static_cast<off_t>(seal.digits));
    const int err = w == static_cast<ssize_t>(kDigits) ? 0 : (w < 0 ? errno : EIO);
    if (::close(fd) != 0 && err == 0) fail(std::strerror(errno));
    if (err != 0) fail(std::strerror(err));
}

std::string fileChecksumProblem(const std::filesystem::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return std::string("cannot be read: ") + std::strerror(errno);
    const FileSeal seal = readSeal(fd);
    ::close(fd);
    if (seal.error != 0) return std::string("cannot be read: ") + std::strerror(seal.error);
    if (seal.digits == std::string::npos) return "has no checksum";
    return seal.stored == checksumDigits(seal.sum) ? "" : "is corrupt (its checksum does not match)";
}

std::string checksumProblem(const char* data, std::size_t n) {
    const std::size_t at = findChecksumDigits(data, n);
    if (at == std::string::npos) return "has no checksum";
    return std::string_view(data + at, kDigits) == checksumDigits(sealedChecksum(data, n, at))
               ? ""
               : "is corrupt (its checksum does not match)";
}

}  // namespace dgv
