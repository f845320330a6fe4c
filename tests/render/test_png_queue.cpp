// PngWriteQueue (io/png.hpp): what `dgv render` uses to encode frame n while frame n+1 draws.
// Same bytes as encodePng, files in order, errors surface on the caller's thread.

#include "io/png.hpp"

#include "base/errors.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

Image gradient(int w, int h, int seed) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            std::uint16_t* p = img.pixel(x, y);
            p[0] = static_cast<std::uint16_t>((x * 997 + seed * 31) & 0xffff);
            p[1] = static_cast<std::uint16_t>((y * 1231 + seed) & 0xffff);
            p[2] = static_cast<std::uint16_t>(((x + y) * 409) & 0xffff);
            p[3] = 65535;
        }
    return img;
}

std::vector<unsigned char> readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

TEST_CASE("png queue: frames written on the worker are byte-identical to encodePng", "[render][png]") {
    test::TempDir dir("png-queue");
    PngWriteOptions opts;
    opts.bitDepth = 16;
    opts.text = {{"Software", "dgv test"}};
    std::vector<std::string> done;
    {
        PngWriteQueue queue;
        for (int i = 0; i < 3; ++i)
            queue.submit(dir.path() / ("f." + std::to_string(i) + ".png"), gradient(40, 30, i), opts,
                         [&done](const std::string& path) { done.push_back(path); });
        queue.finish();
    }
    REQUIRE(done.size() == 3);
    for (int i = 0; i < 3; ++i) {
        const fs::path p = dir.path() / ("f." + std::to_string(i) + ".png");
        CHECK(done[static_cast<std::size_t>(i)] == p.string());
        CHECK(readBytes(p) == encodePng(gradient(40, 30, i), opts));
    }
    // Only the three frames: no temporaries left behind.
    CHECK(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()) == 3);
}

TEST_CASE("png queue: a failed write is rethrown on the caller's thread", "[render][png]") {
    test::TempDir dir("png-queue-fail");
    PngWriteQueue queue;
    queue.submit(dir.path() / "missing-folder" / "f.0001.png", gradient(8, 8, 0), PngWriteOptions{});
    CHECK_THROWS_AS(queue.finish(), RuntimeError);
    // The error is reported once; the queue keeps working.
    queue.submit(dir.path() / "ok.png", gradient(8, 8, 1), PngWriteOptions{});
    CHECK_NOTHROW(queue.finish());
    CHECK(fs::exists(dir.path() / "ok.png"));
}
