// Write failures injected in-process: RLIMIT_FSIZE makes write() fail with EFBIG once a file
// would grow past the limit (SIGXFSZ ignored) -- a full disk as the writer sees it, without root
// or a small file system. The temporary must be removed and the final name must never appear.

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/png.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

/// Limits the size of files this process writes to `bytes` for its lifetime (and ignores SIGXFSZ).
class FileSizeLimit {
public:
    explicit FileSizeLimit(rlim_t bytes) {
        getrlimit(RLIMIT_FSIZE, &mSaved);
        mHandler = std::signal(SIGXFSZ, SIG_IGN);
        rlimit r = mSaved;
        r.rlim_cur = bytes;
        mOk = setrlimit(RLIMIT_FSIZE, &r) == 0;
    }
    ~FileSizeLimit() {
        setrlimit(RLIMIT_FSIZE, &mSaved);
        std::signal(SIGXFSZ, mHandler);
    }
    bool ok() const { return mOk; }
    FileSizeLimit(const FileSizeLimit&) = delete;
    FileSizeLimit& operator=(const FileSizeLimit&) = delete;

private:
    rlimit mSaved{};
    void (*mHandler)(int) = nullptr;
    bool mOk = false;
};

bool isEmptyFolder(const fs::path& dir) { return fs::directory_iterator(dir) == fs::directory_iterator(); }

/// A 256 x 256 image of incompressible-ish noise (~100 kB as PNG).
Image noiseImage() {
    Image image(256, 256);
    std::uint32_t s = 12345;
    for (auto& v : image.rgba) {
        s = s * 1664525u + 1013904223u;
        v = static_cast<std::uint16_t>(s >> 16);
    }
    return image;
}

}  // namespace

TEST_CASE("write faults: a full disk fails writeTextAtomically, leaving nothing", "[io][faults]") {
    test::TempDir dir("faults_text");
    const fs::path target = dir.path() / "notes.txt";
    {
        FileSizeLimit limit(4096);
        REQUIRE(limit.ok());
        try {
            writeTextAtomically(target, std::string(20000, 'x'));
            FAIL("expected a RuntimeError");
        } catch (const RuntimeError& e) {
            const std::string what = e.what();
            CHECK_THAT(what, Catch::StartsWith("cannot write " + target.string() + ": "));
            CHECK_THAT(what, Catch::Contains("File too large"));
        }
        // Below the limit the same call works.
        writeTextAtomically(target, "short");
    }
    CHECK(fs::file_size(target) == 5);
    fs::remove(target);
    CHECK(isEmptyFolder(dir.path()));
}

TEST_CASE("write faults: a full disk fails writePng and the PNG queue, leaving nothing", "[io][faults]") {
    test::TempDir dir("faults_png");
    const fs::path target = dir.path() / "shot.0001.png";
    const Image image = noiseImage();
    {
        FileSizeLimit limit(8192);
        REQUIRE(limit.ok());
        try {
            writePng(target, image);
            FAIL("expected a RuntimeError");
        } catch (const RuntimeError& e) {
            CHECK_THAT(std::string(e.what()), Catch::StartsWith("cannot write " + target.string() + ": "));
            CHECK_THAT(std::string(e.what()), Catch::Contains("File too large"));  // why, not only "Write Error"
        }
        CHECK(isEmptyFolder(dir.path()));

        // Through the render loop's queue: the error surfaces at finish(), nothing is left.
        PngWriteQueue queue;
        queue.submit(target, image, PngWriteOptions{});
        CHECK_THROWS_AS(queue.finish(), RuntimeError);
        CHECK(isEmptyFolder(dir.path()));
    }
    writePng(target, image);  // the limit lifted: the same write succeeds
    CHECK(fs::file_size(target) > 8192);
}

TEST_CASE("write faults: a run removes the temporaries a killed run of this host left in its folders",
          "[e2e][faults]") {
    // SIGKILL runs no handler: the temporary being written stayed behind under its hidden name.
    test::TempDir dir("faults_stale_temporaries");
    std::ofstream(dir.path() / "s.json") << R"({"name": "s", "frames": {"start": 1, "end": 2},
      "objects": [{"primitive": {"type": "sphere", "radius": 0.2}, "resolution": 8, "velocity": [0, -1, 0]}]})";
    const pid_t child = fork();
    if (child == 0) _exit(0);
    REQUIRE(child > 0);
    int status = 0;
    REQUIRE(waitpid(child, &status, 0) == child);
    const std::string tag = temporaryTag().substr(0, 8) + "-" + std::to_string(child);
    const fs::path out = dir.path() / "o";
    fs::create_directories(out / "state");
    std::ofstream(out / (".s.0001.png.tmp-" + tag)) << "half a frame";
    std::ofstream(out / "state" / (".s.0002.dgvstate.tmp-" + tag)) << "half a checkpoint";
    const auto r = test::runDgv("simulate " + (dir.path() / "s.json").string() + " --out " + out.string());
    INFO(r.output);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.output, Catch::Contains("removed 2 temporaries in " + out.string() +
                                         " left by a run of this host that was killed"));
    CHECK_FALSE(fs::exists(out / (".s.0001.png.tmp-" + tag)));
    CHECK_FALSE(fs::exists(out / "state" / (".s.0002.dgvstate.tmp-" + tag)));
}
