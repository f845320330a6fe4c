#include "io/png.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/read_file.hpp"

#include <png.h>
#include <zlib.h>  // Z_RLE
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <utility>

namespace dgv {

namespace fs = std::filesystem;

// libpng reports errors by longjmp. longjmp across a C++ frame that owns objects with
// destructors is undefined behaviour, so everything between setjmp and the end of libpng's
// work lives in the C-style functions below, over raw buffers prepared by their C++ callers.
namespace {

struct PngError {
    char message[256];
};

extern "C" void pngErrorFn(png_structp png, png_const_charp msg) {
    auto* err = static_cast<PngError*>(png_get_error_ptr(png));
    std::snprintf(err->message, sizeof err->message, "%s", msg ? msg : "libpng error");
    png_longjmp(png, 1);
}

extern "C" void pngWarningFn(png_structp, png_const_charp) {}

/// Growable byte buffer owned by C code (malloc/realloc), for encoding to memory.
struct MemoryBuffer {
    unsigned char* data;
    std::size_t size;
    std::size_t capacity;
};

extern "C" void pngWriteMemory(png_structp png, png_bytep bytes, png_size_t n) {
    auto* buf = static_cast<MemoryBuffer*>(png_get_io_ptr(png));
    if (buf->size + n > buf->capacity) {
        std::size_t cap = buf->capacity ? buf->capacity : 65536;
        while (cap < buf->size + n) cap *= 2;
        void* grown = std::realloc(buf->data, cap);
        if (!grown) png_error(png, "out of memory");
        buf->data = static_cast<unsigned char*>(grown);
        buf->capacity = cap;
    }
    std::memcpy(buf->data + buf->size, bytes, n);
    buf->size += n;
}

extern "C" void pngFlushMemory(png_structp) {}

/// Everything the encoder needs, prepared by the caller. rows[y] points at row y (top first):
/// 8-bit samples, or 16-bit samples in host (little-endian) order.
struct EncodeJob {
    int width, height, bitDepth;
    int channelsIn;  // 4 (RGBA in memory)
    bool alphaOut;   // write RGBA, else RGB (the 4th sample is stripped)
    int compressionLevel;
    png_bytep* rows;
    png_textp text;
    int textCount;
    FILE* file;         // either a file...
    MemoryBuffer* mem;  // ...or memory
};

/// Returns 0 on success, else 1 with err->message set. No C++ objects with destructors here.
int encodeRaw(const EncodeJob* job, PngError* err) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, err, pngErrorFn, pngWarningFn);
    if (!png) {
        std::snprintf(err->message, sizeof err->message, "png_create_write_struct failed");
        return 1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, nullptr);
        std::snprintf(err->message, sizeof err->message, "png_create_info_struct failed");
        return 1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return 1;
    }
    if (job->file) {
        png_init_io(png, job->file);
    } else {
        png_set_write_fn(png, job->mem, pngWriteMemory, pngFlushMemory);
    }
    // Fixed settings: one filter, fixed level -> the same image always gives the same bytes.
    png_set_compression_level(png, job->compressionLevel);
    // Levels 1-3: zlib's run-length strategy (matches at distance 1 only). On SUB-filtered
    // renders it is 1.6-1.7x faster than the default strategy at level 3 and about as small
    // (a 1080p frame: 14 vs 22 ms, 288 vs 304 KB; docs/rendering.md).
    if (job->compressionLevel >= 1 && job->compressionLevel <= 3) png_set_compression_strategy(png, Z_RLE);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_IHDR(png, info, static_cast<png_uint_32>(job->width), static_cast<png_uint_32>(job->height), job->bitDepth,
                 job->alphaOut ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    if (job->textCount > 0) png_set_text(png, info, job->text, job->textCount);
    png_write_info(png, info);
    if (job->bitDepth == 16) png_set_swap(png);  // PNG is big-endian; our samples are not
    if (!job->alphaOut && job->channelsIn == 4) png_set_filler(png, 0, PNG_FILLER_AFTER);
    png_write_image(png, job->rows);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

/// Decoder state shared between the C-style reader and its C++ caller.
struct DecodeJob {
    FILE* file;
    png_structp png;
    png_infop info;
    png_infop endInfo;
    unsigned char* pixels;  // malloc'd, width*height*8 bytes (16-bit RGBA, host order)
    png_bytep* rows;        // malloc'd row pointers into pixels
    png_uint_32 width, height;
};

/// Reads the whole file into job->pixels. 0 on success, else 1 with err->message set; the
/// caller always calls finishDecode(). No C++ objects with destructors here.
int decodeRaw(DecodeJob* job, PngError* err) {
    unsigned char sig[8];
    if (std::fread(sig, 1, 8, job->file) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
        std::snprintf(err->message, sizeof err->message, "not a PNG file");
        return 1;
    }
    job->png = png_create_read_struct(PNG_LIBPNG_VER_STRING, err, pngErrorFn, pngWarningFn);
    if (!job->png) {
        std::snprintf(err->message, sizeof err->message, "png_create_read_struct failed");
        return 1;
    }
    job->info = png_create_info_struct(job->png);
    job->endInfo = png_create_info_struct(job->png);
    if (!job->info || !job->endInfo) {
        std::snprintf(err->message, sizeof err->message, "png_create_info_struct failed");
        return 1;
    }
    if (setjmp(png_jmpbuf(job->png))) return 1;
    png_init_io(job->png, job->file);
    png_set_sig_bytes(job->png, 8);
    png_set_user_limits(job->png, 65536, 65536);
    png_read_info(job->png, job->info);

    const int colorType = png_get_color_type(job->png, job->info);
    const int bitDepth = png_get_bit_depth(job->png, job->info);
    {
        // The declared size against the file's, before the pixels are allocated: the image data
        // is deflate-compressed, which expands by at most 1032:1, so a header that declares
        // more filtered rows than the file's bytes can inflate to is corrupt (a 1.1 MB file
        // declaring 20000x20000 pixels made imgdiff allocate 3.2 GB and die).
        struct stat st {};
        const double fileBytes = fstat(fileno(job->file), &st) == 0 ? double(st.st_size) : 0;
        const double w = png_get_image_width(job->png, job->info), h = png_get_image_height(job->png, job->info);
        const double bitsPerPixel = double(png_get_channels(job->png, job->info)) * bitDepth;
        const double filtered = h * (1 + std::ceil(w * bitsPerPixel / 8));
        if (fileBytes > 0 && filtered > 1032.0 * fileBytes + 65536)
            png_error(job->png, "its header declares more pixels than its size can hold (truncated or corrupt)");
    }
    png_set_expand(job->png);                        // palette -> RGB, grey < 8 bits -> 8, tRNS -> alpha
    if (bitDepth < 16) png_set_expand_16(job->png);  // 8-bit v -> v*257
    if (colorType == PNG_COLOR_TYPE_GRAY || colorType == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(job->png);
    if (!(colorType & PNG_COLOR_MASK_ALPHA) && !png_get_valid(job->png, job->info, PNG_INFO_tRNS))
        png_set_add_alpha(job->png, 0xffff, PNG_FILLER_AFTER);
    png_set_swap(job->png);  // big-endian file samples -> host order
    png_set_interlace_handling(job->png);
    png_read_update_info(job->png, job->info);

    job->width = png_get_image_width(job->png, job->info);
    job->height = png_get_image_height(job->png, job->info);
    const png_size_t rowBytes = png_get_rowbytes(job->png, job->info);
    if (rowBytes != static_cast<png_size_t>(job->width) * 8) {
        png_error(job->png, "unexpected row layout after conversion to 16-bit RGBA");
    }
    job->pixels = static_cast<unsigned char*>(std::malloc(rowBytes * job->height));
    job->rows = static_cast<png_bytep*>(std::malloc(sizeof(png_bytep) * job->height));
    if (!job->pixels || !job->rows) png_error(job->png, "out of memory");
    for (png_uint_32 y = 0; y < job->height; ++y) job->rows[y] = job->pixels + rowBytes * y;
    png_read_image(job->png, job->rows);
    png_read_end(job->png, job->endInfo);
    return 0;
}

void finishDecode(DecodeJob* job) {
    if (job->png)
        png_destroy_read_struct(&job->png, job->info ? &job->info : nullptr, job->endInfo ? &job->endInfo : nullptr);
    std::free(job->rows);
    std::free(job->pixels);
    job->rows = nullptr;
    job->pixels = nullptr;
}

void validateImage(const Image& image) {
    if (image.width <= 0 || image.height <= 0 ||
        image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4) {
        throw RuntimeError("PNG: invalid image (" + std::to_string(image.width) + "x" + std::to_string(image.height) +
                           ", " + std::to_string(image.rgba.size()) + " samples)");
    }
}

/// The caller-owned buffers an EncodeJob points into.
struct EncodeBuffers {
    std::vector<std::uint8_t> bytes8;
    std::vector<png_bytep> rows;
    std::vector<png_text> text;
};

EncodeJob prepareEncode(const Image& image, const PngWriteOptions& options, EncodeBuffers& buffers) {
    validateImage(image);
    if (options.bitDepth != 8 && options.bitDepth != 16)
        throw RuntimeError("PNG: bit depth must be 8 or 16, got " + std::to_string(options.bitDepth));
    if (options.compressionLevel < 0 || options.compressionLevel > 9)
        throw RuntimeError("PNG: compression level must be 0..9, got " + std::to_string(options.compressionLevel));
    const std::size_t rowSamples = static_cast<std::size_t>(image.width) * 4;
    buffers.rows.resize(static_cast<std::size_t>(image.height));
    if (options.bitDepth == 8) {
        buffers.bytes8.resize(image.rgba.size());
        for (std::size_t i = 0; i < image.rgba.size(); ++i) buffers.bytes8[i] = to8bit(image.rgba[i]);
        for (int y = 0; y < image.height; ++y)
            buffers.rows[static_cast<std::size_t>(y)] = buffers.bytes8.data() + rowSamples * y;
    } else {
        // libpng takes non-const rows but does not modify them when writing.
        auto* base = reinterpret_cast<png_bytep>(const_cast<std::uint16_t*>(image.rgba.data()));
        for (int y = 0; y < image.height; ++y) buffers.rows[static_cast<std::size_t>(y)] = base + rowSamples * 2 * y;
    }
    for (const auto& [key, value] : options.text) {
        if (key.empty() || key.size() > 79 || key.front() == ' ' || key.back() == ' ')
            throw RuntimeError(
                "PNG: tEXt keyword must be 1-79 characters without leading or "
                "trailing spaces: '" +
                key + "'");
        png_text t{};
        t.compression = PNG_TEXT_COMPRESSION_NONE;
        t.key = const_cast<char*>(key.c_str());
        t.text = const_cast<char*>(value.c_str());
        t.text_length = value.size();
        buffers.text.push_back(t);
    }
    EncodeJob job{};
    job.width = image.width;
    job.height = image.height;
    job.bitDepth = options.bitDepth;
    job.channelsIn = 4;
    job.alphaOut = options.alpha;
    job.compressionLevel = options.compressionLevel;
    job.rows = buffers.rows.data();
    job.text = buffers.text.empty() ? nullptr : buffers.text.data();
    job.textCount = static_cast<int>(buffers.text.size());
    return job;
}

}  // namespace

std::vector<unsigned char> encodePng(const Image& image, const PngWriteOptions& options) {
    EncodeBuffers buffers;
    EncodeJob job = prepareEncode(image, options, buffers);
    MemoryBuffer mem{nullptr, 0, 0};
    job.mem = &mem;
    PngError err{};
    const int rc = encodeRaw(&job, &err);
    std::vector<unsigned char> out;
    if (rc == 0) out.assign(mem.data, mem.data + mem.size);
    std::free(mem.data);
    if (rc != 0) throw RuntimeError(std::string("PNG encoding failed: ") + err.message);
    return out;
}

void writePng(const fs::path& path, const Image& image, const PngWriteOptions& options) {
    EncodeBuffers buffers;
    EncodeJob job = prepareEncode(image, options, buffers);
    writeFileAtomically(path, [&](const fs::path& tmp) {
        FILE* f = std::fopen(tmp.c_str(), "wb");
        if (!f) throw RuntimeError(std::strerror(errno));
        job.file = f;
        PngError err{};
        errno = 0;
        if (encodeRaw(&job, &err) != 0) {
            // libpng says only "Write Error" when fwrite fails: add why (ENOSPC, EFBIG, EIO).
            const int e = std::ferror(f) ? errno : 0;
            std::fclose(f);
            throw RuntimeError(std::string("libpng: ") + err.message + (e ? std::string(": ") + std::strerror(e) : ""));
        }
        if (std::fflush(f) != 0) {
            const int e = errno;
            std::fclose(f);
            throw RuntimeError(std::string("fflush: ") + std::strerror(e));
        }
        if (::fsync(fileno(f)) != 0) {
            const int e = errno;
            std::fclose(f);
            throw RuntimeError(std::string("fsync: ") + std::strerror(e));
        }
        if (std::fclose(f) != 0) throw RuntimeError(std::string("fclose: ") + std::strerror(errno));
    });
}

Image readPng(const fs::path& path, std::vector<std::pair<std::string, std::string>>* text) {
    // A failing disk's EIO is exit 1 (RuntimeError), not libpng's "Read Error" on bad content.
    if (std::error_code ec; fs::is_regular_file(path, ec)) checkInputReadable(path, "PNG file");
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw InputError(path.string(), "", std::strerror(errno));
    DecodeJob job{};
    job.file = f;
    PngError err{};
    const int rc = decodeRaw(&job, &err);
    Image image;
    if (rc == 0) {
        image = Image(static_cast<int>(job.width), static_cast<int>(job.height));
        std::memcpy(image.rgba.data(), job.pixels, image.rgba.size() * sizeof(std::uint16_t));
        if (text) {
            text->clear();
            for (png_infop info : {job.info, job.endInfo}) {
                png_textp chunks = nullptr;
                const int n = png_get_text(job.png, info, &chunks, nullptr);
                for (int i = 0; i < n; ++i) {
                    text->emplace_back(chunks[i].key, std::string(chunks[i].text, chunks[i].text_length));
                }
            }
        }
    }
    finishDecode(&job);
    std::fclose(f);
    if (rc != 0) throw InputError(path.string(), "", std::string("cannot read PNG: ") + err.message);
    return image;
}

PngWriteQueue::PngWriteQueue() : mThread([this] { run(); }) {}

PngWriteQueue::~PngWriteQueue() {
    {
        std::unique_lock<std::mutex> lock(mMutex);
        mCv.wait(lock, [&] { return !mBusy; });
        mStop = true;
    }
    mCv.notify_all();
    mThread.join();
}

void PngWriteQueue::submit(std::filesystem::path path, Image image, PngWriteOptions options,
                           std::function<void(const std::string&)> done) {
    std::unique_lock<std::mutex> lock(mMutex);
    mCv.wait(lock, [&] { return !mBusy; });
    if (mError) std::rethrow_exception(std::exchange(mError, nullptr));
    mPath = std::move(path);
    mImage = std::move(image);
    mOptions = std::move(options);
    mDone = std::move(done);
    mBusy = true;
    lock.unlock();
    mCv.notify_all();
}

void PngWriteQueue::finish() {
    std::unique_lock<std::mutex> lock(mMutex);
    mCv.wait(lock, [&] { return !mBusy; });
    if (mError) std::rethrow_exception(std::exchange(mError, nullptr));
}

void PngWriteQueue::run() {
    std::unique_lock<std::mutex> lock(mMutex);
    for (;;) {
        mCv.wait(lock, [&] { return mBusy || mStop; });
        if (!mBusy) return;  // stopping with nothing in flight
        lock.unlock();
        std::exception_ptr error;
        try {
            writePng(mPath, mImage, mOptions);
            if (mDone) mDone(mPath.string());
        } catch (...) {
            error = std::current_exception();
        }
        lock.lock();
        mError = error;
        mBusy = false;
        mCv.notify_all();
    }
}

}  // namespace dgv
