#pragma once
/// @file read_file.hpp
/// @brief Reading an input file whole, with the two kinds of failure told apart: what is wrong
/// with the input (no such file, a folder, a pipe or device, too large, no permission:
/// InputError, exit 2) and an error of the system while reading it (EIO from a failing disk or a
/// network mount: RuntimeError naming the file and the errno, exit 1, which a farm retries).

#include <cstdint>
#include <filesystem>
#include <string>

namespace dgv {

/// The bytes of `path`, a regular file of at most `maxBytes`. `kind` names what it should be in
/// the messages ("scene file", "curve file").
std::string readInputFile(const std::filesystem::path& path, const std::string& kind, std::uintmax_t maxBytes);

/// Reads `path` to its end without keeping it, with readInputFile's errors (no size limit). Run
/// before a library reader (assimp, libpng, OpenVDB) that would report a failing disk's EIO as
/// bad content: the system's error is then exit 1, the content's stays exit 2. The second read
/// comes from the page cache.
void checkInputReadable(const std::filesystem::path& path, const std::string& kind);

}  // namespace dgv
