#pragma once
// Running the real dgv executable as a user would, for the end-to-end tests: stdout and stderr
// kept apart, the exit code, and a snapshot of a folder's files to prove nothing was written.

#include "base/image.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace dgv::e2e {

namespace fs = std::filesystem;

struct Run {
    int exitCode = -1;
    std::string out, err;  ///< stdout, stderr
};

inline std::string readAll(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

inline std::string quote(const fs::path& p) {
    std::string q = "'";
    for (char c : p.string()) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

/// Runs `<prefix> dgv <args>` through /bin/sh in `cwd` (args shell-quoted by the caller);
/// `prefix` may set up the shell first (e.g. "ulimit -f 8;"). stdout and stderr go to files
/// outside `cwd` so that the folder snapshot sees only what dgv wrote.
inline Run runDgvIn(const fs::path& cwd, const std::string& args, const std::string& prefix = "") {
    const fs::path capture = cwd.parent_path() / (cwd.filename().string() + ".capture");
    fs::create_directories(capture);
    const fs::path outFile = capture / "stdout", errFile = capture / "stderr";
    const std::string cmd = "cd " + quote(cwd) + " && " + prefix + " exec " + quote(DGV_EXE) + " " + args + " >" +
                            quote(outFile) + " 2>" + quote(errFile);
    const int status = std::system(cmd.c_str());
    Run r;
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.out = readAll(outFile);
    r.err = readAll(errFile);
    fs::remove_all(capture);
    return r;
}

/// A stats.csv as rows of named columns (numbers; "nan" reads as NaN).
inline std::vector<std::map<std::string, double>> readStatsCsv(const fs::path& p) {
    std::istringstream in(readAll(p));
    std::string line;
    std::getline(in, line);
    std::vector<std::string> names;
    {
        std::istringstream h(line);
        for (std::string w; std::getline(h, w, ',');) names.push_back(w);
    }
    std::vector<std::map<std::string, double>> rows;
    while (std::getline(in, line)) {
        std::istringstream r(line);
        std::map<std::string, double> row;
        std::size_t i = 0;
        for (std::string w; std::getline(r, w, ',') && i < names.size(); ++i)
            row[names[i]] = std::strtod(w.c_str(), nullptr);
        rows.push_back(row);
    }
    return rows;
}

/// Every path under `dir` (relative, sorted), folders included.
inline std::vector<std::string> snapshot(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(dir)) names.push_back(fs::relative(e.path(), dir).string());
    std::sort(names.begin(), names.end());
    return names;
}

inline std::size_t lineCount(const std::string& s) {
    return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

/// The widest run of pixels along a row whose alpha is at least `threshold` (0..1): an
/// object's extent on a transparent frame, down to its faintest share of a pixel.
inline int widestRun(const Image& img, double threshold) {
    int best = 0;
    for (int y = 0; y < img.height; ++y) {
        int first = -1, last = -1;
        for (int x = 0; x < img.width; ++x)
            if (img.pixel(x, y)[3] >= threshold * 65535) {
                if (first < 0) first = x;
                last = x;
            }
        if (first >= 0) best = std::max(best, last - first + 1);
    }
    return best;
}

}  // namespace dgv::e2e
