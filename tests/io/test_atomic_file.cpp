// Atomic file writes: temporary name, rename, clean-up.

#include "io/atomic_file.hpp"

#include "base/errors.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <regex>
#include <sstream>

using namespace dgv;
namespace fs = std::filesystem;

namespace {
std::vector<std::string> names(const fs::path& dir) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
}
std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}
}  // namespace

TEST_CASE("atomic_file: a successful write leaves exactly the target", "[io]") {
    test::TempDir dir("atomic-ok");
    const fs::path target = dir.path() / "shot.0001.png";
    fs::path seenTmp;
    writeFileAtomically(target, [&](const fs::path& tmp) {
        seenTmp = tmp;
        CHECK(tmp.parent_path() == target.parent_path());  // same folder: rename is atomic
        std::ofstream(tmp) << "frame";
        CHECK_FALSE(fs::exists(target));  // readers never see a partial target
    });
    CHECK(names(dir.path()) == std::vector<std::string>{"shot.0001.png"});
    CHECK(slurp(target) == "frame");
    CHECK_FALSE(fs::exists(seenTmp));

    // Overwrites replace the old contents.
    writeTextAtomically(target, "second");
    CHECK(slurp(target) == "second");
    CHECK(names(dir.path()).size() == 1);
}

TEST_CASE("atomic_file: a throwing writer leaves nothing and names the target", "[io]") {
    test::TempDir dir("atomic-throw");
    const fs::path target = dir.path() / "shot.0002.png";
    try {
        writeFileAtomically(target, [&](const fs::path& tmp) {
            std::ofstream(tmp) << "half a frame";
            throw std::runtime_error("disk on fire");
        });
        FAIL("expected a RuntimeError");
    } catch (const RuntimeError& e) {
        const std::string what = e.what();
        CHECK(what.find(target.string()) != std::string::npos);
        CHECK(what.find("disk on fire") != std::string::npos);
    }
    CHECK(names(dir.path()).empty());

    // A writer that produces no file is a failure too, not a silent success.
    CHECK_THROWS_AS(writeFileAtomically(target, [](const fs::path&) {}), RuntimeError);
    CHECK(names(dir.path()).empty());
}

TEST_CASE("atomic_file: temporary names are hidden and not frame-like", "[io]") {
    const fs::path tmp = temporaryPathFor("out/shot/shot.0042.png");
    CHECK(tmp.parent_path() == fs::path("out/shot"));
    const std::string name = tmp.filename().string();
    CHECK(name == ".shot.0042.png.tmp-" + temporaryTag());
    // The tag: this host's name hashed to 8 hex digits, then the pid.
    CHECK(std::regex_match(temporaryTag(), std::regex("[0-9a-f]{8}-" + std::to_string(getpid()))));
    CHECK(name.front() == '.');
    // Sequence detection keys on a trailing digit group before the extension: the name must not
    // end in "<digits>.png" (or .vdb) and its extension is not .png.
    CHECK_FALSE(std::regex_search(name, std::regex(R"(\d+\.(png|vdb)$)")));
    CHECK(tmp.extension() != ".png");
}

TEST_CASE("atomic_file: an interrupted write's temporary is removed by the signal clean-up", "[io]") {
    test::TempDir dir("atomic-signal");
    const fs::path target = dir.path() / "shot.0003.png";
    writeFileAtomically(target, [&](const fs::path& tmp) {
        std::ofstream(tmp) << "partial";
        REQUIRE(fs::exists(tmp));
        removePendingTemporaries();  // what the SIGINT handler does
        CHECK_FALSE(fs::exists(tmp));
        std::ofstream(tmp) << "complete";  // (the test goes on writing so the call can finish)
    });
    CHECK(slurp(target) == "complete");
    removePendingTemporaries();  // nothing pending: the finished file stays
    CHECK(fs::exists(target));
}

TEST_CASE("atomic_file: ensureDirectory creates folders and refuses files", "[io]") {
    test::TempDir dir("atomic-dirs");
    ensureDirectory(dir.path() / "a" / "b" / "c");
    CHECK(fs::is_directory(dir.path() / "a" / "b" / "c"));
    ensureDirectory(dir.path() / "a");  // existing: fine
    std::ofstream(dir.path() / "f") << "x";
    CHECK_THROWS_AS(ensureDirectory(dir.path() / "f"), RuntimeError);
    CHECK_THROWS_AS(ensureDirectory(dir.path() / "f" / "sub"), RuntimeError);
}

TEST_CASE("atomic_file: a killed run's temporaries of this host are removed, a live or another host's are not",
          "[io]") {
    test::TempDir dir("atomic_stale");
    const std::string host = temporaryTag().substr(0, 8);
    // A pid that is not running: a child that has exited and been reaped.
    const pid_t child = fork();
    if (child == 0) _exit(0);
    REQUIRE(child > 0);
    int status = 0;
    REQUIRE(waitpid(child, &status, 0) == child);
    const std::string dead = std::to_string(child);
    std::string foreign = host;  // another host's tag: the first digit changed
    foreign[0] = foreign[0] == '0' ? '1' : '0';
    const std::vector<std::string> stale = {".s.0001.png.tmp-" + host + "-" + dead,
                                            ".s.mp4.tmp-" + host + "-" + dead + ".mp4"};
    const std::vector<std::string> kept = {
        ".s.0002.png.tmp-" + host + "-" + std::to_string(getpid()),  // this process: alive
        ".s.0003.png.tmp-" + foreign + "-" + dead,                   // another host's
        "s.0004.png",                                                // a frame
        "notes.tmp-" + host + "-" + dead};                           // not hidden: not dgv's
    for (const std::string& n : stale) std::ofstream(dir.path() / n) << "x";
    for (const std::string& n : kept) std::ofstream(dir.path() / n) << "x";
    CHECK(removeStaleTemporaries(dir.path()) == 2);
    std::vector<std::string> left = kept;
    std::sort(left.begin(), left.end());
    CHECK(names(dir.path()) == left);
    CHECK(removeStaleTemporaries(dir.path() / "missing") == 0);
}
