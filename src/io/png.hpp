#pragma once
/// @file png.hpp
/// @brief PNG files through libpng's classic API: 8- or 16-bit RGBA (or RGB), sRGB chunk,
/// tEXt provenance, fixed compression settings (same image -> same bytes; no timestamps).

#include "base/image.hpp"

#include <condition_variable>
#include <exception>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace dgv {

struct PngWriteOptions {
    int bitDepth = 8;   ///< 8 or 16
    bool alpha = true;  ///< RGBA; false writes RGB (alpha dropped)
    /// zlib level: 0 stored; 1-3 run-length matches only (Z_RLE: the fastest, and on rendered
    /// frames about as small as the default strategy at level 3); 4-9 the default strategy.
    int compressionLevel = 3;
    std::vector<std::pair<std::string, std::string>> text;  ///< tEXt key/value pairs
};

/// Writes `image` to `path` atomically (atomic_file.hpp). RuntimeError on failure.
void writePng(const std::filesystem::path& path, const Image& image, const PngWriteOptions& options = {});

/// Encodes to memory (for tests and byte comparisons).
std::vector<unsigned char> encodePng(const Image& image, const PngWriteOptions& options = {});

/// Reads any PNG (8/16-bit, grey/RGB/RGBA/palette) into a 16-bit RGBA Image. InputError naming
/// the file on failure. `text`, when given, receives the tEXt chunks.
Image readPng(const std::filesystem::path& path, std::vector<std::pair<std::string, std::string>>* text = nullptr);

/// Encodes and writes PNGs on one worker thread while the caller renders the next frame: one
/// frame in flight, written in submission order, bytes identical to writePng. An error in the
/// worker is rethrown (as RuntimeError) by the next submit(), wait() or finish().
class PngWriteQueue {
public:
    PngWriteQueue();
    /// Waits for the frame in flight (an error there is dropped: call finish() to see it).
    ~PngWriteQueue();
    PngWriteQueue(const PngWriteQueue&) = delete;
    PngWriteQueue& operator=(const PngWriteQueue&) = delete;

    /// Waits for the previous frame, then hands `image` to the worker (moved, not copied).
    /// `done`, when given, runs on the worker after the file is in place (e.g. progress).
    void submit(std::filesystem::path path, Image image, PngWriteOptions options,
                std::function<void(const std::string&)> done = {});
    /// Waits until the frame in flight is written; rethrows its error.
    void finish();

private:
    void run();
    std::mutex mMutex;
    std::condition_variable mCv;
    bool mBusy = false, mStop = false;
    std::filesystem::path mPath;
    Image mImage;
    PngWriteOptions mOptions;
    std::function<void(const std::string&)> mDone;
    std::exception_ptr mError;
    std::thread mThread;
};

}  // namespace dgv
