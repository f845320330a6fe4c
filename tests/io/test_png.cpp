// PNG writing and reading through libpng's classic API.

#include "io/png.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <fstream>
#include <iterator>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

Image pattern(int w, int h, bool eightBitValues) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            std::uint16_t* p = img.pixel(x, y);
            const unsigned v[4] = {static_cast<unsigned>(x * 37 + y * 11), static_cast<unsigned>(x * y * 7 + 3),
                                   static_cast<unsigned>(65535 - x * 101 - y), static_cast<unsigned>((x + y) * 997)};
            for (int c = 0; c < 4; ++c)
                p[c] = static_cast<std::uint16_t>(eightBitValues ? (v[c] % 256) * 257 : v[c] % 65536);
        }
    return img;
}

std::vector<unsigned char> readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The chunk types in file order.
std::vector<std::string> chunkTypes(const std::vector<unsigned char>& png) {
    std::vector<std::string> types;
    std::size_t at = 8;
    while (at + 8 <= png.size()) {
        const std::uint32_t len = (std::uint32_t(png[at]) << 24) | (std::uint32_t(png[at + 1]) << 16) |
                                  (std::uint32_t(png[at + 2]) << 8) | png[at + 3];
        types.emplace_back(reinterpret_cast<const char*>(&png[at + 4]), 4);
        at += 12 + len;
    }
    return types;
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
}

std::size_t filesIn(const fs::path& dir) {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

}  // namespace

TEST_CASE("png: 8- and 16-bit round trips are exact, tEXt comes back", "[io]") {
    test::FpTrapsOff guard;
    test::TempDir dir("png-roundtrip");
    const std::vector<std::pair<std::string, std::string>> text = {{"Software", "dgv 0.1"}, {"dgv:frame", "12"}};

    PngWriteOptions o16;
    o16.bitDepth = 16;
    o16.text = text;
    const Image img16 = pattern(37, 23, false);
    writePng(dir.path() / "a16.png", img16, o16);
    std::vector<std::pair<std::string, std::string>> got;
    const Image back16 = readPng(dir.path() / "a16.png", &got);
    CHECK(back16.width == 37);
    CHECK(back16.height == 23);
    CHECK(back16.rgba == img16.rgba);
    CHECK(got == text);

    PngWriteOptions o8;
    o8.text = text;
    const Image img8 = pattern(37, 23, true);  // 8-bit values (v*257): exact through 8 bits
    writePng(dir.path() / "a8.png", img8, o8);
    const Image back8 = readPng(dir.path() / "a8.png");
    CHECK(back8.rgba == img8.rgba);

    // Arbitrary 16-bit values through 8 bits: the nearest 8-bit code, expanded by 257.
    const Image back8b = readPng((writePng(dir.path() / "b8.png", img16), dir.path() / "b8.png"));
    for (std::size_t i = 0; i < img16.rgba.size(); ++i) REQUIRE(back8b.rgba[i] == to8bit(img16.rgba[i]) * 257);

    // RGB without alpha reads back opaque.
    PngWriteOptions rgb;
    rgb.alpha = false;
    writePng(dir.path() / "rgb.png", img8, rgb);
    const Image backRgb = readPng(dir.path() / "rgb.png");
    for (int y = 0; y < img8.height; ++y)
        for (int x = 0; x < img8.width; ++x) {
            REQUIRE(std::memcmp(backRgb.pixel(x, y), img8.pixel(x, y), 6) == 0);
            REQUIRE(backRgb.pixel(x, y)[3] == 65535);
        }
    CHECK(filesIn(dir.path()) == 4);  // no temporaries left
}

TEST_CASE("png: encoding is deterministic and tagged sRGB, without timestamps", "[io][determinism]") {
    test::FpTrapsOff guard;
    const Image img = pattern(64, 48, false);
    for (int depth : {8, 16}) {
        PngWriteOptions o;
        o.bitDepth = depth;
        o.text = {{"Software", "dgv"}};
        const std::vector<unsigned char> a = encodePng(img, o);
        const std::vector<unsigned char> b = encodePng(img, o);
        CHECK(a == b);
        const std::vector<std::string> chunks = chunkTypes(a);
        CHECK(chunks.front() == "IHDR");
        CHECK(contains(chunks, "sRGB"));
        CHECK(contains(chunks, "gAMA"));
        CHECK(contains(chunks, "cHRM"));
        CHECK(contains(chunks, "tEXt"));
        CHECK_FALSE(contains(chunks, "tIME"));
        CHECK(chunks.back() == "IEND");
        CHECK(a[24] == depth);  // IHDR bit depth
        CHECK(a[25] == 6);      // RGBA
    }
    // The file on disk is the same bytes as in memory.
    test::TempDir dir("png-bytes");
    writePng(dir.path() / "x.png", img);
    CHECK(readBytes(dir.path() / "x.png") == encodePng(img));
}

