#pragma once
/// @file image.hpp
/// @brief An RGBA image in memory: 16 bits per channel, sRGB-encoded colour, straight
/// (unassociated) alpha, rows top to bottom. io/png writes it at 8 or 16 bits; render/ fills it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace dgv {

struct Image {
    int width = 0;
    int height = 0;
    /// width*height*4 samples, row-major from the top row, channel order R,G,B,A, 0..65535.
    std::vector<std::uint16_t> rgba;

    Image() = default;
    Image(int w, int h) : width(w), height(h), rgba(static_cast<std::size_t>(w) * h * 4, 0) {}

    std::uint16_t* pixel(int x, int y) { return rgba.data() + (static_cast<std::size_t>(y) * width + x) * 4; }
    const std::uint16_t* pixel(int x, int y) const {
        return rgba.data() + (static_cast<std::size_t>(y) * width + x) * 4;
    }
};

/// 16-bit sample to the nearest 8-bit code value (exact rounding: v*255/65535).
inline std::uint8_t to8bit(std::uint16_t v) {
    return static_cast<std::uint8_t>((static_cast<std::uint32_t>(v) * 255u + 32767u) / 65535u);
}

/// The exact sRGB transfer function (IEC 61966-2-1), linear [0,1] -> encoded [0,1]; values
/// outside [0,1] are clamped first.
inline double encodeSrgb(double x) {
    x = std::clamp(x, 0.0, 1.0);
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}

/// Its inverse, encoded [0,1] -> linear [0,1] (scene colours are given encoded).
inline double decodeSrgb(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

}  // namespace dgv
