#pragma once
/// @file exr.hpp
/// @brief OpenEXR files of a LinearImage, for compositing: one-part scanline, ZIP compression,
/// channels R, G, B, A (half; premultiplied linear, EXR's convention), Z (float; the depth) and
/// `contact` (half), y = 0 the top row. Sealed like the caches (io/checksum.hpp: a `dgv_checksum`
/// string attribute) and written atomically; same image and text -> same bytes (no timestamps).

#include "base/image.hpp"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace dgv {

/// Writes `image` to `path` atomically (atomic_file.hpp). `text` pairs become string attributes
/// of the header under their own keys. std::invalid_argument when the image's planes do not hold
/// width*height pixels, a side is not in 1..65536, or a key is empty, repeated, names an attribute
/// the header already has (`channels`, `dgv_checksum`, ...) or a key or value holds the seal's tag
/// "dgvsum:". RuntimeError naming the file and the cause on any other failure.
void writeExr(const std::filesystem::path& path, const LinearImage& image,
              const std::vector<std::pair<std::string, std::string>>& text = {});

/// Reads a file written by writeExr, or any EXR whose first part has R, G and B channels; the
/// image is the file's data window. A missing A reads as 1, a missing Z as LinearImage::kNoDepth,
/// a missing `contact` as 0. The seal is not checked (foreign files have none): a caller that
/// wants a whole file of writeExr checks io/checksum.hpp's fileChecksumProblem first, so damaged
/// bytes never reach OpenEXR (app/resume.cpp). InputError naming the file when it is not such a file (RuntimeError for the system's
/// read errors, read_file.hpp). `text`, when given, receives the header's string attributes but
/// `dgv_checksum`, sorted by key.
LinearImage readExr(const std::filesystem::path& path,
                    std::vector<std::pair<std::string, std::string>>* text = nullptr);

}  // namespace dgv
