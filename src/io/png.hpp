#pragma once
/// @file png.hpp
/// @brief PNG files through libpng's classic API: 8- or 16-bit RGBA (or RGB), sRGB chunk,
/// tEXt provenance, fixed compression settings (same image -> same bytes; no timestamps).

#include "base/image.hpp"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace dgv {

struct PngWriteOptions {
    int bitDepth = 8;        ///< 8 or 16
    bool alpha = true;       ///< RGBA; false writes RGB (alpha dropped)
    int compressionLevel = 3;
    std::vector<std::pair<std::string, std::string>> text;  ///< tEXt key/value pairs
};

/// Writes `image` to `path` atomically (atomic_file.hpp). RuntimeError on failure.
void writePng(const std::filesystem::path& path, const Image& image, const PngWriteOptions& options = {});

/// Encodes to memory (for tests and byte comparisons).
std::vector<unsigned char> encodePng(const Image& image, const PngWriteOptions& options = {});

/// Reads any PNG (8/16-bit, grey/RGB/RGBA/palette) into a 16-bit RGBA Image. InputError naming
/// the file on failure. `text`, when given, receives the tEXt chunks.
Image readPng(const std::filesystem::path& path,
              std::vector<std::pair<std::string, std::string>>* text = nullptr);

}  // namespace dgv
