#include "app/plot.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <utility>

namespace dgv::app {
namespace {

// ---- a 5x7 bitmap font: 7 rows per glyph, bit 4 = leftmost column ------------------------------
struct Glyph {
    char c;
    std::array<std::uint8_t, 7> rows;
};
constexpr Glyph kFont[] = {
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}}, {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}}, {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}}, {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}}, {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}}, {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'A', {0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11}}, {'B', {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E}},
    {'C', {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}}, {'D', {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C}},
    {'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}}, {'F', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}},
    {'G', {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}}, {'H', {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {'I', {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}}, {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}},
    {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}}, {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F}},
    {'M', {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}}, {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
    {'O', {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}}, {'P', {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}},
    {'Q', {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}}, {'R', {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11}},
    {'S', {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}}, {'T', {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
    {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}}, {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}}, {'X', {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11}},
    {'Y', {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}}, {'Z', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}}, {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {'+', {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}}, {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
    {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}}, {',', {0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08}},
    {'=', {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00}}, {':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
    {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}}, {'_', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F}},
    {'<', {0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02}}, {'>', {0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08}},
    {'|', {0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}}, {'\'', {0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00}},
};
constexpr int kScale = 2;             // font pixels per glyph pixel
constexpr int kAdvance = 6 * kScale;  // glyph width + 1 column of spacing
constexpr int kTextHeight = 7 * kScale;

const Glyph* glyphFor(char c) {
    const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    for (const Glyph& g : kFont)
        if (g.c == u) return &g;
    return nullptr;  // space and anything unknown: blank
}

struct Canvas {
    Image& img;
    void put(int x, int y, const Vec3& srgb, double alpha = 1) {
        if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
        std::uint16_t* p = img.pixel(x, y);
        for (int c = 0; c < 3; ++c) {
            const double v = std::clamp(srgb[c], 0.0, 1.0) * 65535.0;
            p[c] = static_cast<std::uint16_t>(std::lround(alpha * v + (1 - alpha) * p[c]));
        }
        p[3] = 65535;
    }
    void rect(int x0, int y0, int x1, int y1, const Vec3& c) {
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) put(x, y, c);
    }
    /// A line of width ~2 px (Bresenham, stamped 2x2).
    void line(double xa, double ya, double xb, double yb, const Vec3& c, int width = 2) {
        int x0 = static_cast<int>(std::lround(xa)), y0 = static_cast<int>(std::lround(ya));
        const int x1 = static_cast<int>(std::lround(xb)), y1 = static_cast<int>(std::lround(yb));
        const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
        int err = dx + dy;
        const int lo = -(width - 1) / 2, hi = width / 2;
        for (int guard = 0; guard < 100000; ++guard) {
            for (int oy = lo; oy <= hi; ++oy)
                for (int ox = lo; ox <= hi; ++ox) put(x0 + ox, y0 + oy, c);
            if (x0 == x1 && y0 == y1) break;
            const int e2 = 2 * err;
            if (e2 >= dy) err += dy, x0 += sx;
            if (e2 <= dx) err += dx, y0 += sy;
        }
    }
    /// Text with its top-left corner at (x, y); `vertical`: rotated 90° counter-clockwise, the
    /// baseline running upwards from (x, y) = bottom-left.
    void text(int x, int y, const std::string& s, const Vec3& c, bool vertical = false) {
        for (std::size_t i = 0; i < s.size(); ++i) {
            const Glyph* g = glyphFor(s[i]);
            if (!g) continue;
            for (int r = 0; r < 7; ++r)
                for (int col = 0; col < 5; ++col) {
                    if (!((g->rows[static_cast<std::size_t>(r)] >> (4 - col)) & 1)) continue;
                    for (int a = 0; a < kScale; ++a)
                        for (int b = 0; b < kScale; ++b) {
                            const int gx = static_cast<int>(i) * kAdvance + col * kScale + a, gy = r * kScale + b;
                            if (vertical)
                                put(x + gy, y - gx, c);
                            else
                                put(x + gx, y + gy, c);
                        }
                }
        }
    }
};

int textWidth(const std::string& s) { return static_cast<int>(s.size()) * kAdvance - kScale; }

std::string tickLabel(double v, double step) {
    if (std::abs(v) < step * 1e-9) v = 0;
    char buf[32];
    const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
    std::snprintf(buf, sizeof buf, "%.*f", std::min(decimals, 6), v);
    return buf;
}

}  // namespace

std::vector<double> niceTicks(double lo, double hi, int target) {
    if (!(hi > lo)) {
        const double pad = std::abs(lo) > 0 ? 0.5 * std::abs(lo) : 1;
        lo -= pad;
        hi += pad;
    }
    const double raw = (hi - lo) / std::max(1, target);
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    double step = mag;
    for (const double m : {1.0, 2.0, 5.0, 10.0})
        if (m * mag >= raw) {
            step = m * mag;
            break;
        }
    std::vector<double> t;
    for (double v = std::floor(lo / step) * step; v <= hi + step * 1e-9; v += step) t.push_back(v);
    if (t.back() < hi - step * 1e-9) t.push_back(t.back() + step);
    return t;
}

