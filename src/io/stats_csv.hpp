#pragma once
/// @file stats_csv.hpp
/// @brief stats.csv: one row of figures per simulated frame (sim/simulation.hpp's FrameStats),
/// under a header naming the columns (scenes/README.md lists them). The whole file is written
/// again, atomically, after each frame, so a reader never sees a torn one; a state checkpoint
/// carries the rows up to its frame, so a resumed run's file is the uninterrupted run's.

#include "sim/simulation.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

/// stats.csv's header line (no newline).
std::string statsCsvHeader();
/// One frame's row (no newline).
std::string statsCsvRow(const FrameStats& s);

/// The rows of a run's stats.csv, kept in memory and written whole.
class StatsCsv {
public:
    /// Appends frame s's row.
    void add(const FrameStats& s) { mRows.push_back(statsCsvRow(s)); }
    /// The frames' rows (no header), as a state checkpoint keeps them.
    const std::vector<std::string>& rows() const { return mRows; }
    /// Replaces the rows with a checkpoint's.
    void restore(std::vector<std::string> rows) { mRows = std::move(rows); }
    /// Writes <dir>/stats.csv: the header and every row (atomic).
    void write(const std::filesystem::path& dir) const;

private:
    std::vector<std::string> mRows;
};

}  // namespace dgv
