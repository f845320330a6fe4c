// The sRGB curves of base/image.hpp against the standard's own figures.
#include <catch2/catch.hpp>

#include "base/image.hpp"

using namespace dgv;

TEST_CASE("image: the sRGB decode is the encode's inverse and meets IEC 61966-2-1's figures", "[base]") {
    // the two pieces meet at the standard's break points, continuously
    CHECK(encodeSrgb(0.0031308) == Approx(0.04045).margin(1e-7));
    CHECK(decodeSrgb(0.04045) == Approx(0.0031308).margin(1e-7));
    CHECK(encodeSrgb(0.0) == 0.0);
    CHECK(encodeSrgb(1.0) == Approx(1.0).epsilon(1e-15));
    CHECK(decodeSrgb(1.0) == Approx(1.0).epsilon(1e-15));
    CHECK(decodeSrgb(0.5) == Approx(0.21404114).epsilon(1e-7));  // middle grey: 0.214 linear
    double worst = 0;
    for (int i = 0; i <= 1000; ++i) {
        const double c = i / 1000.0;
        worst = std::max(worst, std::abs(encodeSrgb(decodeSrgb(c)) - c));
    }
    CHECK(worst < 1e-14);
    CHECK(encodeSrgb(-0.5) == 0.0);  // clamped
    CHECK(encodeSrgb(2.0) == Approx(1.0).epsilon(1e-15));
}
