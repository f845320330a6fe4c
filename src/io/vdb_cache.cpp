// Per-frame OpenVDB caches (vdb_cache.hpp, docs/vdb.md).
//
// The world grids are deform/resample's blocks (the numerics, with no OpenVDB in them) made
// into leaves; the lattice grids, the `surface` level set and the streamed writer are here.

#include "io/vdb_cache.hpp"

#include "base/errors.hpp"
#include "deform/resample.hpp"
#include "base/parallel.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/io/DelayedLoadMetadata.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/ValueTransformer.h>

#include <tbb/task_arena.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <set>
#include <numeric>
#include <optional>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>

#ifndef DGV_VERSION_STRING
#define DGV_VERSION_STRING "unknown"
#endif

namespace dgv {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string sanitise(const std::string& s) {
    std::string out;
    for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_') ? c : '_';
    return out.empty() ? std::string("object") : out;
}

void validate(const std::vector<VdbObjectFrame>& objects, const VdbFrameInfo& info, const VdbWriteSettings& settings) {
    auto bad = [](const std::string& where, const std::string& what) { throw InputError("", where, what); };
    if (objects.empty()) bad("vdb", "no object to write");
    for (std::size_t o = 0; o < objects.size(); ++o) {
        const VdbObjectFrame& f = objects[o];
        const std::string w = "vdb: object " + std::to_string(o) + " (" + f.name + ")";
        if (!f.lattice || !f.cells || !f.positions || !f.restVolumes)
            bad(w, "lattice, cells, positions and rest volumes are required");
        const std::size_t P = static_cast<std::size_t>(f.lattice->size());
        const std::size_t C = static_cast<std::size_t>(f.cells->size());
        if (!(f.lattice->spacing > 0) || !std::isfinite(f.lattice->spacing)) bad(w, "lattice spacing must be positive");
        if (f.positions->size() != P)
            bad(w, "positions: expected " + std::to_string(P) + " entries, got " + std::to_string(f.positions->size()));
        if (f.velocities && f.velocities->size() != P)
            bad(w,
                "velocities: expected " + std::to_string(P) + " entries, got " + std::to_string(f.velocities->size()));
        if (f.contact && f.contact->size() != P)
            bad(w, "contact: expected " + std::to_string(P) + " entries, got " + std::to_string(f.contact->size()));
        if (f.restVolumes->size() != C)
            bad(w, "rest volumes: expected " + std::to_string(C) + " entries, got " +
                       std::to_string(f.restVolumes->size()));
        for (Real v0 : *f.restVolumes)
            if (!(v0 > 0) || !std::isfinite(v0)) bad(w, "rest volumes must be positive");
        for (const Vec3& x : *f.positions)
            if (!allFiniteNoTrap(x)) bad(w, "positions must be finite");
        if (f.velocities)
            for (const Vec3& x : *f.velocities)
                if (!allFiniteNoTrap(x)) bad(w, "velocities must be finite");
    }
    if (!(settings.worldVoxelSize >= 0) || !std::isfinite(settings.worldVoxelSize))
        bad("vdb: voxel_size", "must be positive (or 0 for the lattice spacing)");
    if (!(settings.surfaceHalfWidth >= 1) || !std::isfinite(settings.surfaceHalfWidth))
        bad("vdb: surface half width", "must be at least 1 voxel");
    if (!std::isfinite(info.time) || !(info.fps > 0) || !std::isfinite(info.fps))
        bad("vdb", "time must be finite and fps positive");
}

openvdb::math::Transform::Ptr latticeTransform(Real h, const Vec3& origin) {
    auto t = openvdb::math::Transform::createLinearTransform(h);
    t->postTranslate(openvdb::Vec3d(origin.x(), origin.y(), origin.z()));
    return t;
}

/// The world grids: density, vel, rest, contact.
struct WorldGrids {
    openvdb::FloatGrid::Ptr density, contact;
    openvdb::Vec3SGrid::Ptr vel, rest;
    Index activeVoxels = 0;
    Real densitySum = 0;
    Index unresolved = 0;
    Index slowSolves = 0;  // voxels the batched Newton left to solveCell
    Index candidates = 0;  // (voxel, cell) pairs solved
};

WorldGrids resample(const std::vector<VdbObjectFrame>& objects, Real vs, const Vec3& origin,
                    const openvdb::math::Transform::Ptr& xform, VdbKernel kernel, VdbBinning binning,
                    VdbStageSeconds& stages) {
    // The numerics are deform/resample's; here each block becomes its leaves.
    std::vector<ResampleInput> bodies;
    for (const VdbObjectFrame& f : objects)
        bodies.push_back({f.lattice, f.cells, f.positions, f.velocities, f.contact});
    using FloatLeaf = openvdb::FloatTree::LeafNodeType;
    using VecLeaf = openvdb::Vec3STree::LeafNodeType;
    static_assert(FloatLeaf::DIM == kResampleBlockDim && VecLeaf::DIM == kResampleBlockDim, "a block is a leaf");
    constexpr int kLeafVoxels = kResampleBlockVoxels;
    struct BlockOut {
        std::unique_ptr<FloatLeaf> density, contact;  // null: an active tile of the value below
        std::unique_ptr<VecLeaf> vel, rest;           // null: no active voxel in the block
        float densityTile = 0, contactTile = 0;
        Index active = 0;
        Real densitySum = 0;
    };
    std::vector<BlockOut> out;
    const ResampleReport rr = resampleLattices(
        bodies, vs, origin, kernel, binning, [&](Index blocks) { out.resize(static_cast<std::size_t>(blocks)); },
        [&](Index b, const ResampledBlock& blk) {
            BlockOut& o = out[static_cast<std::size_t>(b)];
            // the leaves, written whole: active voxels their means, the others the background 0
            openvdb::util::NodeMask<3> mask;
            for (int at = 0; at < kLeafVoxels; ++at)
                if (blk.covered[static_cast<std::size_t>(at)]) mask.setOn(static_cast<openvdb::Index>(at));
            o.active = blk.active;
            o.densitySum = blk.densitySum;
            const openvdb::Coord origin3(blk.origin[0], blk.origin[1], blk.origin[2]);
            auto newLeaf = [&](auto* type) {  // values uninitialised: every one is written below
                using LeafT = std::remove_pointer_t<decltype(type)>;
                auto leaf =
                    std::make_unique<LeafT>(openvdb::PartialCreate(), origin3, typename LeafT::ValueType(0.f), false);
                leaf->setValueMask(mask);
                return leaf;
            };
            o.vel = newLeaf(static_cast<VecLeaf*>(nullptr));
            o.rest = newLeaf(static_cast<VecLeaf*>(nullptr));
            openvdb::Vec3s* const velOut = o.vel->buffer().data();  // allocates
            openvdb::Vec3s* const restOut = o.rest->buffer().data();
            for (std::size_t at = 0; at < std::size_t(kLeafVoxels); ++at) {
                velOut[at] = openvdb::Vec3s(blk.velocity[at][0], blk.velocity[at][1], blk.velocity[at][2]);
                restOut[at] = openvdb::Vec3s(blk.rest[at][0], blk.rest[at][1], blk.rest[at][2]);
            }
            // density and contact: a whole block of one value is an active tile (the inside of an
            // object: density 1, contact 0), as OpenVDB's prune would make it
            const bool full = o.active == kLeafVoxels;
            auto uniform = [&](const std::array<float, kLeafVoxels>& x) {
                return full && std::all_of(x.begin(), x.end(), [&](float y) { return y == x[0]; });
            };
            auto leafOf = [&](const std::array<float, kLeafVoxels>& x) {
                auto leaf = newLeaf(static_cast<FloatLeaf*>(nullptr));
                std::memcpy(leaf->buffer().data(), x.data(), sizeof(float) * kLeafVoxels);
                return leaf;
            };
            if (uniform(blk.density))
                o.densityTile = blk.density[0];
            else
                o.density = leafOf(blk.density);
            if (uniform(blk.contact))
                o.contactTile = blk.contact[0];
            else
                o.contact = leafOf(blk.contact);
        });
    stages.cells = rr.cellsSeconds;
    stages.bins = rr.binsSeconds;
    stages.voxels = rr.voxelsSeconds;
    const auto t = Clock::now();
    WorldGrids g;
    g.unresolved = rr.unresolved;
    g.slowSolves = rr.slowSolves;
    g.candidates = rr.candidates;
    g.density = openvdb::FloatGrid::create(0.f);
    g.contact = openvdb::FloatGrid::create(0.f);
    g.vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
    g.rest = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
    for (BlockOut& o : out) {  // in block order
        if (!o.vel) continue;
        g.activeVoxels += o.active;
        g.densitySum += o.densitySum;
        const openvdb::Coord at = o.vel->origin();
        if (o.density)
            g.density->tree().addLeaf(o.density.release());
        else
            g.density->tree().addTile(1, at, o.densityTile, true);
        if (o.contact)
            g.contact->tree().addLeaf(o.contact.release());
        else
            g.contact->tree().addTile(1, at, o.contactTile, true);
        g.vel->tree().addLeaf(o.vel.release());
        g.rest->tree().addLeaf(o.rest.release());
    }
    g.density->setTransform(xform);
    g.contact->setTransform(xform);
    g.vel->setTransform(xform);
    g.rest->setTransform(xform);
    stages.trees = since(t);
    return g;
}

template <typename GridT>
void stamp(GridT& grid, const std::string& name, openvdb::GridClass cls, const VdbFrameInfo& info) {
    grid.setName(name);
    grid.setGridClass(cls);
    grid.setCreator("dgv");
    grid.insertMeta("dgv_frame", openvdb::Int32Metadata(info.frame));
    grid.insertMeta("dgv_time", openvdb::DoubleMetadata(info.time));
}

/// A std::streambuf that appends to a std::string: the target of the per-thread leaf streams.
class StringSink : public std::streambuf {
public:
    explicit StringSink(std::string& out) : out_(out) {}

protected:
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        out_.append(s, static_cast<std::size_t>(n));
        return n;
    }
    int_type overflow(int_type c) override {
        if (!traits_type::eq_int_type(c, traits_type::eof())) out_.push_back(traits_type::to_char_type(c));
        return traits_type::not_eof(c);
    }

private:
    std::string& out_;
};

