#pragma once
/// @file image_compare.hpp
/// @brief The golden-image rule (docs/rendering.md, "Golden images"): compare decoded pixels;
/// a pixel differs when max over R,G,B,A of |a - b| (8-bit code values) exceeds `threshold`;
/// the images match when at most `maxFraction` of the pixels differ (and none exceeds `hard`).

#include "base/image.hpp"

#include <string>

namespace dgv {

struct ImageCompareSettings {
    double threshold = 4.0;      ///< per-pixel tolerance, 8-bit code values
    double maxFraction = 0.005;  ///< fraction of pixels allowed over the threshold
    double hard = -1;            ///< any pixel above this fails; < 0: off
};

struct ImageCompareResult {
    bool sizeMismatch = false;
    bool pass = false;
    long differing = 0;  ///< pixels over the threshold
    double fraction = 0;
    double meanError = 0;  ///< mean of the per-pixel max channel error
    double maxError = 0;
    int maxX = 0, maxY = 0, maxChannel = 0;
    int boxMinX = 0, boxMinY = 0, boxMaxX = -1, boxMaxY = -1;  ///< bounds of differing pixels

    std::string summary() const;  ///< one line with the figures above
};

ImageCompareResult compareImages(const Image& reference, const Image& candidate,
                                 const ImageCompareSettings& settings = {});

/// |a - b| * gain per channel, alpha opaque (for the .diff.png written on failure).
Image differenceImage(const Image& a, const Image& b, double gain = 16);

}  // namespace dgv
