#pragma once
/// @file atomic_file.hpp
/// @brief Writing files so that a reader never sees half of one: write to a hidden temporary
/// name in the same folder (".<name>.tmp-<host>-<pid>", <host> a hash of the host's name; not
/// mistaken for a frame by sequence detection), fsync, rename over the final name. On failure
/// the temporary is removed; one a killed process left is removed by removeStaleTemporaries.

#include <filesystem>
#include <functional>
#include <string>

namespace dgv {

/// "<host>-<pid>": this process's temporaries' tag.
std::string temporaryTag();

/// The temporary name used for `target`.
std::filesystem::path temporaryPathFor(const std::filesystem::path& target);

/// Removes the temporaries in `dir` (not its subfolders) that a process of this host left when
/// it was killed (SIGKILL, a node's power cut: no handler ran): those tagged with this host whose
/// pid no longer runs. Another host's are left alone (a farm's shared folder: their pids mean
/// nothing here), and so are a live process's. Returns how many were removed.
int removeStaleTemporaries(const std::filesystem::path& dir);

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