/// One grid's leaf buffers as LeafNode::writeBuffers writes them, and the per-leaf figures of
/// its DelayedLoadMetadata.
struct SerialisedLeaves {
    std::vector<std::string> runs;             // consecutive leaves, in the tree's order
    std::vector<std::int8_t> maskMeta;         // per leaf: the mask-compression byte
    std::vector<std::int64_t> compressedSize;  // per leaf: bytes of the values (their 8-byte count and
                                               // the compressed or raw values)
};

/// Bytes LeafNode::writeBuffers writes before the values: the value mask, the mask-compression
/// byte, the inactive values and the selection mask that byte announces (io/Compression.h).
constexpr std::size_t kLeafMaskBytes = openvdb::util::NodeMask<3>::WORD_COUNT * sizeof(openvdb::Index64);
template <typename ValueT>
std::size_t leafHeaderBytes(std::int8_t meta) {
    namespace io = openvdb::io;
    constexpr std::size_t mask = kLeafMaskBytes;
    std::size_t n = mask + 1;
    if (meta == io::NO_MASK_AND_ONE_INACTIVE_VAL || meta == io::MASK_AND_ONE_INACTIVE_VAL) n += sizeof(ValueT);
    if (meta == io::MASK_AND_TWO_INACTIVE_VALS) n += 2 * sizeof(ValueT);
    if (meta == io::MASK_AND_NO_INACTIVE_VALS || meta == io::MASK_AND_ONE_INACTIVE_VAL ||
        meta == io::MASK_AND_TWO_INACTIVE_VALS)
        n += mask;
    return n;
}

