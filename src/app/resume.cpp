#include "app/resume.hpp"

#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"
#include "io/exr.hpp"
#include "io/png.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include <filesystem>
#include <system_error>
#include <utility>
#include <vector>

namespace dgv::app {

namespace fs = std::filesystem;

/// True when `program` is an executable file in a folder of $PATH.
bool onPath(const std::string& program) {
    const char* path = std::getenv("PATH");
    if (!path) return false;
    std::string all = path;
    std::size_t start = 0;
    while (start <= all.size()) {
        const std::size_t end = std::min(all.find(':', start), all.size());
        const fs::path candidate = fs::path(all.substr(start, end - start)) / program;
        if (end > start && access(candidate.c_str(), X_OK) == 0) return true;
        start = end + 1;
    }
    return false;
}

std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

std::string framePath(const std::string& dir, const std::string& name, int frame, const std::string& extension) {
    char num[32];
    std::snprintf(num, sizeof num, "%04d", frame);
    return (fs::path(dir) / (name + "." + num + "." + extension)).string();
}

void checkOutputFolder(const std::string& dir, const std::string& input, const std::string& where) {
    if (dir.empty()) return;
    fs::path p = fs::path(dir).lexically_normal();
    for (;;) {
        std::error_code ec;
        const fs::file_status st = fs::status(p, ec);  // ENOTDIR below a file: "not found", go up
        // A symbolic link to nothing: making the folder would fail with only "File exists".
        if (!fs::exists(st) && fs::is_symlink(fs::symlink_status(p, ec)))
            throw InputError(input, where,
                             dir + ": not a folder (" + p.string() + " is a symbolic link to '" +
                                 fs::read_symlink(p, ec).string() + "', which does not exist)");
        if (fs::exists(st)) {
            if (fs::is_directory(st)) return;
            throw InputError(input, where,
                             p == fs::path(dir).lexically_normal()
                                 ? dir + ": not a folder (a file of that name exists)"
                                 : dir + ": not a folder (" + p.string() + " is a file)");
        }
        if (!p.has_relative_path() || p.parent_path() == p) return;
        p = p.parent_path();
    }
}

bool frameIsComplete(const std::string& path, int frame, int width, int height, const std::string& key, Image* image,
                     bool anyRenderer) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return false;
    std::vector<std::pair<std::string, std::string>> text;
    Image decoded;
    try {
        if (fs::path(path).extension() == ".exr") {
            // The seal first: OpenEXR's reader is not shown damaged bytes. Then every scanline.
            if (!fileChecksumProblem(path).empty()) return false;
            decoded = encodedImageOf(readExr(path, &text));
        } else {
            decoded = readPng(path, &text);  // the whole file: image data, CRCs, IEND
        }
    } catch (const InputError&) {
        return false;
    }
    if (decoded.width != width || decoded.height != height) return false;
    bool frameMatches = false, keyMatches = false;
    for (const auto& [name, value] : text) {
        if (name == "dgv:frame") frameMatches = value == std::to_string(frame);
        if (name == "dgv:key") keyMatches = anyRenderer ? value.rfind(key + " ", 0) == 0 : value == key;
    }
    if (!frameMatches || !keyMatches) return false;
    if (image) *image = std::move(decoded);
    return true;
}

void removeStaleOutputTemporaries(const std::string& dir) {
    int removed = 0;
    for (const char* sub : {"", "vdb", "mesh", "state"}) {
        std::error_code ec;
        const std::filesystem::path folder = std::filesystem::path(dir) / sub;
        if (std::filesystem::is_directory(folder, ec)) removed += removeStaleTemporaries(folder);
    }
    if (removed > 0)
        logInfo("removed " + std::to_string(removed) + " temporar" + (removed == 1 ? "y" : "ies") + " in " + dir +
                " left by a run of this host that was killed");
}

}  // namespace dgv::app
