#pragma once
/// @file plot.hpp
/// @brief Small line and scatter plots rendered to an Image (no plotting dependency): axes with
/// "nice" ticks (1, 2, 5 × 10^k), grid, tick labels, axis labels, title and legend in a built-in
/// 5×7 bitmap font (upper case, digits, common punctuation; drawn at 2× scale). Used for the GLN
/// figures (app/curve_scene.cpp).

#include "base/image.hpp"
#include "base/types.hpp"

#include <limits>
#include <string>
#include <vector>

namespace dgv::app {

struct PlotSeries {
    std::string label;
    std::vector<double> x, y;    ///< same length; a NaN in either breaks the line there
    Vec3 color = Vec3(0, 0, 0);  ///< sRGB in [0, 1]
    bool lines = true;           ///< join consecutive points
    bool markers = false;        ///< a small square at each point
    int width = 2;               ///< line width in pixels (markers grow with it)
};

struct PlotSpec {
    std::string title, xLabel, yLabel;
    std::vector<PlotSeries> series;
    int width = 900, height = 560;
    /// Fixed y range; NaN: from the data. Values outside are drawn at the border (clipped).
    double yMin = std::numeric_limits<double>::quiet_NaN(), yMax = std::numeric_limits<double>::quiet_NaN();
};

/// The plot as an opaque image (white background).
Image drawPlot(const PlotSpec& spec);

/// "Nice" tick positions covering [lo, hi]: about `target` ticks at a step of 1, 2 or 5 × 10^k.
std::vector<double> niceTicks(double lo, double hi, int target = 6);

}  // namespace dgv::app
