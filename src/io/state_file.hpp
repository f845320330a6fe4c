#pragma once
/// @file state_file.hpp
/// @brief State checkpoints on disk (docs/robustness.md, "State checkpoints"): after each frame
/// of a moving scene, out/<scene>/state/<scene>.####.dgvstate holds everything the simulation
/// needs to continue bit-identically from that frame (dynamics/body_state.hpp), the stats.csv
/// rows of the frames so far, and the renderer's per-point contact history.
///
/// Format (version 10; all integers and reals in the machine's byte order, which the header
/// records, reals as IEEE doubles):
///   "DGVSTATE" | u32 format version | u32 0x01020304 (byte order) | u32 sizeof(Real)
///   | str dgv version | u64 scene key | i32 frame | u64 payload bytes | u64 payload checksum
///   (stateChecksum) | payload
/// payload: u32 rows, str each | u32 objects, per object: u8 present, and when present u64 #P
///   and the arrays of DeformableBodyState in declaration order (vectors: u64 count + elements;
///   bools as u8) | u32 contact histories, each u64 count + i32 elements.
/// str = u32 length + bytes. A file is used only when every check passes: magic, version, byte
/// order, size (a truncated file is detected), checksum, and (by the caller) the scene key,
/// dgv version and array sizes.

#include "base/types.hpp"
#include "geom/lattice.hpp"
#include "sim/scene.hpp"
#include "sim/simulation.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace dgv {

inline constexpr std::uint32_t kStateFormatVersion =
    10;  ///< 2: the displacement of the step before; 3: plasticity's rest shape; 4: the last step's length; 5: the load
         ///< modes' amplitudes; 6: the volume multipliers' prediction; 7: the time in free flight; 8: a re-parametrised
         ///< body's lattice and surface; 9: the payload's checksum over 64-bit words (stateChecksum); 10: the one-solve
         ///< step's rest stretches and the step before's positions and velocities (StepSolver::One)

/// The payload's checksum (io/checksum.hpp, checksum64).
std::uint64_t stateChecksum(const char* data, std::size_t n);

struct StateCheckpoint {
    std::string dgvVersion;                        ///< DGV_VERSION_STRING of the writer
    std::uint64_t sceneKey = 0;                    ///< sceneDynamicsKey of the scene it belongs to
    int frame = 0;                                 ///< the simulation's frame
    std::vector<std::string> statsRows;            ///< stats.csv rows of frames.start .. frame (no header)
    std::vector<Simulation::ObjectState> objects;  ///< per scene object
    std::vector<std::vector<int>> contactAges;     ///< per scene object (ContactHistory::age)
};

/// out/<scene>/state/<name>.####.dgvstate
std::filesystem::path stateFilePath(const std::filesystem::path& outDir, const std::string& name, int frame);

/// The checkpoint's bytes (the format above).
std::string serializeState(const StateCheckpoint& checkpoint);

/// Writes serializeState(checkpoint) atomically (temporary + rename; RuntimeError naming the file).
void writeStateFile(const std::filesystem::path& path, const StateCheckpoint& checkpoint);

/// Parses a checkpoint's bytes: an empty string and `out` filled when they are a complete
/// checkpoint of this format (then serializeState(out) gives these bytes back), otherwise the
/// reason (as readStateFile). Never throws for bad bytes; allocates no more than their size.
std::string parseState(const std::string& bytes, StateCheckpoint& out);

/// Reads and checks a checkpoint. Returns an empty string and fills `out` when the file is a
/// complete checkpoint of this format; otherwise the reason in a few words ("no such file",
/// "truncated: 812 of 40960 bytes", "checksum mismatch", "format version 2, this dgv reads 1",
/// ...), and `out` is unspecified. Never throws for a bad file.
std::string readStateFile(const std::filesystem::path& path, StateCheckpoint& out);

/// What a checkpoint must match: a 64-bit hash of the scene file's JSON without the keys that
/// cannot change the dynamics (name, frames.end, camera, render, output, objects[].color; key
/// order and white space do not matter), of the bytes of collider mesh files, and of every
/// lattice (origin, spacing, dims, point coordinates; nullptr for objects that do not move).
/// Throws InputError when the scene file cannot be read.
std::uint64_t sceneDynamicsKey(const SceneDesc& scene, const std::vector<const Lattice*>& lattices);

/// What every rendered frame of `scene` is a function of: the scene file's content (canonical
/// JSON, without frames.end and output.dir, which change no frame), the bytes of every mesh and
/// level-set file it reads, and this dgv's version. Written into each PNG frame (tEXt dgv:key)
/// and checked by --resume, which keeps a frame only when it carries the current key: frames of
/// an earlier version of the scene, or of another bit depth, are rendered again. The text of the
/// key is 16 hex digits. Throws InputError when the scene file cannot be read.
std::string sceneFrameKey(const SceneDesc& scene);

}  // namespace dgv
