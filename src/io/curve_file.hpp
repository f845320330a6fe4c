#pragma once
/// @file curve_file.hpp
/// @brief Curve files for `dgv gln`: one closed polyline per file, one vertex "x y z" per line
/// (whitespace-separated numbers; the edge from the last vertex back to the first is implied).
/// '#' starts a comment (to the end of the line); blank lines are ignored. At least 3 vertices.
/// Problems throw InputError(file, "line N", what): an unparsable line, a line with other than
/// three numbers, a NaN or infinite coordinate, fewer than 3 vertices, a missing file.

#include "base/types.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

/// Reads a curve file.
std::vector<Vec3> readCurveFile(const std::filesystem::path& path);

/// Same, from text; `name` names the input in messages.
std::vector<Vec3> parseCurveText(const std::string& text, const std::string& name);

/// Writes a curve file (17 significant digits: reads back exactly), atomically.
void writeCurveFile(const std::filesystem::path& path, const std::vector<Vec3>& curve, const std::string& comment = "");

}  // namespace dgv
