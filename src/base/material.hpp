#pragma once
/// @file material.hpp
/// @brief A surface's look as its mesh file describes it (io/mesh_import reads it, the view hands
/// it to the renderer; docs/rendering.md, "Materials from the file").

#include "base/image.hpp"
#include "base/types.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace dgv {

/// A colour image a material samples: 8 bits per channel, sRGB-encoded colour, straight alpha,
/// rows from the top of the picture. Texture coordinates (u, v) have v = 0 at its bottom row.
struct TextureImage {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> rgba;  ///< width*height*4 samples, R,G,B,A
    std::string source;              ///< the file (or "<mesh file> embedded #n"), for messages

    /// The mean colour in linear RGB (the texture's look from afar); white when empty.
    Vec3 meanLinear() const {
        static const std::array<double, 256> linear = [] {
            std::array<double, 256> t{};
            for (int c = 0; c < 256; ++c) t[static_cast<std::size_t>(c)] = decodeSrgb(c / 255.0);
            return t;
        }();
        const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
        if (n == 0 || rgba.size() < 4 * n) return Vec3::Ones();
        Vec3 sum = Vec3::Zero();
        for (std::size_t p = 0; p < n; ++p)
            for (int c = 0; c < 3; ++c) sum[c] += linear[rgba[4 * p + static_cast<std::size_t>(c)]];
        return sum / static_cast<double>(n);
    }
};

struct SurfaceMaterial {
    std::string name;
    /// Linear RGB (glTF baseColorFactor, MTL Kd, Collada/FBX diffuse); times the map's colour.
    Vec3 baseColour = Vec3(0.8, 0.8, 0.8);
    std::shared_ptr<const TextureImage> baseColourMap;  ///< null: the factor alone
    /// glTF's metallic-roughness where the file gives them: perceptual roughness 0..1 (sets the
    /// highlight's width; < 0: each light's own exponent) and metalness 0..1.
    Real roughness = -1;
    Real metallic = 0;

    /// The colour seen from afar: the factor times the map's mean (linear RGB).
    Vec3 meanColour() const { return baseColourMap ? Vec3(baseColour.cwiseProduct(baseColourMap->meanLinear())) : baseColour; }
};

}  // namespace dgv
