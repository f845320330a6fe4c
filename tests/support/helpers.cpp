#include "support/helpers.hpp"

#include <fenv.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace dgv::test {

namespace fs = std::filesystem;
constexpr int kTraps = FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW;

void enableFpTraps() { feenableexcept(kTraps); }

FpTrapsOff::FpTrapsOff() : mSaved(fegetexcept()) { fedisableexcept(kTraps); }
FpTrapsOff::~FpTrapsOff() {
    feclearexcept(FE_ALL_EXCEPT);
    feenableexcept(mSaved);
}

TempDir::TempDir(const std::string& name) {
    mPath = fs::path(DGV_TEST_BINARY_DIR) / "test-tmp" / (name + "-" + std::to_string(getpid()));
    fs::remove_all(mPath);
    fs::create_directories(mPath);
}
TempDir::~TempDir() {
    std::error_code ec;
    fs::remove_all(mPath, ec);
}

CommandResult runDgv(const std::string& args) {
    std::string cmd = "cd '" + std::string(DGV_TEST_SOURCE_DIR) + "' && '" + DGV_EXE + "' " + args + " 2>&1";
    CommandResult r;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) throw std::runtime_error("popen failed: " + cmd);
    std::array<char, 4096> buf{};
    std::size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
    int status = pclose(pipe);
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return r;
}

fs::path sourcePath(const std::string& relative) { return fs::path(DGV_TEST_SOURCE_DIR) / relative; }

std::filesystem::path writeFile(const std::filesystem::path& dir, const std::string& name, const std::string& text) {
    const std::filesystem::path p = dir / name;
    std::ofstream(p, std::ios::binary) << text;
    return p;
}

}  // namespace dgv::test
