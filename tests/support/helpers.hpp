#pragma once
// Shared test helpers: floating-point traps, temporary folders, running the dgv command.

#include <filesystem>
#include <string>

namespace dgv::test {

/// Traps FE_INVALID, FE_DIVBYZERO and FE_OVERFLOW in the calling thread (and threads it starts).
void enableFpTraps();

/// Turns the traps off for a scope (for third-party code that uses infinities on purpose).
class FpTrapsOff {
public:
    FpTrapsOff();
    ~FpTrapsOff();
    FpTrapsOff(const FpTrapsOff&) = delete;
    FpTrapsOff& operator=(const FpTrapsOff&) = delete;

private:
    int mSaved;
};

/// A fresh, empty folder under the build tree, removed when the object dies.
class TempDir {
public:
    explicit TempDir(const std::string& name);
    ~TempDir();
    const std::filesystem::path& path() const { return mPath; }

private:
    std::filesystem::path mPath;
};

struct CommandResult {
    int exitCode = -1;
    std::string output;  ///< stdout and stderr together
};

/// Runs the built dgv executable with `args` (a shell-quoted string) from the source root.
CommandResult runDgv(const std::string& args);

/// Absolute path of a file in the source tree (e.g. "scenes/default.json").
std::filesystem::path sourcePath(const std::string& relative);

/// assimp's own test models (Debian's assimp-testmodels, a declared test dependency).
inline const std::filesystem::path kAssimpModels = "/usr/share/assimp/models";

/// Writes `text` to dir/name (binary) and returns that path.
std::filesystem::path writeFile(const std::filesystem::path& dir, const std::string& name, const std::string& text);

}  // namespace dgv::test
