#include "io/read_file.hpp"

#include "base/errors.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <limits>

namespace dgv {

namespace {

/// Opens `path` as a regular file of at most `maxBytes` and passes its bytes to `sink` block by
/// block, telling the input's problems (InputError) from the system's (RuntimeError).
template <class Sink>
void streamInputFile(const std::filesystem::path& path, const std::string& kind, std::uintmax_t maxBytes, Sink sink) {
    const std::string name = path.string();
    struct stat st {};
    if (::stat(name.c_str(), &st) != 0) {
        if (errno == ENOENT || errno == ENOTDIR) throw InputError(name, "", "no such file");
        if (errno == EACCES) throw InputError(name, "", "cannot be read (permission denied)");
        throw RuntimeError(name + ": cannot read: " + std::strerror(errno));
    }
    if (S_ISDIR(st.st_mode)) throw InputError(name, "", "is a folder, not a " + kind);
    // A FIFO would block and a device (/dev/zero) never end: only regular files.
    if (!S_ISREG(st.st_mode))
        throw InputError(name, "", "is not a regular file (a pipe, device or socket); give a " + kind);
    if (static_cast<std::uintmax_t>(st.st_size) > maxBytes)
        throw InputError(name, "",
                         "is " + std::to_string(static_cast<std::uintmax_t>(st.st_size) >> 20) + " MiB; a " + kind +
                             " is at most " + std::to_string(maxBytes >> 20) + " MiB");
    const int fd = ::open(name.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        if (errno == EACCES) throw InputError(name, "", "cannot be read (permission denied)");
        throw RuntimeError(name + ": cannot open: " + std::strerror(errno));
    }
    std::uintmax_t total = 0;
    char buffer[1 << 16];
    for (;;) {
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n == 0) break;
        if (n < 0) {
            if (errno == EINTR) continue;
            const int err = errno;
            ::close(fd);
            throw RuntimeError(name + ": read error: " + std::strerror(err) +
                               " (the system failed to read it, not its content: check the disk or mount and retry)");
        }
        total += static_cast<std::uintmax_t>(n);
        if (total > maxBytes) {  // it grew while read
            ::close(fd);
            throw InputError(name, "",
                             "is over " + std::to_string(maxBytes >> 20) + " MiB; a " + kind + " is at most " +
                                 std::to_string(maxBytes >> 20) + " MiB");
        }
        sink(buffer, static_cast<std::size_t>(n));
    }
    ::close(fd);
}

}  // namespace

std::string readInputFile(const std::filesystem::path& path, const std::string& kind, std::uintmax_t maxBytes) {
    std::string bytes;
    std::error_code ec;
    const std::uintmax_t size = std::filesystem::file_size(path, ec);
    if (!ec && size <= maxBytes) bytes.reserve(static_cast<std::size_t>(size));
    streamInputFile(path, kind, maxBytes, [&](const char* data, std::size_t n) { bytes.append(data, n); });
    return bytes;
}

void checkInputReadable(const std::filesystem::path& path, const std::string& kind) {
    streamInputFile(path, kind, std::numeric_limits<std::uintmax_t>::max(), [](const char*, std::size_t) {});
}

}  // namespace dgv
