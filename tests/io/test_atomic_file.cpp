// Atomic file writes: temporary name, rename, clean-up.

#include "io/atomic_file.hpp"

#include "base/errors.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

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
    CHECK(name == ".shot.0042.png.tmp-" + std::to_string(getpid()));
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
