#pragma once
/// @file texture.hpp
/// @brief The images a mesh file's materials refer to, decoded through stb_image (PNG, JPEG,
/// TGA, BMP, PSD, GIF's first frame, HDR tone-clamped): from a file beside the mesh or from
/// bytes the mesh file embeds (GLB, FBX).

#include "base/material.hpp"

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

/// The largest side accepted (the renderer's texture limit).
constexpr int kMaxTextureSide = 16384;

/// Decodes an image held in memory. `source` names it in the result and in errors.
/// InputError(source, "", why) when it is not an image stb_image reads, or larger than
/// kMaxTextureSide on a side.
TextureImage decodeTexture(const unsigned char* bytes, std::size_t size, const std::string& source);

/// Reads (io/read_file: a failing disk is a RuntimeError) and decodes a file. InputError naming
/// the file when it is missing, unreadable or not an image.
TextureImage readTexture(const std::filesystem::path& path);

/// An image in linear light (an environment map): Radiance HDR as its floats, any other format
/// stb_image reads decoded from sRGB. Rows from the top. InputError naming the file as readTexture.
struct LinearRgbImage {
    int width = 0;
    int height = 0;
    std::vector<Vec3> pixels;
};
LinearRgbImage readLinearImage(const std::filesystem::path& path);

}  // namespace dgv
