// stats.csv (stats_csv.hpp).

#include "io/stats_csv.hpp"

#include "io/atomic_file.hpp"

#include <cstdio>

namespace dgv {

std::string statsCsvHeader() {
    return "frame,time,kinetic_energy,sum_dgamma2,max_cell_volume_error,total_volume_drift,inverted_cells,"
           "contacts,limited_points,step_ms,max_penetration,contact_precision,contact_recall,substeps,"
           "flipped_triangles,torn_edges,surface_stretch,reparametrisations,solve_iterations,solve_unconverged";
}

Real FrameStats::contactPrecision() const {
    return contactSetSize > 0 ? Real(contactTruePositive) / Real(contactSetSize) : Real(NAN);
}

Real FrameStats::contactRecall() const {
    return contactTruth > 0 ? Real(contactTruePositive) / Real(contactTruth) : Real(NAN);
}

std::string statsCsvRow(const FrameStats& s) {
    char buf[640];
    std::snprintf(buf, sizeof buf,
                  "%d,%.6f,%.9g,%.9g,%.3e,%.3e,%lld,%lld,%lld,%.3f,%.4g,%.4g,%.4g,%d,%lld,%lld,%.4g,%lld,%d,%lld", s.frame,
                  s.time, s.kineticEnergy, s.sumDeltaGamma2, s.maxCellVolumeError, s.totalVolumeDrift,
                  static_cast<long long>(s.invertedCells), static_cast<long long>(s.contacts),
                  static_cast<long long>(s.limitedPoints), s.stepMs, s.maxPenetration, s.contactPrecision(),
                  s.contactRecall(), s.substeps, static_cast<long long>(s.flippedTriangles),
                  static_cast<long long>(s.tornEdges), s.surfaceStretch, static_cast<long long>(s.reparametrisations),
                  s.solveIterations, static_cast<long long>(s.solveUnconverged));
    return buf;
}

void StatsCsv::write(const std::filesystem::path& dir) const {
    std::string text = statsCsvHeader() + "\n";
    for (const std::string& r : mRows) text += r + "\n";
    writeTextAtomically(dir / "stats.csv", text);
}

}  // namespace dgv