/// The leaves of `grids` (float and vec3s grids) serialised by OpenVDB's own
/// LeafNode::writeBuffers, 32 leaves a task, each task into a string of its own, so the bytes are
/// the library's; the compressed sizes for the DelayedLoadMetadata fall out of the same pass
/// (OpenVDB 10's Archive::writeGrid compresses every leaf twice: once to size it, once to write
/// it). Tasks are numbered grid by grid in file order; run(k) does task k.
class LeafSerialiser {
public:
    LeafSerialiser(const openvdb::GridCPtrVec& grids, std::uint32_t compression)
        : out_(grids.size()), writers_(grids.size()), tasksOf_(grids.size(), 0) {
        for (std::size_t g = 0; g < grids.size(); ++g) {
            auto setUp = [&](const auto& grid) {
                using GridT = std::decay_t<decltype(grid)>;
                using LeafT = typename GridT::TreeType::LeafNodeType;
                using ValueT = typename GridT::ValueType;
                std::vector<const LeafT*> leaves;
                leaves.reserve(grid.tree().leafCount());
                for (auto it = grid.tree().cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
                SerialisedLeaves& o = out_[g];
                o.maskMeta.resize(leaves.size());
                o.compressedSize.resize(leaves.size());
                for (std::size_t i = 0; i < leaves.size(); i += kRun)
                    tasks_.push_back({g, i, std::min(leaves.size(), i + kRun)});
                tasksOf_[g] = (leaves.size() + kRun - 1) / kRun;
                o.runs.resize(tasksOf_[g]);
                const bool toHalf = grid.saveFloatAsHalf();
                const ValueT* background = &grid.tree().background();
                writers_[g] = [&o, leaves = std::move(leaves), toHalf, background, compression](const Task& t,
                                                                                                std::string& bytes) {
                    StringSink sink(bytes);
                    std::ostream os(&sink);
                    openvdb::io::setDataCompression(os, compression);
                    openvdb::io::setGridBackgroundValuePtr(os, background);
                    for (std::size_t i = t.first; i < t.last; ++i) {
                        const LeafT& leaf = *leaves[i];
                        const std::size_t start = bytes.size();
                        leaf.writeBuffers(os, toHalf);
                        const std::int8_t meta =
                            static_cast<std::int8_t>(bytes[start + kLeafMaskBytes]);  // after the mask
                        o.maskMeta[i] = meta;
                        if (leaf.onVoxelCount() > 0) {
                            o.compressedSize[i] =
                                static_cast<std::int64_t>(bytes.size() - start - leafHeaderBytes<ValueT>(meta));
                        } else {  // no active value: the size function's own corner cases
                            o.compressedSize[i] = static_cast<std::int64_t>(openvdb::io::writeCompressedValuesSize(
                                                      leaf.buffer().data(), LeafT::SIZE, leaf.valueMask(),
                                                      std::uint8_t(meta), toHalf, compression)) +
                                                  8;
                        }
                    }
                    if (!os) throw RuntimeError("serialising a VDB leaf buffer failed");
                };
            };
            if (auto f = openvdb::GridBase::constGrid<openvdb::FloatGrid>(grids[g]))
                setUp(*f);
            else if (auto v = openvdb::GridBase::constGrid<openvdb::Vec3SGrid>(grids[g]))
                setUp(*v);
            else
                throw std::logic_error("vdb_cache: the parallel writer handles float and vec3s grids only");
        }
    }
    std::size_t tasks() const { return tasks_.size(); }
    std::size_t gridOf(std::size_t k) const { return tasks_[k].grid; }
    std::size_t tasksOf(std::size_t g) const { return tasksOf_[g]; }
    void run(std::size_t k) {
        const Task& t = tasks_[k];
        writers_[t.grid](t, out_[t.grid].runs[t.first / kRun]);
    }
    SerialisedLeaves& grid(std::size_t g) { return out_[g]; }

private:
    static constexpr std::size_t kRun = 32;  // leaves per task
    struct Task {
        std::size_t grid, first, last;
    };
    std::vector<SerialisedLeaves> out_;
    std::vector<Task> tasks_;
    std::vector<std::function<void(const Task&, std::string&)>> writers_;
    std::vector<std::size_t> tasksOf_;
};

/// write(2) of all n bytes; 0 or the errno value.
int writeAll(int fd, const char* p, std::size_t n) {
    while (n > 0) {
        const ssize_t k = ::write(fd, p, n);
        if (k < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        if (k == 0) return EIO;
        p += k;
        n -= static_cast<std::size_t>(k);
    }
    return 0;
}

/// Writes what openvdb::io::Archive::write(os, grids, seekable = true, meta) writes, byte for byte
/// (tested, the random file UUID aside), either by OpenVDB itself (`parallel` false) or streamed:
/// the leaves are serialised by TBB's threads (LeafSerialiser) in file order while a writer
/// thread writes each grid as soon as its leaves are done, and asks the kernel to start writing
/// back every 8 MiB (sync_file_range), so the compression, the copy into the page cache and the
/// device writes overlap and the fsync at the end has little left to wait for. Checks every
/// write, which io::File::write does not (on a full disk it returns normally and leaves a
/// truncated file), seals it (io/checksum.hpp: hashed as it streams out, or read back after
/// OpenVDB's own writer) and fsyncs it.
class CheckedArchive : public openvdb::io::Archive {
public:
    /// Writes `grids` and then the `laterCount` grids `later()` returns, which it builds while the
    /// first ones are written (the streamed writer; OpenVDB's builds them first).
    void writeFile(const fs::path& file, const openvdb::GridCPtrVec& grids, std::size_t laterCount,
                   const std::function<openvdb::GridCPtrVec()>& later, const openvdb::MetaMap& meta, bool parallel,
                   VdbStageSeconds& stages) const {
        const auto t = Clock::now();
        std::streamoff end = -1;
        if (parallel) {
            const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
            if (fd < 0) throw RuntimeError("cannot open " + file.string() + " for writing: " + std::strerror(errno));
            int err = 0;
            try {
                sum_ = Checksum64();
                sealAt_ = -1;
                end = writeStreamed(fd, grids, laterCount, later, meta);
                if (sealAt_ < 0) throw std::logic_error("vdb_cache: the file metadata holds no seal placeholder");
                const std::string digits = checksumDigits(sum_.finish());
                if (::pwrite(fd, digits.data(), digits.size(), static_cast<off_t>(sealAt_)) !=
                    static_cast<ssize_t>(digits.size()))
                    throw RuntimeError(std::string("the write failed (disk full?): ") + std::strerror(errno));
            } catch (...) {
                ::close(fd);
                throw;
            }
            if (::fsync(fd) != 0) err = errno;
            if (::close(fd) != 0 && err == 0) err = errno;
            if (err != 0) throw RuntimeError(std::string("the write failed (disk full?): ") + std::strerror(err));
        } else {
            std::ofstream os(file, std::ios_base::out | std::ios_base::binary | std::ios_base::trunc);
            if (!os) throw RuntimeError("cannot open " + file.string() + " for writing");
            openvdb::GridCPtrVec all = grids;
            for (const auto& g : later()) all.push_back(g);
            openvdb::io::Archive::write(os, all, /*seekable=*/true, meta);
            os.flush();
            const bool ok = os.good();
            end = ok ? std::streamoff(os.tellp()) : -1;
            os.close();
            if (!ok || os.fail()) throw RuntimeError("the write failed (disk full?)");
            sealFileChecksum(file);  // OpenVDB's own writer: read back and sealed in place
        }
        std::error_code ec;
        const std::uintmax_t size = fs::file_size(file, ec);
        if (ec || end < 0 || size != std::uintmax_t(end))
            throw RuntimeError("the written file has " + std::to_string(size) + " bytes, expected " +
                               std::to_string(end));
        stages.file = since(t);
    }

private:
    mutable Checksum64 sum_;           // the streamed file's checksum so far
    mutable std::int64_t sealAt_ = -1;  // where its seal's digits are, once written
    // Archive::write and Archive::writeGrid of OpenVDB 10, for grids with unique, non-empty names
    // and trees of their own (no instancing). OpenVDB's own functions write the headers,
    // metadata, transforms and topologies into memory (`hs`); the grid descriptor's stream
    // positions, which Archive::writeGrid patches by seeking back, are computed instead.
    // Returns the file's size.
    std::streamoff writeStreamed(int fd, const openvdb::GridCPtrVec& first, std::size_t laterCount,
                                 const std::function<openvdb::GridCPtrVec()>& later,
                                 const openvdb::MetaMap& meta) const {
        namespace io = openvdb::io;
        const std::uint32_t c = compression();
        if (c & io::COMPRESS_ZIP) throw std::logic_error("vdb_cache: the parallel writer does not do ZIP");
        std::set<std::string> names;
        std::set<const openvdb::TreeBase*> trees;
        auto check = [&](const openvdb::GridCPtrVec& gs) {
            for (const auto& g : gs)
                if (!g || g->getName().empty() || !names.insert(g->getName()).second ||
                    !trees.insert(&g->baseTree()).second)
                    throw std::logic_error(
                        "vdb_cache: the parallel writer needs distinct named grids with trees of their own");
        };
        check(first);
        const std::size_t total = first.size() + laterCount;
        std::optional<LeafSerialiser> firstLeaves(std::in_place, first, c), laterLeaves;

        // the writer thread's state, under `mutex`: it may write grid g once left[g] is 0; the
        // later grids and their leaves are filled in before their left[] counts are set
        std::mutex mutex;
        std::condition_variable ready;
        constexpr std::size_t kNotYet = std::numeric_limits<std::size_t>::max();
        std::vector<std::size_t> left(total, kNotYet);
        openvdb::GridCPtrVec grids(total);
        std::vector<SerialisedLeaves*> leavesOf(total, nullptr);
        for (std::size_t g = 0; g < first.size(); ++g) {
            grids[g] = first[g];
            left[g] = firstLeaves->tasksOf(g);
            leavesOf[g] = &firstLeaves->grid(g);
        }
        bool stop = false;                // serialising failed
        std::atomic<bool> failed{false};  // the writer failed: serialising may stop
        std::exception_ptr writerError;
        std::streamoff size = 0;

        auto writer = [&] {
            try {
                std::int64_t offset = 0, synced = 0;
                std::string bytes;
                StringSink sink(bytes);
                std::ostream hs(&sink);
                auto put = [&](const char* p, std::size_t n) {
                    // The seal (io/checksum.hpp) hashed as the bytes go out; its placeholder is
                    // in the file metadata, the first bytes written.
                    if (sealAt_ < 0)
                        if (const std::size_t d = findChecksumDigits(p, n); d != std::string::npos)
                            sealAt_ = offset + static_cast<std::int64_t>(d);
                    sum_.add(p, n);
                    if (int err = writeAll(fd, p, n))
                        throw RuntimeError(std::string("the write failed (disk full?): ") + std::strerror(err));
                    offset += static_cast<std::int64_t>(n);
                    constexpr std::int64_t kSyncChunk = std::int64_t(8) << 20;
                    if (offset - synced >= kSyncChunk) {  // a hint: errors come back from fsync
                        ::sync_file_range(fd, synced, offset - synced, SYNC_FILE_RANGE_WRITE);
                        synced = offset;
                    }
                };
                io::StreamMetadata::Ptr fileMeta(new io::StreamMetadata);
                io::setStreamMetadataPtr(hs, fileMeta, /*transfer=*/false);
                io::setDataCompression(hs, c);
                io::setWriteGridStatsMetadata(hs, isGridStatsMetadataEnabled());
                writeHeader(hs, /*seekable=*/true);
                meta.writeMeta(hs);
                const std::int32_t count = static_cast<std::int32_t>(total);
                hs.write(reinterpret_cast<const char*>(&count), sizeof count);
                for (std::size_t g = 0; g < total; ++g) {
                    {
                        std::unique_lock<std::mutex> lock(mutex);
                        ready.wait(lock, [&] { return left[g] == 0 || stop; });
                        if (stop) return;
                    }
                    const openvdb::GridBase::ConstPtr& grid = grids[g];
                    SerialisedLeaves& l = *leavesOf[g];
                    io::GridDescriptor gd(grid->getName(), grid->type(), grid->saveFloatAsHalf());
                    io::StreamMetadata::Ptr gridMeta(new io::StreamMetadata(*fileMeta));
                    gridMeta->setHalfFloat(grid->saveFloatAsHalf());
                    gridMeta->gridMetadata() = static_cast<const openvdb::MetaMap&>(*grid);
                    io::setStreamMetadataPtr(hs, gridMeta, /*transfer=*/false);

                    gd.writeHeader(hs);
                    const std::size_t posAt = bytes.size();  // the stream positions go here
                    gd.writeStreamPos(hs);
                    const std::size_t gridAt = bytes.size();
                    setGridCompression(hs, *grid);
                    io::DelayedLoadMetadata delayed;
                    if (!l.maskMeta.empty()) {
                        delayed.resizeMask(l.maskMeta.size());
                        delayed.resizeCompressedSize(l.maskMeta.size());
                        for (std::size_t i = 0; i < l.maskMeta.size(); ++i) {
                            delayed.setMask(i, l.maskMeta[i]);
                            delayed.setCompressedSize(i, l.compressedSize[i]);
                        }
                    }
                    const auto copy = openvdb::ConstPtrCast<openvdb::GridBase>(grid->copyGrid());  // shallow
                    copy->insertMeta(openvdb::GridBase::META_FILE_DELAYED_LOAD, delayed);
                    if (io::getWriteGridStatsMetadata(hs)) {
                        copy->addStatsMetadata();
                        copy->insertMeta(openvdb::GridBase::META_FILE_COMPRESSION,
                                         openvdb::StringMetadata(io::compressionToString(io::getDataCompression(hs))));
                    }
                    copy->writeMeta(hs);
                    grid->writeTransform(hs);
                    grid->writeTopology(hs);
                    if (!hs) throw RuntimeError("serialising a VDB grid header failed");
                    std::int64_t runBytes = 0;
                    for (const std::string& run : l.runs) runBytes += static_cast<std::int64_t>(run.size());
                    const std::int64_t gridPos = offset + static_cast<std::int64_t>(gridAt);
                    const std::int64_t blockPos = offset + static_cast<std::int64_t>(bytes.size());
                    gd.setGridPos(gridPos);
                    gd.setBlockPos(blockPos);
                    gd.setEndPos(blockPos + runBytes);
                    std::string pos;
                    {
                        StringSink posSink(pos);
                        std::ostream ps(&posSink);
                        gd.writeStreamPos(ps);
                    }
                    if (pos.size() != gridAt - posAt)
                        throw std::logic_error("vdb_cache: unexpected grid stream-position size");
                    bytes.replace(posAt, pos.size(), pos);
                    put(bytes.data(), bytes.size());
                    bytes.clear();
                    for (std::string& run : l.runs) {
                        put(run.data(), run.size());
                        std::string().swap(run);  // written: free it
                    }
                    io::setStreamMetadataPtr(hs, fileMeta, /*transfer=*/false);
                    io::setDataCompression(hs, c);
                }
                size = offset;
            } catch (...) {
                writerError = std::current_exception();
                failed = true;
            }
        };

        std::thread writerThread(writer);
        std::exception_ptr serialiseError;
        // every thread takes the next task in file order, so grids finish roughly in order
        auto serialise = [&](LeafSerialiser& leaves, std::size_t firstGrid) {
            std::atomic<std::size_t> next{0};
            const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
            tbb::parallel_for(
                tbb::blocked_range<int>(0, threads, 1),
                [&](const tbb::blocked_range<int>&) {
                    for (std::size_t k; !failed && (k = next++) < leaves.tasks();) {
                        leaves.run(k);
                        std::lock_guard<std::mutex> lock(mutex);
                        if (--left[firstGrid + leaves.gridOf(k)] == 0) ready.notify_one();
                    }
                },
                tbb::simple_partitioner());
        };
        try {
            serialise(*firstLeaves, 0);
            // the later grids, built while the writer writes the first ones
            const openvdb::GridCPtrVec more = failed ? openvdb::GridCPtrVec{} : later();
            if (!failed) {
                if (more.size() != laterCount)
                    throw std::logic_error("vdb_cache: the later grids are not as many as announced");
                check(more);
                laterLeaves.emplace(more, c);
                {
                    std::lock_guard<std::mutex> lock(mutex);
                    for (std::size_t i = 0; i < more.size(); ++i) {
                        grids[first.size() + i] = more[i];
                        leavesOf[first.size() + i] = &laterLeaves->grid(i);
                        left[first.size() + i] = laterLeaves->tasksOf(i);
                    }
                    ready.notify_one();  // a grid without leaves is ready at once
                }
                serialise(*laterLeaves, first.size());
            }
        } catch (...) {
            serialiseError = std::current_exception();
            std::lock_guard<std::mutex> lock(mutex);
            stop = true;
            ready.notify_one();
        }
        writerThread.join();
        if (serialiseError) std::rethrow_exception(serialiseError);
        if (writerError) std::rethrow_exception(writerError);
        return size;
    }
};

/// Re-opens a written file and reads every grid's metadata and the file metadata: catches the
/// truncated files io::File::write leaves on a full disk.
void verifyWritten(const fs::path& file, const std::vector<std::string>& names) {
    try {
        openvdb::io::File v(file.string());
        v.open(false);
        auto meta = v.getMetadata();
        auto grids = v.readAllGridMetadata();
        std::vector<std::string> got;
        for (const auto& g : *grids) got.push_back(g->getName());
        v.close();
        std::vector<std::string> want = names;
        std::sort(got.begin(), got.end());
        std::sort(want.begin(), want.end());
        if (got != want) throw RuntimeError("the written file lists other grids than were written");
        if (!meta || !(*meta)["dgv_frame"]) throw RuntimeError("the written file lost its metadata");
    } catch (const RuntimeError& e) {
        throw RuntimeError("the written file does not read back (disk full?): " + libraryMessage(e.what()));
    } catch (const std::exception& e) {
        throw RuntimeError("the written file does not read back (disk full?): " + libraryMessage(e.what()));
    }
}

/// The suffix of an object's lattice grids: none for one object, else _<name>.
std::string latticeSuffix(const std::vector<VdbObjectFrame>& objects, const VdbObjectFrame& f) {
    return objects.size() == 1 ? "" : "_" + sanitise(f.name);
}

/// `position` and `volume_ratio` of every object, on the material lattice.
struct LatticeGrids {
    openvdb::GridPtrVec grids;
    Real objectVolume = 0;  // sum of the deformed cell volumes
};

LatticeGrids latticeGrids(const std::vector<VdbObjectFrame>& objects, const VdbFrameInfo& info) {
    LatticeGrids out;
    for (const VdbObjectFrame& f : objects) {
        const std::string suffix = latticeSuffix(objects, f);
        const Lattice& lat = *f.lattice;
        auto lx = latticeTransform(lat.spacing, lat.originWorld);
        openvdb::Vec3SGrid::Ptr pos = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
        {
            auto acc = pos->getAccessor();
            for (Index p = 0; p < lat.size(); ++p) {
                const Vec3i& u = lat.coords[static_cast<std::size_t>(p)];
                const Vec3& x = (*f.positions)[static_cast<std::size_t>(p)];
                acc.setValue(openvdb::Coord(u.x(), u.y(), u.z()),
                             openvdb::Vec3s(float(x.x()), float(x.y()), float(x.z())));
            }
        }
        pos->setTransform(lx);
        stamp(*pos, "position" + suffix, openvdb::GRID_UNKNOWN, info);
        pos->setVectorType(openvdb::VEC_CONTRAVARIANT_ABSOLUTE);
        pos->insertMeta("dgv_object", openvdb::StringMetadata(f.name));

        const std::vector<Real> vols = cellVolumes(*f.cells, *f.positions);
        out.objectVolume += std::accumulate(vols.begin(), vols.end(), Real(0));
        openvdb::FloatGrid::Ptr ratio = openvdb::FloatGrid::create(0.f);
        {
            auto acc = ratio->getAccessor();
            for (Index c = 0; c < f.cells->size(); ++c) {
                const Vec3i& u = f.cells->lowest[static_cast<std::size_t>(c)];
                acc.setValue(openvdb::Coord(u.x(), u.y(), u.z()),
                             float(vols[static_cast<std::size_t>(c)] / (*f.restVolumes)[static_cast<std::size_t>(c)]));
            }
        }
        ratio->setTransform(lx->copy());
        stamp(*ratio, "volume_ratio" + suffix, openvdb::GRID_UNKNOWN, info);
        ratio->insertMeta("dgv_object", openvdb::StringMetadata(f.name));
        ratio->insertMeta("dgv_cell_at", openvdb::StringMetadata("lowest corner"));
        out.grids.push_back(pos);
        out.grids.push_back(ratio);
    }
    return out;
}

}  // namespace

fs::path vdbFramePath(const fs::path& dir, const std::string& scene, int frame) {
    char digits[32];
    std::snprintf(digits, sizeof digits, "%04d", frame);
    return dir / (scene + "." + digits + ".vdb");
}

VdbWriteReport writeVdbFrame(const fs::path& path, const std::vector<VdbObjectFrame>& objects, const VdbFrameInfo& info,
                             const VdbWriteSettings& settings) {
    const auto t0 = Clock::now();
    validate(objects, info, settings);
    openvdb::initialize();  // idempotent and thread-safe

    Real vs = settings.worldVoxelSize;
    if (vs == 0) {
        vs = objects[0].lattice->spacing;
        for (const VdbObjectFrame& f : objects) vs = std::min(vs, f.lattice->spacing);
    }
    // World grid extent check before allocating: the bounds of all positions in voxels.
    Box3 bounds;
    for (const VdbObjectFrame& f : objects)
        for (const Vec3& x : *f.positions) bounds.extend(x);
    const Vec3 origin = objects[0].lattice->originWorld;
    if (!bounds.empty()) {
        const Vec3 ext = bounds.size() / vs;
        if (ext.maxCoeff() > 16384 || (bounds.min - origin).cwiseAbs().maxCoeff() / vs > 1e6 ||
            (bounds.max - origin).cwiseAbs().maxCoeff() / vs > 1e6)
            throw InputError(
                "", "vdb: voxel_size",
                "the world grid would span more than 16384 voxels (voxel size " + std::to_string(vs) + ")");
    }

    VdbWriteReport report;
    openvdb::math::Transform::Ptr xform = latticeTransform(vs, origin);
    WorldGrids world = resample(objects, vs, origin, xform, settings.kernel, settings.binning, report.stages);
    report.activeVoxels = world.activeVoxels;
    report.densityVolume = world.densitySum * vs * vs * vs;
    report.unresolved = world.unresolved;
    report.slowSolves = world.slowSolves;
    report.candidates = world.candidates;

    openvdb::GridPtrVec grids;
    stamp(*world.density, "density", openvdb::GRID_FOG_VOLUME, info);
    stamp(*world.vel, "vel", openvdb::GRID_UNKNOWN, info);
    world.vel->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
    world.vel->insertMeta("dgv_velocity_unit", openvdb::StringMetadata("world units per second"));
    stamp(*world.rest, "rest", openvdb::GRID_UNKNOWN, info);
    world.rest->setVectorType(openvdb::VEC_INVARIANT);
    stamp(*world.contact, "contact", openvdb::GRID_FOG_VOLUME, info);
    if (settings.halfFloat) {
        world.density->setSaveFloatAsHalf(true);
        world.vel->setSaveFloatAsHalf(true);
        world.contact->setSaveFloatAsHalf(true);
    }
    grids.push_back(world.density);
    grids.push_back(world.vel);
    grids.push_back(world.rest);
    grids.push_back(world.contact);

    // ---- surface ---------------------------------------------------------------------------
    auto ts = Clock::now();
    if (settings.surface) {
        openvdb::FloatGrid::Ptr surface;
        for (const VdbObjectFrame& f : objects) {
            if (!f.surface || f.surface->triangles.empty()) continue;
            std::vector<openvdb::Vec3s> pts;
            pts.reserve(f.surface->vertices.size());
            for (const Vec3& x : f.surface->vertices) {
                if (!allFiniteNoTrap(x))
                    throw InputError("", "vdb: object " + f.name, "surface vertices must be finite");
                pts.emplace_back(float((x.x() - origin.x()) / vs), float((x.y() - origin.y()) / vs),
                                 float((x.z() - origin.z()) / vs));
            }
            std::vector<openvdb::Vec3I> tris;
            tris.reserve(f.surface->triangles.size());
            for (const auto& t : f.surface->triangles) {
                for (int q : t)
                    if (q < 0 || std::size_t(q) >= pts.size())
                        throw InputError("", "vdb: object " + f.name, "surface triangle index out of range");
                tris.emplace_back(openvdb::Index32(t[0]), openvdb::Index32(t[1]), openvdb::Index32(t[2]));
            }
            // points in index space; the transform is attached afterwards
            openvdb::math::Transform::Ptr unit = openvdb::math::Transform::createLinearTransform(1.0);
            openvdb::FloatGrid::Ptr ls =
                openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*unit, pts, tris, float(settings.surfaceHalfWidth));
            if (!surface) {
                surface = ls;
            } else {
                openvdb::tools::csgUnion(*surface, *ls);
            }
        }
        if (surface) {
            // meshToLevelSet in index space gives distances in voxels: scale to world units
            const float scale = float(vs);
            openvdb::tools::foreach (surface->beginValueAll(),
                                     [scale](const openvdb::FloatGrid::ValueAllIter& it) { it.setValue(*it * scale); });
            surface->tree().root().setBackground(float(settings.surfaceHalfWidth * vs), false);
            surface->setTransform(xform);
            stamp(*surface, "surface", openvdb::GRID_LEVEL_SET, info);
            grids.push_back(surface);
        }
    }