TEST_CASE("png: a write that cannot happen throws and leaves nothing behind", "[io]") {
    test::FpTrapsOff guard;
    test::TempDir dir("png-fail");
    const Image img = pattern(8, 8, false);
    // Tests run as root, so a read-only folder would not stop the write: use a path whose
    // parent is a regular file, a missing folder, and /proc.
    std::ofstream(dir.path() / "file") << "x";
    for (const fs::path& target :
         {dir.path() / "file" / "a.png", dir.path() / "missing" / "a.png", fs::path("/proc/dgv-test.png")}) {
        try {
            writePng(target, img);
            FAIL("expected a RuntimeError for " << target);
        } catch (const RuntimeError& e) {
            CHECK(std::string(e.what()).find(target.string()) != std::string::npos);
        }
        CHECK_FALSE(fs::exists(target));
        CHECK_FALSE(fs::exists(temporaryPathFor(target)));
    }
    CHECK(filesIn(dir.path()) == 1);
}

TEST_CASE("png: unreadable, truncated or garbage files are input errors naming the file", "[io]") {
    test::FpTrapsOff guard;
    test::TempDir dir("png-bad");
    const std::vector<unsigned char> good = encodePng(pattern(32, 32, false));
    const fs::path truncated = dir.path() / "truncated.png";
    std::ofstream(truncated, std::ios::binary)
        .write(reinterpret_cast<const char*>(good.data()), static_cast<std::streamsize>(good.size() / 2));
    const fs::path garbage = dir.path() / "garbage.png";
    std::ofstream(garbage) << "this is not a png file at all, just text that goes on for a while";
    const fs::path corrupt = dir.path() / "corrupt.png";
    std::vector<unsigned char> bad = good;
    bad[40] ^= 0xff;  // inside IHDR or the following chunk: a CRC error
    std::ofstream(corrupt, std::ios::binary)
        .write(reinterpret_cast<const char*>(bad.data()), static_cast<std::streamsize>(bad.size()));
    for (const fs::path& p : {truncated, garbage, corrupt, dir.path() / "missing.png"}) {
        try {
            readPng(p);
            FAIL("expected an InputError for " << p);
        } catch (const InputError& e) {
            CHECK(e.input() == p.string());
        }
    }
}

TEST_CASE("png: a header declaring more pixels than the file can hold is refused before allocating", "[io]") {
    // A 1.1 MB file declaring 20000x20000 pixels made imgdiff allocate 3.2 GB and run out of
    // memory. Deflate expands at most 1032:1, so such a header is corrupt; the IHDR of a small
    // PNG is patched to 20000x20000 with its CRC recomputed, so only the declared size is wrong.
    test::FpTrapsOff guard;
    test::TempDir dir("png-huge");
    std::vector<unsigned char> png = encodePng(pattern(16, 16, false));
    REQUIRE(std::memcmp(png.data() + 12, "IHDR", 4) == 0);
    for (int k = 0; k < 2; ++k) {  // width, height (big-endian) at bytes 16 and 20
        const std::uint32_t v = 20000;
        for (int b = 0; b < 4; ++b)
            png[static_cast<std::size_t>(16 + 4 * k + b)] = static_cast<unsigned char>(v >> (24 - 8 * b));
    }
    std::uint32_t crc = 0xffffffffu;  // CRC-32 (PNG's) of the chunk type and data, bytes 12..28
    for (std::size_t i = 12; i < 29; ++i) {
        crc ^= png[i];
        for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    crc ^= 0xffffffffu;
    for (int b = 0; b < 4; ++b) png[static_cast<std::size_t>(29 + b)] = static_cast<unsigned char>(crc >> (24 - 8 * b));
    const fs::path huge = dir.path() / "huge.png";
    std::ofstream(huge, std::ios::binary)
        .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    try {
        readPng(huge);
        FAIL("expected an InputError");
    } catch (const InputError& e) {
        CHECK(e.input() == huge.string());
        CHECK_THAT(e.problem(), Catch::Contains("declares more pixels than its size can hold"));
    }
    // the same image at its own size reads
    const fs::path small = dir.path() / "small.png";
    const std::vector<unsigned char> ok = encodePng(pattern(16, 16, false));
    std::ofstream(small, std::ios::binary)
        .write(reinterpret_cast<const char*>(ok.data()), static_cast<std::streamsize>(ok.size()));
    CHECK(readPng(small).width == 16);
}
