// The golden-image rule.

#include "render/image_compare.hpp"

#include <catch2/catch.hpp>

using namespace dgv;

namespace {
Image gradient(int w, int h) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            std::uint16_t* p = img.pixel(x, y);
            p[0] = static_cast<std::uint16_t>(x * 257);
            p[1] = static_cast<std::uint16_t>(y * 257);
            p[2] = 32768;
            p[3] = 65535;
        }
    return img;
}
}  // namespace

TEST_CASE("image_compare: identical images pass with zero error", "[render]") {
    const Image a = gradient(40, 30);
    const ImageCompareResult r = compareImages(a, a);
    CHECK(r.pass);
    CHECK_FALSE(r.sizeMismatch);
    CHECK(r.differing == 0);
    CHECK(r.fraction == 0);
    CHECK(r.meanError == 0);
    CHECK(r.maxError == 0);
    CHECK(r.summary().rfind("PASS", 0) == 0);
}

TEST_CASE("image_compare: one pixel over the threshold fails a zero-fraction rule and is located", "[render]") {
    const Image a = gradient(40, 30);
    Image b = a;
    b.pixel(17, 9)[2] = static_cast<std::uint16_t>(b.pixel(17, 9)[2] + 10 * 257);  // 10 code values in B
    b.pixel(3, 4)[0] = static_cast<std::uint16_t>(b.pixel(3, 4)[0] + 2 * 257);     // 2: under the threshold
    ImageCompareSettings strict;
    strict.maxFraction = 0;
    const ImageCompareResult r = compareImages(a, b, strict);
    CHECK_FALSE(r.pass);
    CHECK(r.differing == 1);
    CHECK(r.fraction == Approx(1.0 / (40 * 30)));
    CHECK(r.maxError == Approx(10.0));
    CHECK(r.maxX == 17);
    CHECK(r.maxY == 9);
    CHECK(r.maxChannel == 2);
    CHECK(r.boxMinX == 17);
    CHECK(r.boxMaxX == 17);
    CHECK(r.boxMinY == 9);
    CHECK(r.boxMaxY == 9);
    CHECK(r.meanError == Approx(12.0 / (40 * 30)));
    const std::string s = r.summary();
    CHECK(s.find("FAIL") == 0);
    CHECK(s.find("(17, 9)") != std::string::npos);
    CHECK(s.find("1 pixels") != std::string::npos);

    // The default rule tolerates 0.5% of the pixels; a hard limit still catches the one.
    CHECK(compareImages(a, b).pass);
    ImageCompareSettings hard;
    hard.hard = 8;
    CHECK_FALSE(compareImages(a, b, hard).pass);
}

TEST_CASE("image_compare: different sizes fail", "[render]") {
    const ImageCompareResult r = compareImages(gradient(40, 30), gradient(30, 40));
    CHECK(r.sizeMismatch);
    CHECK_FALSE(r.pass);
    CHECK(r.summary().find("size") != std::string::npos);
}

TEST_CASE("image_compare: the difference image scales |a - b|", "[render]") {
    const Image a = gradient(8, 8);
    Image b = a;
    b.pixel(2, 3)[1] = static_cast<std::uint16_t>(b.pixel(2, 3)[1] + 100);
    const Image d = differenceImage(a, b, 16);
    CHECK(d.pixel(2, 3)[1] == 1600);
    CHECK(d.pixel(2, 3)[0] == 0);
    CHECK(d.pixel(2, 3)[3] == 65535);
    CHECK(d.pixel(0, 0)[1] == 0);
}
