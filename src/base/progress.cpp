#include "base/progress.hpp"

#include <unistd.h>

#include <cmath>
#include <csignal>

namespace dgv {
namespace {
bool gQuiet = false;
int gMode = 0;
volatile std::sig_atomic_t gCancel = 0;
}  // namespace

void Progress::setQuiet(bool quiet) { gQuiet = quiet; }
void Progress::setMode(int mode) { gMode = mode; }

Progress::Progress(std::string label, long total, std::string unit)
    : mLabel(std::move(label)), mUnit(std::move(unit)), mTotal(total > 0 ? total : 1) {
    mBar = gMode == 1 || (gMode == 0 && isatty(STDERR_FILENO));
    mStart = mLastDraw = std::chrono::steady_clock::now();
    if (!gQuiet && mBar) draw(false);
}

Progress::~Progress() { finish(); }

std::string formatDuration(double seconds) {
    if (!std::isfinite(seconds) || seconds < 0) return "?";
    long s = std::lround(seconds);
    char buf[32];
    if (s >= 3600)
        std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    else
        std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
    return buf;
}

void Progress::step(const std::string& detail) {
    ++mDone;
    if (gQuiet) return;
    if (mBar) {
        auto now = std::chrono::steady_clock::now();
        if (mDone >= mTotal || now - mLastDraw > std::chrono::milliseconds(100)) {
            mLastDraw = now;
            draw(false);
        }
        return;
    }
    double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStart).count();
    double rate = elapsed > 0 ? mDone / elapsed : 0.0;
    double eta = rate > 0 ? (mTotal - mDone) / rate : 0.0;
    std::fprintf(stderr, "dgv: %s %ld/%ld %s (%.2f/s, ETA %s)%s%s\n", mLabel.c_str(), mDone, mTotal, mUnit.c_str(),
                 rate, formatDuration(eta).c_str(), detail.empty() ? "" : " ", detail.c_str());
    std::fflush(stderr);
}

void Progress::draw(bool final) {
    const int width = 30;
    double frac = double(mDone) / double(mTotal);
    int filled = static_cast<int>(frac * width);
    std::string bar(static_cast<std::size_t>(width), ' ');
    for (int i = 0; i < filled && i < width; ++i) bar[static_cast<std::size_t>(i)] = '=';
    if (filled < width && !final) bar[static_cast<std::size_t>(filled)] = '>';
    double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStart).count();
    double rate = elapsed > 0 ? mDone / elapsed : 0.0;
    std::string eta = final ? formatDuration(elapsed) : (rate > 0 ? formatDuration((mTotal - mDone) / rate) : "?");
    std::fprintf(stderr, "\r%s [%s] %ld/%ld %s %.2f/s %s %s\x1b[K", mLabel.c_str(), bar.c_str(), mDone, mTotal,
                 mUnit.c_str(), rate, final ? "in" : "ETA", eta.c_str());
    std::fflush(stderr);
}

void Progress::finish() {
    if (mFinished) return;
    mFinished = true;
    if (gQuiet || !mBar) return;
    draw(true);
    std::fputc('\n', stderr);
    std::fflush(stderr);
}

void logInfo(const std::string& line) {
    if (gQuiet) return;
    std::fprintf(stderr, "dgv: %s\n", line.c_str());
    std::fflush(stderr);
}

void logWarning(const std::string& line) {
    std::fprintf(stderr, "dgv: warning: %s\n", line.c_str());
    std::fflush(stderr);
}

void requestCancel() noexcept { gCancel = 1; }
bool cancelRequested() noexcept { return gCancel != 0; }
void resetCancel() noexcept { gCancel = 0; }

}  // namespace dgv
