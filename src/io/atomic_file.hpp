#pragma once
/// @file atomic_file.hpp
/// @brief Writing files so that a reader never sees half of one: write to a hidden temporary
/// name in the same folder (".<name>.tmp-<pid>", not mistaken for a frame by sequence
/// detection), fsync, rename over the final name. On failure the temporary is removed.

#include <filesystem>
#include <functional>
#include <string>

namespace dgv {

/// The temporary name used for `target`.
std::filesystem::path temporaryPathFor(const std::filesystem::path& target);

/// Calls write(tmpPath) to produce the file under a temporary name, then fsyncs and renames it
/// to `target`. If write throws, or the sync or rename fails, the temporary is removed and a
/// RuntimeError naming `target` and the reason is thrown. The temporary currently being written
/// is removed by removePendingTemporaries() (called from the SIGINT/SIGTERM handler).
void writeFileAtomically(const std::filesystem::path& target,
                         const std::function<void(const std::filesystem::path& tmpPath)>& write);

/// Writes `contents` to `target` atomically.
void writeTextAtomically(const std::filesystem::path& target, const std::string& contents);

/// Removes temporaries of writes in progress (async-signal-safe: unlink only).
void removePendingTemporaries() noexcept;

/// Creates `dir` and its parents; RuntimeError naming it when that fails or it is not a folder.
void ensureDirectory(const std::filesystem::path& dir);

}  // namespace dgv