Image drawPlot(const PlotSpec& spec) {
    Image img(spec.width, spec.height);
    for (std::size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = 65535;
    Canvas cv{img};
    const Vec3 black(0, 0, 0), grid(0.87, 0.87, 0.87), grey(0.35, 0.35, 0.35);

    // Data range.
    double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
    for (const PlotSeries& s : spec.series)
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
            if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
            xlo = std::min(xlo, s.x[i]), xhi = std::max(xhi, s.x[i]);
            ylo = std::min(ylo, s.y[i]), yhi = std::max(yhi, s.y[i]);
        }
    if (!std::isfinite(xlo)) xlo = 0, xhi = 1, ylo = 0, yhi = 1;
    if (std::isfinite(spec.yMin)) ylo = spec.yMin;
    if (std::isfinite(spec.yMax)) yhi = spec.yMax;
    const std::vector<double> xt = niceTicks(xlo, xhi, 8), yt = niceTicks(ylo, yhi, 6);
    const double x0 = xt.front(), x1 = xt.back(), y0 = yt.front(), y1 = yt.back();
    const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1, ystep = yt.size() > 1 ? yt[1] - yt[0] : 1;

    // Plot area.
    int maxYLabel = 0;
    for (double v : yt) maxYLabel = std::max(maxYLabel, textWidth(tickLabel(v, ystep)));
    const int left = 40 + maxYLabel + 16, right = spec.width - 24, top = 56, bottom = spec.height - 70;
    auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * (right - left); };
    auto py = [&](double y) { return bottom - (y - y0) / (y1 - y0) * (bottom - top); };

    for (double v : xt) {
        const int x = static_cast<int>(std::lround(px(v)));
        cv.line(x, top, x, bottom, grid, 1);
        cv.line(x, bottom, x, bottom + 6, black, 2);
        const std::string l = tickLabel(v, xstep);
        cv.text(x - textWidth(l) / 2, bottom + 12, l, black);
    }
    for (double v : yt) {
        const int y = static_cast<int>(std::lround(py(v)));
        cv.line(left, y, right, y, grid, 1);
        cv.line(left - 6, y, left, y, black, 2);
        const std::string l = tickLabel(v, ystep);
        cv.text(left - 12 - textWidth(l), y - kTextHeight / 2, l, black);
    }
    cv.line(left, top, left, bottom, black, 2);
    cv.line(left, bottom, right, bottom, black, 2);
    cv.line(left, top, right, top, grey, 1);
    cv.line(right, top, right, bottom, grey, 1);

    // Data, clipped to the plot area by construction of the ticks (they cover the range).
    for (const PlotSeries& s : spec.series) {
        bool have = false;
        double lx = 0, ly = 0;
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
            if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
                have = false;
                continue;
            }
            const double X = px(s.x[i]), Y = py(std::clamp(s.y[i], y0, y1));
            if (s.lines && have) cv.line(lx, ly, X, Y, s.color, s.width);
            const int mk = std::max(2, s.width / 2 + 1);
            if (s.markers)
                cv.rect(static_cast<int>(std::lround(X)) - mk, static_cast<int>(std::lround(Y)) - mk,
                        static_cast<int>(std::lround(X)) + mk, static_cast<int>(std::lround(Y)) + mk, s.color);
            lx = X, ly = Y, have = true;
        }
    }

    // Labels, title, legend (top right, inside the plot area, on a white box).
    cv.text(left + (right - left - textWidth(spec.xLabel)) / 2, spec.height - 28, spec.xLabel, black);
    cv.text(14, top + (bottom - top + textWidth(spec.yLabel)) / 2, spec.yLabel, black, true);
    cv.text(left + (right - left - textWidth(spec.title)) / 2, 18, spec.title, black);
    int legendWidth = 0;
    for (const PlotSeries& s : spec.series) legendWidth = std::max(legendWidth, textWidth(s.label));
    if (!spec.series.empty() && legendWidth > 0) {
        const int lw = legendWidth + 52, lh = static_cast<int>(spec.series.size()) * 22 + 10;
        // The corner of the plot area that hides the fewest data points.
        int lx0 = right - lw - 10, ly0 = top + 10;
        std::size_t fewest = std::numeric_limits<std::size_t>::max();
        for (const auto& [cx, cy] : {std::pair<int, int>{right - lw - 10, top + 10},
                                     {left + 10, top + 10},
                                     {right - lw - 10, bottom - lh - 10},
                                     {left + 10, bottom - lh - 10}}) {
            std::size_t hidden = 0;
            for (const PlotSeries& s : spec.series)
                for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
                    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
                    const double X = px(s.x[i]), Y = py(std::clamp(s.y[i], y0, y1));
                    if (X >= cx - 4 && X <= cx + lw + 4 && Y >= cy - 4 && Y <= cy + lh + 4) ++hidden;
                }
            if (hidden < fewest) fewest = hidden, lx0 = cx, ly0 = cy;
        }
        cv.rect(lx0, ly0, lx0 + lw, ly0 + lh, Vec3(1, 1, 1));
        cv.line(lx0, ly0, lx0 + lw, ly0, grey, 1);
        cv.line(lx0, ly0 + lh, lx0 + lw, ly0 + lh, grey, 1);
        cv.line(lx0, ly0, lx0, ly0 + lh, grey, 1);
        cv.line(lx0 + lw, ly0, lx0 + lw, ly0 + lh, grey, 1);
        for (std::size_t i = 0; i < spec.series.size(); ++i) {
            const PlotSeries& s = spec.series[i];
            const int y = ly0 + 8 + static_cast<int>(i) * 22;
            if (s.lines) cv.line(lx0 + 8, y + kTextHeight / 2, lx0 + 36, y + kTextHeight / 2, s.color, 3);
            if (s.markers) cv.rect(lx0 + 19, y + kTextHeight / 2 - 3, lx0 + 25, y + kTextHeight / 2 + 3, s.color);
            cv.text(lx0 + 44, y, s.label, black);
        }
    }
    return img;
}

}  // namespace dgv::app
