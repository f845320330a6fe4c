#include "io/texture.hpp"

#include "base/errors.hpp"
#include "io/read_file.hpp"

#include <ImfRgbaFile.h>
#include <stb_image.h>

#include <cstring>
#include <limits>
#include <memory>

namespace dgv {

TextureImage decodeTexture(const unsigned char* bytes, std::size_t size, const std::string& source) {
    if (size == 0) throw InputError(source, "", "the image is empty");
    if (size > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        throw InputError(source, "", "the image is larger than 2 GiB");
    int w = 0, h = 0, channels = 0;
    const int n = static_cast<int>(size);
    // The size first, so a huge declared image is refused before it is allocated.
    if (!stbi_info_from_memory(bytes, n, &w, &h, &channels)) {
        const char* why = stbi_failure_reason();
        throw InputError(source, "", std::string("not an image dgv reads (PNG, JPEG, TGA, BMP, ...): ") +
                                         (why ? why : "unknown format"));
    }
    if (w <= 0 || h <= 0 || w > kMaxTextureSide || h > kMaxTextureSide)
        throw InputError(source, "", "the image is " + std::to_string(w) + "x" + std::to_string(h) +
                                         " pixels; at most " + std::to_string(kMaxTextureSide) + " on a side");
    std::unique_ptr<unsigned char, void (*)(void*)> pixels(stbi_load_from_memory(bytes, n, &w, &h, &channels, 4),
                                                           stbi_image_free);
    if (!pixels) {
        const char* why = stbi_failure_reason();
        throw InputError(source, "", std::string("the image cannot be decoded: ") + (why ? why : "unknown error"));
    }
    TextureImage image;
    image.width = w;
    image.height = h;
    image.source = source;
    image.rgba.assign(pixels.get(), pixels.get() + static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4);
    return image;
}

namespace {

/// The largest image file read (stb_image counts its input in an int).
constexpr std::uintmax_t kMaxImageBytes = static_cast<std::uintmax_t>(std::numeric_limits<int>::max());

/// An OpenEXR file's RGB (any layout OpenEXR's RGBA interface reads: half or float, scanline
/// or tiled, with or without alpha).
LinearRgbImage readExrRgb(const std::string& p) {
    LinearRgbImage out;
    try {
        Imf::RgbaInputFile file(p.c_str());
        const Imath::Box2i dw = file.dataWindow();
        const long long w = static_cast<long long>(dw.max.x) - dw.min.x + 1, h = static_cast<long long>(dw.max.y) - dw.min.y + 1;
        if (w <= 0 || h <= 0 || w > kMaxTextureSide || h > kMaxTextureSide)
            throw InputError(p, "", "the image is " + std::to_string(w) + "x" + std::to_string(h) +
                                         " pixels; at most " + std::to_string(kMaxTextureSide) + " on a side");
        std::vector<Imf::Rgba> rgba(static_cast<std::size_t>(w * h));
        file.setFrameBuffer(rgba.data() - dw.min.x - dw.min.y * w, 1, static_cast<std::size_t>(w));
        file.readPixels(dw.min.y, dw.max.y);
        out.width = static_cast<int>(w);
        out.height = static_cast<int>(h);
        out.pixels.resize(rgba.size());
        for (std::size_t i = 0; i < rgba.size(); ++i) out.pixels[i] = Vec3(rgba[i].r, rgba[i].g, rgba[i].b);
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(p, "", std::string("OpenEXR cannot read it: ") + e.what());
    }
    return out;
}

}  // namespace

LinearRgbImage readLinearImage(const std::filesystem::path& path) {
    // (an EXR is read again by OpenEXR, from the page cache: this read tells a failing disk apart)
    const std::string text = readInputFile(path, "environment image", kMaxImageBytes);
    const auto* bytes = reinterpret_cast<const unsigned char*>(text.data());
    const std::size_t size = text.size();
    const std::string p = path.string();
    LinearRgbImage out;
    const bool exr = size >= 4 && bytes[0] == 0x76 && bytes[1] == 0x2f && bytes[2] == 0x31 && bytes[3] == 0x01;
    if (exr) {
        out = readExrRgb(p);
    } else if (stbi_is_hdr_from_memory(bytes, static_cast<int>(size))) {
        int w = 0, h = 0, channels = 0;
        if (!stbi_info_from_memory(bytes, static_cast<int>(size), &w, &h, &channels) || w <= 0 ||
            h <= 0 || w > kMaxTextureSide || h > kMaxTextureSide)
            throw InputError(p, "", "not a Radiance HDR image dgv reads, or larger than " +
                                        std::to_string(kMaxTextureSide) + " pixels on a side");
        std::unique_ptr<float, void (*)(void*)> f(
            stbi_loadf_from_memory(bytes, static_cast<int>(size), &w, &h, &channels, 3), stbi_image_free);
        if (!f) {
            const char* why = stbi_failure_reason();
            throw InputError(p, "", std::string("the HDR image cannot be decoded: ") + (why ? why : "unknown error"));
        }
        out.width = w;
        out.height = h;
        out.pixels.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
        for (std::size_t i = 0; i < out.pixels.size(); ++i)
            out.pixels[i] = Vec3(f.get()[3 * i], f.get()[3 * i + 1], f.get()[3 * i + 2]);
    } else {
        const TextureImage t = decodeTexture(bytes, size, p);
        out.width = t.width;
        out.height = t.height;
        out.pixels.resize(static_cast<std::size_t>(t.width) * static_cast<std::size_t>(t.height));
        for (std::size_t i = 0; i < out.pixels.size(); ++i)
            out.pixels[i] = Vec3(decodeSrgb(t.rgba[4 * i] / 255.0), decodeSrgb(t.rgba[4 * i + 1] / 255.0),
                                 decodeSrgb(t.rgba[4 * i + 2] / 255.0));
    }
    // Lossy HDR compression leaves small negative values: light is not negative, so they are 0.
    for (Vec3& c : out.pixels) {
        if (!c.allFinite()) throw InputError(p, "", "holds a non-finite pixel (infinite or NaN)");
        c = c.cwiseMax(0.0);
    }
    return out;
}

TextureImage readTexture(const std::filesystem::path& path) {
    const std::string bytes = readInputFile(path, "texture", kMaxImageBytes);
    return decodeTexture(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), path.string());
}

}  // namespace dgv
