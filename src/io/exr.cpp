// OpenEXR files through OpenEXR's C++ API (exr.hpp).

#include "io/exr.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"
#include "io/read_file.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStdIO.h>
#include <ImfStringAttribute.h>
#include <ImfThreading.h>
#include <Imath/half.h>

#include <cstdint>
#include <mutex>
#include <new>
#include <stdexcept>

namespace dgv {

namespace fs = std::filesystem;

namespace {

constexpr const char* kSealKey = "dgv_checksum";
constexpr const char* kContact = "contact";
constexpr int kMaxSide = 65536;  // as readPng's limit

/// OpenEXR allocates a file's line offset table from the data window its header declares, before
/// any pixel is read: a damaged or hostile header could ask for gigabytes. Its process-wide
/// limit refuses such a header (and, as the same check runs on writing, writeExr refuses larger
/// images itself).
void limitOpenExr() {
    static std::once_flag once;
    std::call_once(once, [] { Imf::Header::setMaxImageSize(kMaxSide, kMaxSide); });
}

/// A slice of `count` interleaved samples of type T per pixel starting at `first`, over the data
/// window.
template <typename T>
Imf::Slice slice(Imf::PixelType type, const T* first, int count, const Imath::Box2i& window, double fill = 0.0) {
    const std::size_t xStride = sizeof(T) * static_cast<std::size_t>(count);
    const std::size_t yStride = xStride * static_cast<std::size_t>(window.max.x - window.min.x + 1);
    return Imf::Slice::Make(type, first, window, xStride, yStride, 1, 1, fill);
}

void checkImage(const LinearImage& image) {
    const auto bad = [](const std::string& why) { throw std::invalid_argument("writeExr: " + why); };
    if (image.width < 1 || image.height < 1 || image.width > kMaxSide || image.height > kMaxSide)
        bad("the image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
            " (each side must be 1.." + std::to_string(kMaxSide) + ")");
    const std::size_t pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    if (image.rgba.size() != 4 * pixels)
        bad("rgba holds " + std::to_string(image.rgba.size()) + " samples, not 4 per pixel");
    if (image.depth.size() != pixels)
        bad("depth holds " + std::to_string(image.depth.size()) + " samples, not 1 per pixel");
    if (image.contact.size() != pixels)
        bad("contact holds " + std::to_string(image.contact.size()) + " samples, not 1 per pixel");
}

/// The whole file through OpenEXR's reader. Throws OpenEXR's exceptions, or std::runtime_error
/// for a file it reads that is not an image of ours.
LinearImage decode(const fs::path& path, std::vector<std::pair<std::string, std::string>>* text) {
    limitOpenExr();
    Imf::InputFile file(path.c_str(), Imf::globalThreadCount());
    const Imf::Header& header = file.header();
    for (const char* name : {"R", "G", "B"})
        if (!header.channels().findChannel(name))
            throw std::runtime_error(std::string("it has no ") + name + " channel");
    const Imath::Box2i window = header.dataWindow();
    const std::int64_t width = std::int64_t(window.max.x) - window.min.x + 1;
    const std::int64_t height = std::int64_t(window.max.y) - window.min.y + 1;
    // A pixel is at least one 2-byte sample, and OpenEXR's compressors expand a byte of the file
    // into at most ~1032 (deflate's bound; RLE, PIZ and B44 less), so a file holds at most ~516
    // pixels per byte. A header declaring over 1032 (a margin of two) is damaged: refused before
    // allocating for them.
    std::error_code ec;
    const std::uintmax_t bytes = fs::file_size(path, ec);
    if (ec || static_cast<std::uintmax_t>(width * height) > 1032 * bytes)
        throw std::runtime_error("its header declares more pixels than its size can hold (truncated or corrupt)");
    LinearImage image(static_cast<int>(width), static_cast<int>(height));
    // Floats in place: OpenEXR converts from the file's channel types on input. The fill values
    // are what a file without the channel reads as.
    Imf::FrameBuffer fb;
    const char* names[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; ++c)
        fb.insert(names[c], slice(Imf::FLOAT, image.rgba.data() + c, 4, window, c == 3 ? 1.0 : 0.0));
    fb.insert("Z", slice(Imf::FLOAT, image.depth.data(), 1, window, LinearImage::kNoDepth));
    fb.insert(kContact, slice(Imf::FLOAT, image.contact.data(), 1, window));
    file.setFrameBuffer(fb);
    file.readPixels(window.min.y, window.max.y);
    if (text) {
        text->clear();
        for (auto it = header.begin(); it != header.end(); ++it)  // a std::map: sorted by key
            if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute());
                s && it.name() != std::string(kSealKey))
                text->emplace_back(it.name(), s->value());
    }
    return image;
}

}  // namespace

