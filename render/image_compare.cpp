#include "render/image_compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dgv {

namespace {
/// 16-bit sample in 8-bit code values (0..255, not rounded).
double code8(std::uint16_t v) { return v * (255.0 / 65535.0); }
const char* kChannelNames[4] = {"R", "G", "B", "A"};
}  // namespace

std::string ImageCompareResult::summary() const {
    char buf[512];
    if (sizeMismatch) return "FAIL: the image sizes differ";
    if (differing == 0) {
        std::snprintf(buf, sizeof buf, "%s: 0 pixels differ; mean error %.4f, max error %.3f at (%d, %d) channel %s",
                      pass ? "PASS" : "FAIL", meanError, maxError, maxX, maxY, kChannelNames[maxChannel]);
    } else {
        std::snprintf(buf, sizeof buf,
                      "%s: %ld pixels (%.4f%%) over the threshold; mean error %.4f, max error %.3f at "
                      "(%d, %d) channel %s; differing pixels in x %d..%d, y %d..%d",
                      pass ? "PASS" : "FAIL", differing, 100.0 * fraction, meanError, maxError, maxX, maxY,
                      kChannelNames[maxChannel], boxMinX, boxMaxX, boxMinY, boxMaxY);
    }
    return buf;
}

ImageCompareResult compareImages(const Image& reference, const Image& candidate, const ImageCompareSettings& settings) {
    ImageCompareResult r;
    if (reference.width != candidate.width || reference.height != candidate.height ||
        reference.rgba.size() != candidate.rgba.size() ||
        reference.rgba.size() != static_cast<std::size_t>(reference.width) * reference.height * 4) {
        r.sizeMismatch = true;
        r.pass = false;
        return r;
    }
    const long pixels = static_cast<long>(reference.width) * reference.height;
    double sum = 0;
    bool hardFail = false;
    r.boxMinX = reference.width;
    r.boxMinY = reference.height;
    for (int y = 0; y < reference.height; ++y) {
        for (int x = 0; x < reference.width; ++x) {
            const std::uint16_t* a = reference.pixel(x, y);
            const std::uint16_t* b = candidate.pixel(x, y);
            double d = 0;
            int channel = 0;
            for (int c = 0; c < 4; ++c) {
                const double e = std::abs(code8(a[c]) - code8(b[c]));
                if (e > d) {
                    d = e;
                    channel = c;
                }
            }
            sum += d;
            if (d > r.maxError) {
                r.maxError = d;
                r.maxX = x;
                r.maxY = y;
                r.maxChannel = channel;
            }
            if (d > settings.threshold) {
                ++r.differing;
                r.boxMinX = std::min(r.boxMinX, x);
                r.boxMinY = std::min(r.boxMinY, y);
                r.boxMaxX = std::max(r.boxMaxX, x);
                r.boxMaxY = std::max(r.boxMaxY, y);
            }
            if (settings.hard >= 0 && d > settings.hard) hardFail = true;
        }
    }
    if (r.differing == 0) {
        r.boxMinX = r.boxMinY = 0;
        r.boxMaxX = r.boxMaxY = -1;
    }
    r.fraction = pixels > 0 ? static_cast<double>(r.differing) / static_cast<double>(pixels) : 0.0;
    r.meanError = pixels > 0 ? sum / static_cast<double>(pixels) : 0.0;
    r.pass = !hardFail && r.fraction <= settings.maxFraction;
    return r;
}

Image differenceImage(const Image& a, const Image& b, double gain) {
    const int w = std::min(a.width, b.width), h = std::min(a.height, b.height);
    Image out(std::max(w, 0), std::max(h, 0));
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const std::uint16_t* pa = a.pixel(x, y);
            const std::uint16_t* pb = b.pixel(x, y);
            std::uint16_t* o = out.pixel(x, y);
            for (int c = 0; c < 3; ++c) {
                const double d = std::abs(static_cast<double>(pa[c]) - static_cast<double>(pb[c])) * gain;
                o[c] = static_cast<std::uint16_t>(std::min(d + 0.5, 65535.0));
            }
            // Alpha differences show as grey added to all channels, so they are not lost.
            const double da = std::abs(static_cast<double>(pa[3]) - static_cast<double>(pb[3])) * gain;
            for (int c = 0; c < 3; ++c) o[c] = static_cast<std::uint16_t>(std::min(65535.0, o[c] + da));
            o[3] = 65535;
        }
    }
    return out;
}

}  // namespace dgv
