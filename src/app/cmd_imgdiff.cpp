// dgv imgdiff: the golden-image comparison as a command (render/image_compare.hpp).

#include "app/commands.hpp"
#include "app/resume.hpp"
#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/png.hpp"
#include "render/image_compare.hpp"

#include <cstdio>
#include <filesystem>

namespace dgv::app {

int runImgdiff(const ImgdiffOptions& options) {
    // A --diff-out that cannot be a folder is bad input found first, not exit 1 (imgdiff's "differ").
    checkOutputFolder(options.diffDir, "--diff-out", "");
    Image ref = readPng(options.reference);
    Image cand = readPng(options.candidate);
    ImageCompareSettings s;
    s.threshold = options.threshold;
    s.maxFraction = options.maxFraction;
    s.hard = options.hard;
    ImageCompareResult r = compareImages(ref, cand, s);
    std::printf("%s\n", r.summary().c_str());  // "PASS: ..." or "FAIL: ..."
    if (!r.pass && !options.diffDir.empty() && !r.sizeMismatch) {
        namespace fs = std::filesystem;
        ensureDirectory(options.diffDir);
        const std::string stem = fs::path(options.candidate).stem().string();
        const fs::path newPath = fs::path(options.diffDir) / (stem + ".new.png");
        const fs::path diffPath = fs::path(options.diffDir) / (stem + ".diff.png");
        writePng(newPath, cand);
        writePng(diffPath, differenceImage(ref, cand));
        std::printf("wrote %s and %s\n", newPath.c_str(), diffPath.c_str());
    }
    return r.pass ? kExitOk : kExitFailure;
}

}  // namespace dgv::app