void writeExr(const fs::path& path, const LinearImage& image,
              const std::vector<std::pair<std::string, std::string>>& text) {
    checkImage(image);
    limitOpenExr();
    Imf::Header header(image.width, image.height);  // data = display window, pixel aspect 1
    header.compression() = Imf::ZIP_COMPRESSION;
    header.lineOrder() = Imf::INCREASING_Y;  // y = 0 first: the top row, as in LinearImage
    // Pinned, so that a process-wide setDefaultZipCompressionLevel cannot change the bytes.
    header.zipCompressionLevel() = 4;
    for (const char* name : {"R", "G", "B", "A"}) header.channels().insert(name, Imf::Channel(Imf::HALF));
    header.channels().insert("Z", Imf::Channel(Imf::FLOAT));
    header.channels().insert(kContact, Imf::Channel(Imf::HALF));
    header.insert(kSealKey, Imf::StringAttribute(checksumPlaceholder()));  // sealed below
    const std::string tag = "dgvsum:";
    for (const auto& [key, value] : text) {
        // The seal is the file's first "dgvsum:" tag; the header's attributes go out sorted by
        // name, so a tag in the text could come first.
        if (key.empty() || header.find(key) != header.end() || key.find(tag) != std::string::npos ||
            value.find(tag) != std::string::npos)
            throw std::invalid_argument("writeExr: text key '" + key +
                                        "' is empty, repeated or reserved, or it or its value holds \"dgvsum:\"");
        header.insert(key, Imf::StringAttribute(value));
    }

    // OpenEXR converts pixel types on input only: the half channels are converted here (round to
    // nearest even), R, G, B, A and contact interleaved.
    const std::size_t pixels = image.depth.size();
    std::vector<Imath::half> halves(5 * pixels);
    for (std::size_t i = 0; i < pixels; ++i) {
        for (int c = 0; c < 4; ++c) halves[5 * i + c] = Imath::half(image.rgba[4 * i + c]);
        halves[5 * i + 4] = Imath::half(image.contact[i]);
    }
    const Imath::Box2i window = header.dataWindow();
    Imf::FrameBuffer fb;
    const char* names[5] = {"R", "G", "B", "A", kContact};
    for (int c = 0; c < 5; ++c) fb.insert(names[c], slice(Imf::HALF, halves.data() + c, 5, window));
    fb.insert("Z", slice(Imf::FLOAT, image.depth.data(), 1, window));

    // Encoded whole in memory, so that the seal covers the finished bytes. Scanline blocks of 16
    // rows are compressed independently and go out in y order whatever the thread count.
    std::string bytes;
    try {
        Imf::StdOSStream out;
        {
            Imf::OutputFile file(out, header, Imf::globalThreadCount());
            file.setFrameBuffer(fb);
            file.writePixels(image.height);
        }  // the destructor writes the line offset table
        bytes = out.str();
    } catch (const std::exception& e) {
        throw RuntimeError("cannot write " + path.string() + ": OpenEXR: " + libraryMessage(e.what()));
    }
    sealChecksum(bytes);
    writeTextAtomically(path, bytes);
}

LinearImage readExr(const fs::path& path, std::vector<std::pair<std::string, std::string>>* text) {
    // A failing disk's EIO is exit 1 (RuntimeError), not OpenEXR's complaint about the content.
    checkInputReadable(path, "file in OpenEXR format");
    try {
        return decode(path, text);
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(path.string(), "", "cannot read it as OpenEXR: " + libraryMessage(e.what()));
    }
}

}  // namespace dgv
