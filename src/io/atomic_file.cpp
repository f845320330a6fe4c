#include "io/atomic_file.hpp"

#include "base/errors.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

namespace dgv {

namespace fs = std::filesystem;

namespace {

// The registry of temporaries being written, read by removePendingTemporaries() from a signal
// handler: fixed-size static storage, no allocation, slots claimed with lock-free atomics.
constexpr int kMaxPending = 64;
constexpr std::size_t kMaxPath = 4096;

// Slot states: 0 free, 1 being filled or cleared (not for the handler), 2 holds a live path.
std::atomic<int> gSlotState[kMaxPending];
char gSlotPath[kMaxPending][kMaxPath];

static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free atomics");

/// Claims a slot for `path`; -1 when the registry is full or the path too long (the write
/// still happens; only the interrupt clean-up misses it).
int registerPending(const std::string& path) {
    if (path.size() + 1 > kMaxPath) return -1;
    for (int i = 0; i < kMaxPending; ++i) {
        int expected = 0;
        if (gSlotState[i].compare_exchange_strong(expected, 1)) {
            std::memcpy(gSlotPath[i], path.c_str(), path.size() + 1);
            gSlotState[i].store(2);
            return i;
        }
    }
    return -1;
}

void unregisterPending(int slot) {
    if (slot < 0) return;
    gSlotState[slot].store(1);
    gSlotPath[slot][0] = '\0';
    gSlotState[slot].store(0);
}

std::string errnoText(int err) { return std::strerror(err); }

/// fsync of a file or folder by path; returns 0 or an errno value.
int syncPath(const fs::path& p, bool directory) {
    int fd = ::open(p.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
    if (fd < 0) return errno;
    int err = 0;
    if (::fsync(fd) != 0) err = errno;
    // Some file systems refuse fsync on folders (EINVAL); the rename is still atomic there.
    if (directory && (err == EINVAL || err == EBADF)) err = 0;
    if (::close(fd) != 0 && err == 0) err = errno;
    return err;
}

}  // namespace

std::string temporaryTag() {
    // The host's name hashed (FNV-1a, 8 hex digits): a folder shared by a farm's nodes holds
    // temporaries of processes on other hosts, whose pids mean nothing here.
    static const std::string tag = [] {
        char host[256] = {};
        if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
        std::uint32_t h = 2166136261u;
        for (const char* c = host; *c; ++c) h = (h ^ static_cast<unsigned char>(*c)) * 16777619u;
        char hex[16];
        std::snprintf(hex, sizeof hex, "%08x", h);
        return std::string(hex);
    }();
    return tag + "-" + std::to_string(::getpid());
}

fs::path temporaryPathFor(const fs::path& target) {
    return target.parent_path() / ("." + target.filename().string() + ".tmp-" + temporaryTag());
}

int removeStaleTemporaries(const fs::path& dir) {
    const std::string tag = temporaryTag();
    const std::string host = tag.substr(0, tag.find('-'));
    int removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        const std::size_t at = name.rfind(".tmp-" + host + "-");
        if (name.empty() || name[0] != '.' || at == std::string::npos) continue;
        // The pid: the digits after the host tag (a movie's temporary adds ".mp4").
        const char* digits = name.c_str() + at + 5 + host.size() + 1;
        char* stop = nullptr;
        const long pid = std::strtol(digits, &stop, 10);
        if (stop == digits || pid <= 0) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
        std::error_code rm;
        if (it->is_regular_file(rm) && fs::remove(it->path(), rm)) ++removed;
    }
    return removed;
}

void writeFileAtomically(const fs::path& target, const std::function<void(const fs::path& tmpPath)>& write) {
    const fs::path tmp = temporaryPathFor(target);
    const int slot = registerPending(tmp.string());
    auto fail = [&](const std::string& why) {
        ::unlink(tmp.c_str());
        unregisterPending(slot);
        throw RuntimeError("cannot write " + target.string() + ": " + why);
    };

    try {
        write(tmp);
    } catch (const std::exception& e) {
        fail(e.what());
    } catch (...) {
        fail("unknown error");
    }

    struct stat st {};
    if (::lstat(tmp.c_str(), &st) != 0) fail("the temporary " + tmp.string() + " was not written: " + errnoText(errno));
    if (!S_ISREG(st.st_mode)) fail("the temporary " + tmp.string() + " is not a regular file");
    if (int err = syncPath(tmp, false)) fail("fsync: " + errnoText(err));
    if (::rename(tmp.c_str(), target.c_str()) != 0) fail("rename: " + errnoText(errno));
    unregisterPending(slot);

    const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    if (int err = syncPath(dir, true)) {
        throw RuntimeError("cannot write " + target.string() + ": fsync of the folder: " + errnoText(err));
    }
}

void writeTextAtomically(const fs::path& target, const std::string& contents) {
    writeFileAtomically(target, [&](const fs::path& tmp) {
        int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) throw RuntimeError(errnoText(errno));
        const char* p = contents.data();
        std::size_t left = contents.size();
        while (left > 0) {
            ssize_t n = ::write(fd, p, left);
            if (n < 0) {
                if (errno == EINTR) continue;
                const int err = errno;
                ::close(fd);
                throw RuntimeError(errnoText(err));
            }
            p += n;
            left -= static_cast<std::size_t>(n);
        }
        if (::close(fd) != 0) throw RuntimeError(errnoText(errno));
    });
}

void removePendingTemporaries() noexcept {
    for (int i = 0; i < kMaxPending; ++i) {
        if (gSlotState[i].load() == 2) ::unlink(gSlotPath[i]);
    }
}

void ensureDirectory(const fs::path& dir) {
    if (dir.empty()) return;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw RuntimeError("cannot create folder " + dir.string() + ": " + ec.message());
    if (!fs::is_directory(dir, ec)) throw RuntimeError("cannot create folder " + dir.string() + ": not a folder");
}

}  // namespace dgv
