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

/// A frame for compositing (EXR output, io/exr.hpp): linear light, premultiplied (associated)
/// alpha, with the depth and the contact highlight as extra planes. Rows top to bottom.
struct LinearImage {
    int width = 0;
    int height = 0;
    /// width*height*4 samples R,G,B,A: linear RGB times alpha (scene-referred, not clamped).
    std::vector<float> rgba;
    /// width*height: the nearest surface's distance along the camera's view axis (world units),
    /// kNoDepth where nothing is drawn.
    std::vector<float> depth;
    /// width*height, 0..1: the contact highlight's matte, averaged over the pixel's samples: 1 on
    /// a highlighted surface (a body's contact scalar > 0); where the highlight's ramp starts at
    /// the surface's own colour (a collider's footprint, a contact fading in `recent` mode) the
    /// ramp's position, so the matte follows what shows. Behind see-through meshes weighted as
    /// their colour is; 0 where nothing is highlighted.
    std::vector<float> contact;
    /// The depth of a pixel that shows no surface (the background): as Blender's Z pass writes it.
    static constexpr float kNoDepth = 1e10f;

    LinearImage() = default;
    LinearImage(int w, int h)
        : width(w), height(h), rgba(static_cast<std::size_t>(w) * h * 4, 0.0f),
          depth(static_cast<std::size_t>(w) * h, kNoDepth), contact(static_cast<std::size_t>(w) * h, 0.0f) {}
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

/// What a PNG frame of `linear` would hold: colour un-premultiplied and sRGB-encoded, straight
/// alpha (a preview of an EXR frame, e.g. its contact sheet thumbnail).
inline Image encodedImageOf(const LinearImage& linear) {
    Image out(linear.width, linear.height);
    for (std::size_t p = 0; p < linear.rgba.size(); p += 4) {
        const double a = std::clamp(static_cast<double>(linear.rgba[p + 3]), 0.0, 1.0);
        for (std::size_t c = 0; c < 3; ++c)
            out.rgba[p + c] = static_cast<std::uint16_t>(
                std::lround(65535.0 * encodeSrgb(a > 0 ? linear.rgba[p + c] / a : 0.0)));
        out.rgba[p + 3] = static_cast<std::uint16_t>(std::lround(65535.0 * a));
    }
    return out;
}

}  // namespace dgv