    report.stages.surface = since(ts);

    // ---- lattice grids: built while the world grids are written (CheckedArchive::writeFile) -----
    std::vector<std::string> names;
    for (const auto& g : grids) names.push_back(g->getName());
    for (const VdbObjectFrame& f : objects) {
        names.push_back("position" + latticeSuffix(objects, f));
        names.push_back("volume_ratio" + latticeSuffix(objects, f));
    }
    auto later = [&]() -> openvdb::GridCPtrVec {
        const auto tl = Clock::now();
        LatticeGrids lattice = latticeGrids(objects, info);
        report.objectVolume = lattice.objectVolume;
        report.stages.lattice = since(tl);
        return openvdb::GridCPtrVec(lattice.grids.begin(), lattice.grids.end());
    };
    report.resampleSeconds = since(t0);

    // ---- write, check, rename --------------------------------------------------------------
    openvdb::MetaMap meta;
    meta.insertMeta("creator", openvdb::StringMetadata(std::string("dgv ") + DGV_VERSION_STRING));
    meta.insertMeta("dgv_version", openvdb::StringMetadata(DGV_VERSION_STRING));
    meta.insertMeta("dgv_scene", openvdb::StringMetadata(info.scene));
    meta.insertMeta("dgv_key", openvdb::StringMetadata(info.key));
    meta.insertMeta("dgv_frame", openvdb::Int32Metadata(info.frame));
    meta.insertMeta("dgv_time", openvdb::DoubleMetadata(info.time));
    meta.insertMeta("dgv_fps", openvdb::DoubleMetadata(info.fps));
    meta.insertMeta("dgv_up_axis", openvdb::StringMetadata(info.upAxis));
    meta.insertMeta("dgv_units", openvdb::StringMetadata("m"));
    meta.insertMeta("dgv_checksum", openvdb::StringMetadata(checksumPlaceholder()));  // sealed below
    const auto t1 = Clock::now();
    writeFileAtomically(path, [&](const fs::path& tmp) {
        CheckedArchive archive;
        archive.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
        openvdb::GridCPtrVec constGrids(grids.begin(), grids.end());
        archive.writeFile(tmp, constGrids, 2 * objects.size(), later, meta, settings.writer == VdbWriter::Parallel,
                          report.stages);
        verifyWritten(tmp, names);
    });
    report.writeSeconds = since(t1);
    report.stages.verify = report.writeSeconds - report.stages.file;
    std::error_code ec;
    report.bytes = fs::file_size(path, ec);
    report.seconds = since(t0);
    return report;
}

}  // namespace dgv
