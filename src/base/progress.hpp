#pragma once
/// @file progress.hpp
/// @brief Progress of long work on stderr, and cooperative cancellation.
///
/// On a terminal: one self-rewriting bar line ("render [=====>   ] 12/48 frames 3.1/s ETA 0:11").
/// Otherwise (a log file, a render farm): one plain line per step. Quiet mode prints nothing.
/// Cancellation: app/ installs SIGINT/SIGTERM handlers that call requestCancel(); long loops
/// call cancelRequested() between units of work and stop cleanly.

#include <chrono>
#include <cstdio>
#include <string>

namespace dgv {

class Progress {
public:
    /// @param label  what is being done ("render")
    /// @param total  number of units (> 0)
    /// @param unit   plural noun of a unit ("frames")
    Progress(std::string label, long total, std::string unit);
    ~Progress();

    /// One more unit finished; `detail` is appended to plain log lines (e.g. the file written).
    void step(const std::string& detail = "");
    /// Ends the bar line (called by the destructor too).
    void finish();

    /// Global switches, set once by app/: quiet suppresses output; forceMode overrides the
    /// terminal detection (0 auto, 1 bar, 2 plain lines).
    static void setQuiet(bool quiet);
    static void setMode(int mode);

private:
    void draw(bool final);

    std::string mLabel, mUnit;
    long mTotal = 1;
    long mDone = 0;
    bool mBar = false;
    bool mFinished = false;
    std::chrono::steady_clock::time_point mStart;
    std::chrono::steady_clock::time_point mLastDraw;
};

/// One informational line on stderr ("dgv: ..."), unless quiet.
void logInfo(const std::string& line);
/// One warning line on stderr ("dgv: warning: ..."), printed even when quiet.
void logWarning(const std::string& line);

/// Formats seconds as M:SS or H:MM:SS.
std::string formatDuration(double seconds);

/// Cooperative cancellation (async-signal-safe to request).
void requestCancel() noexcept;
bool cancelRequested() noexcept;
void resetCancel() noexcept;

}  // namespace dgv
