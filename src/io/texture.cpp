#include "io/texture.hpp"

#include "base/errors.hpp"
#include "io/read_file.hpp"

#include <stb_image.h>

#include <cstring>
#include <fstream>
#include <iterator>
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

TextureImage readTexture(const std::filesystem::path& path) {
    const std::string p = path.string();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(p, "", "file not found");
    checkInputReadable(path, "texture");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(p, "", "cannot be opened for reading (permission denied?)");
    const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return decodeTexture(bytes.data(), bytes.size(), p);
}

}  // namespace dgv
