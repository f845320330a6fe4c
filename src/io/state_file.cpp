// State checkpoints on disk (state_file.hpp).

#include "io/state_file.hpp"

#include "base/check.hpp"
#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"
#include "io/mesh_import.hpp"
#include "io/stats_csv.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <type_traits>

namespace dgv {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'D', 'G', 'V', 'S', 'T', 'A', 'T', 'E'};
constexpr std::uint32_t kByteOrder = 0x01020304u;

/// FNV-1a, 64 bit.
struct Fnv {
    std::uint64_t h = 1469598103934665603ull;
    void add(const void* data, std::size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < n; ++i) {
            h ^= p[i];
            h *= 1099511628211ull;
        }
    }
    template <typename T>
    void value(const T& v) {
        add(&v, sizeof v);
    }
    void text(const std::string& s) {
        value(static_cast<std::uint64_t>(s.size()));
        add(s.data(), s.size());
    }
};

/// Counts the bytes a Writer would append (the payload's size, known before it is written).
class Counter {
public:
    std::size_t bytes = 0;
    template <typename T>
    void value(const T&) {
        bytes += sizeof(T);
    }
    void text(const std::string& s) { bytes += sizeof(std::uint32_t) + s.size(); }
    template <typename T>
    void array(const std::vector<T>& v) {
        bytes += sizeof(std::uint64_t) + v.size() * sizeof(T);
    }
};

class Writer {
public:
    std::string bytes;
    template <typename T>
    void value(const T& v) {
        bytes.append(reinterpret_cast<const char*>(static_cast<const void*>(&v)), sizeof v);
    }
    void text(const std::string& s) {
        value(static_cast<std::uint32_t>(s.size()));
        bytes += s;
    }
    template <typename T>
    void array(const std::vector<T>& v) {
        value(static_cast<std::uint64_t>(v.size()));
        if (!v.empty())
            bytes.append(reinterpret_cast<const char*>(static_cast<const void*>(v.data())), v.size() * sizeof(T));
    }
};

/// Bounds-checked reading; `ok` turns false on the first read past the end.
class Reader {
public:
    Reader(const char* data, std::size_t size) : mData(data), mSize(size) {}
    bool ok = true;
    template <typename T>
    T value() {
        T v{};
        if (!ok || mSize - mPos < sizeof v) {
            ok = false;
            return v;
        }
        std::memcpy(static_cast<void*>(&v), mData + mPos, sizeof v);
        mPos += sizeof v;
        return v;
    }
    std::string text() {
        const auto n = value<std::uint32_t>();
        if (!ok || mSize - mPos < n) {
            ok = false;
            return {};
        }
        std::string s(mData + mPos, n);
        mPos += n;
        return s;
    }
    template <typename T>
    void array(std::vector<T>& v) {
        const auto n = value<std::uint64_t>();
        if (!ok || n > (mSize - mPos) / sizeof(T)) {
            ok = false;
            return;
        }
        v.resize(static_cast<std::size_t>(n));
        if (n > 0) std::memcpy(static_cast<void*>(v.data()), mData + mPos, static_cast<std::size_t>(n) * sizeof(T));
        mPos += static_cast<std::size_t>(n) * sizeof(T);
    }
    std::size_t position() const { return mPos; }
    bool atEnd() const { return mPos == mSize; }

private:
    const char* mData;
    std::size_t mSize;
    std::size_t mPos = 0;
};

// Eigen's fixed-size types are plain arrays of their scalars (copied with memcpy here).
static_assert(sizeof(Vec3) == 3 * sizeof(Real) && sizeof(Mat3) == 9 * sizeof(Real) && sizeof(Vec3i) == 3 * sizeof(int));

template <class W>
void writeBody(W& w, const DeformableBodyState& s) {
    w.value(static_cast<std::uint64_t>(s.positions.size()));
    w.array(s.positions);
    w.array(s.velocities);
    for (const auto& t : s.tangentPrev) w.array(t);
    w.value(static_cast<std::uint8_t>(s.havePrev));
    for (const auto& g : s.deltaGamma) w.array(g);
    w.array(s.contact);
    w.array(s.contactDepth);
    w.value(s.centre);
    w.value(s.centreVelocity);
    w.value(s.flex);
    w.value(s.flexVelocity);
    w.value(static_cast<std::uint8_t>(s.halfStep));
    w.value(s.plasticFlex);
    for (const auto& g : s.plasticGamma) w.array(g);
    w.value(s.lastStep);
    w.value(s.freeFlight);
    w.value(s.loadAmplitude);
    w.value(s.loadRate);
    w.array(s.displacement);
    w.array(s.displacementPrev);
    w.array(s.volumeLambda);
    w.array(s.volumeLambdaPrev);
    w.array(s.volumeCachePositions);
    w.array(s.volumeCachePinned);
    w.array(s.positionsBefore);
    w.array(s.velocitiesBefore);
    w.array(s.cellRest);
}

/// A bool stored as one byte: 0 or 1, anything else is malformed.
bool readBool(Reader& r) {
    const auto b = r.value<std::uint8_t>();
    if (b > 1) r.ok = false;
    return b == 1;
}

void readBody(Reader& r, DeformableBodyState& s) {
    const auto points = r.value<std::uint64_t>();  // #P (the arrays carry their own counts too)
    r.array(s.positions);
    if (points != s.positions.size()) r.ok = false;
    r.array(s.velocities);
    for (auto& t : s.tangentPrev) r.array(t);
    s.havePrev = readBool(r);
    for (auto& g : s.deltaGamma) r.array(g);
    r.array(s.contact);
    r.array(s.contactDepth);
    s.centre = r.value<Vec3>();
    s.centreVelocity = r.value<Vec3>();
    s.flex = r.value<Mat3>();
    s.flexVelocity = r.value<Mat3>();
    s.halfStep = readBool(r);
    s.plasticFlex = r.value<Mat3>();
    for (auto& g : s.plasticGamma) r.array(g);
    s.lastStep = r.value<Real>();
    if (!(s.lastStep >= 0) || !std::isfinite(s.lastStep)) r.ok = false;
    s.freeFlight = r.value<Real>();
    if (!(s.freeFlight >= 0) || !std::isfinite(s.freeFlight)) r.ok = false;
    s.loadAmplitude = r.value<Vec3>();
    s.loadRate = r.value<Vec3>();
    if (!s.loadAmplitude.allFinite() || !s.loadRate.allFinite()) r.ok = false;
    r.array(s.displacement);
    r.array(s.displacementPrev);
    r.array(s.volumeLambda);
    r.array(s.volumeLambdaPrev);
    r.array(s.volumeCachePositions);
    r.array(s.volumeCachePinned);
    r.array(s.positionsBefore);
    r.array(s.velocitiesBefore);
    r.array(s.cellRest);
}

std::size_t headerSize(const std::string& version) {
    return sizeof kMagic + 3 * sizeof(std::uint32_t) + sizeof(std::uint32_t) + version.size() + sizeof(std::uint64_t) +
           sizeof(std::int32_t) + 2 * sizeof(std::uint64_t);
}

}  // namespace

fs::path stateFilePath(const fs::path& outDir, const std::string& name, int frame) {
    char num[32];
    std::snprintf(num, sizeof num, "%04d", frame);
    return outDir / "state" / (name + "." + num + ".dgvstate");
}

namespace {

/// The payload in the format's order, to a Writer or a Counter.
template <class W>
void writePayload(W& w, const StateCheckpoint& c) {
    w.value(static_cast<std::uint32_t>(c.statsRows.size()));
    for (const std::string& row : c.statsRows) w.text(row);
    w.value(static_cast<std::uint32_t>(c.objects.size()));
    for (const Simulation::ObjectState& o : c.objects) {
        w.value(static_cast<std::uint8_t>(o.present));
        if (!o.present) continue;
        writeBody(w, o.body);
        w.value(static_cast<std::int32_t>(o.remaps));
        if (o.remaps > 0) {
            w.value(o.latticeOrigin);
            w.value(o.latticeSpacing);
            w.value(o.latticeDims);
            w.array(o.latticeCoords);
            w.array(o.surfaceVertices);
            w.array(o.surfaceTriangles);
        }
    }
    w.value(static_cast<std::uint32_t>(c.contactAges.size()));
    for (const std::vector<int>& a : c.contactAges) w.array(a);
}

}  // namespace

std::uint64_t stateChecksum(const char* data, std::size_t n) { return checksum64(data, n); }

std::string serializeState(const StateCheckpoint& c) {
    // One buffer of the file's exact size: the header, the payload written after it, then the
    // payload's checksum patched into the header (no second copy of a payload of megabytes).
    Counter count;
    writePayload(count, c);
    Writer file;
    file.bytes.reserve(headerSize(c.dgvVersion) + count.bytes);
    file.bytes.append(kMagic, sizeof kMagic);
    file.value(kStateFormatVersion);
    file.value(kByteOrder);
    file.value(static_cast<std::uint32_t>(sizeof(Real)));
    file.text(c.dgvVersion);
    file.value(c.sceneKey);
    file.value(static_cast<std::int32_t>(c.frame));
    file.value(static_cast<std::uint64_t>(count.bytes));
    const std::size_t sumAt = file.bytes.size();
    file.value(std::uint64_t(0));
    const std::size_t start = file.bytes.size();
    writePayload(file, c);
    DGV_CHECK_EQ(file.bytes.size() - start, count.bytes);
    const std::uint64_t sum = stateChecksum(file.bytes.data() + start, count.bytes);
    std::memcpy(&file.bytes[sumAt], &sum, sizeof sum);
    return std::move(file.bytes);
}

void writeStateFile(const fs::path& path, const StateCheckpoint& c) { writeTextAtomically(path, serializeState(c)); }

std::string readStateFile(const fs::path& path, StateCheckpoint& out) {
    // The system's failure (EIO), told apart from a bad file; either way the checkpoint is skipped.
    auto readError = [] {
        return std::string("cannot be read: ") + (errno ? std::strerror(errno) : "read error") +
               " (the system failed to read it, not its content)";
    };
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return fs::exists(path, ec) ? "not a regular file" : "no such file";
    std::ifstream in(path, std::ios::binary);
    if (!in) return "cannot open it";
    {
        // A foreign file, another format version or byte order shows in the first 20 bytes:
        // refused before the rest is read (a 2 GB file was read whole, 4 GB resident, first).
        char head[sizeof kMagic + 3 * sizeof(std::uint32_t)];
        errno = 0;
        in.read(head, sizeof head);
        if (in.bad()) return readError();
        StateCheckpoint scratch;
        const std::string early = parseState(std::string(head, static_cast<std::size_t>(in.gcount())), scratch);
        if (!early.empty() && early.rfind("truncated: ", 0) != 0) return early;
        in.clear();
        in.seekg(0);
    }
    errno = 0;
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) return readError();
    return parseState(bytes, out);
}

std::string parseState(const std::string& bytes, StateCheckpoint& out) {
    Reader h(bytes.data(), bytes.size());
    if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
        return "not a dgv state file";
    for (std::size_t i = 0; i < sizeof kMagic; ++i) (void)h.value<char>();
    const auto version = h.value<std::uint32_t>();
    const auto order = h.value<std::uint32_t>();
    const auto realSize = h.value<std::uint32_t>();
    if (!h.ok) return "truncated: " + std::to_string(bytes.size()) + " bytes";
    if (version != kStateFormatVersion)
        return "format version " + std::to_string(version) + ", this dgv reads " + std::to_string(kStateFormatVersion);
    if (order != kByteOrder || realSize != sizeof(Real))
        return "written on a machine with another byte order or real size";
    out.dgvVersion = h.text();
    out.sceneKey = h.value<std::uint64_t>();
    out.frame = h.value<std::int32_t>();
    const auto payloadBytes = h.value<std::uint64_t>();
    const auto sum = h.value<std::uint64_t>();
    if (!h.ok) return "truncated: " + std::to_string(bytes.size()) + " bytes";
    const std::size_t start = h.position();
    if (bytes.size() - start != payloadBytes)
        return (bytes.size() - start < payloadBytes ? "truncated: " : "trailing bytes: ") +
               std::to_string(bytes.size()) + " of " + std::to_string(start + payloadBytes) + " bytes";
    if (stateChecksum(bytes.data() + start, payloadBytes) != sum) return "checksum mismatch (corrupt)";

    Reader r(bytes.data() + start, static_cast<std::size_t>(payloadBytes));
    const auto rows = r.value<std::uint32_t>();
    out.statsRows.clear();
    for (std::uint32_t i = 0; i < rows && r.ok; ++i) out.statsRows.push_back(r.text());
    const auto objects = r.value<std::uint32_t>();
    out.objects.clear();
    for (std::uint32_t i = 0; i < objects && r.ok; ++i) {
        Simulation::ObjectState o;
        o.present = readBool(r);
        if (o.present) {
            readBody(r, o.body);
            o.remaps = r.value<std::int32_t>();
            if (o.remaps > 0) {
                o.latticeOrigin = r.value<Vec3>();
                o.latticeSpacing = r.value<Real>();
                o.latticeDims = r.value<Vec3i>();
                r.array(o.latticeCoords);
                r.array(o.surfaceVertices);
                r.array(o.surfaceTriangles);
            }
        }
        out.objects.push_back(std::move(o));
    }
    const auto histories = r.value<std::uint32_t>();
    out.contactAges.clear();
    for (std::uint32_t i = 0; i < histories && r.ok; ++i) {
        out.contactAges.emplace_back();
        r.array(out.contactAges.back());
    }
    if (!r.ok || !r.atEnd()) return "malformed payload";
    return {};
}

namespace {

/// The scene file read again and parsed, without frames.end (which changes no frame and no
/// state); `purpose` names what it is read for in the error.
nlohmann::json rereadScene(const SceneDesc& scene, const char* purpose) {
    std::ifstream in(scene.path, std::ios::binary);
    if (!in) throw InputError(scene.path, "", std::string("cannot read the scene file again (for ") + purpose + ")");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) throw InputError(scene.path, "", "the scene file changed while dgv ran");
    if (j.contains("frames") && j["frames"].is_object()) j["frames"].erase("end");
    return j;
}

/// The scene file's JSON without what cannot change the dynamics, in a canonical form.
std::string dynamicsJson(const SceneDesc& scene) {
    nlohmann::json j = rereadScene(scene, "the state checkpoints");
    for (const char* key : {"name", "camera", "render", "output", "curves", "gln"}) j.erase(key);
    if (j.contains("objects") && j["objects"].is_array())
        for (auto& o : j["objects"])
            if (o.is_object()) o.erase("color");
    return j.dump();  // keys sorted (std::map), no white space
}

}  // namespace

std::string sceneFrameKey(const SceneDesc& scene) {
    nlohmann::json j = rereadScene(scene, "the frames' key");
    if (j.contains("output") && j["output"].is_object()) j["output"].erase("dir");
    Fnv f;
    f.text(j.dump());  // keys sorted (std::map), no white space
    f.text(DGV_VERSION_STRING);
    auto file = [&](const std::string& path) {
        if (path.empty()) return;
        std::ifstream m(path, std::ios::binary);
        f.text(std::string((std::istreambuf_iterator<char>(m)), std::istreambuf_iterator<char>()));
    };
    // A mesh with what it refers to: an OBJ's MTL, a glTF's buffers, and the textures an object
    // drawn in the file's look shows (a changed texture is a changed frame).
    auto mesh = [&](const std::string& path, const std::string& name, double units, bool look) {
        if (path.empty()) return;
        MeshImportOptions o;
        o.meshName = name;
        o.unitScale = units;
        o.materials = look;
        o.decodeTextures = false;
        o.orientOutward = false;
        o.logUnitScale = false;
        MeshImportReport r;
        try {
            importMesh(path, o, &r);
        } catch (const InputError&) {
            r.filesRead = {path};  // the scene's reader has accepted it; keyed by its bytes alone
        }
        // each file by its name beside the mesh (a project moved elsewhere keeps its frames)
        const fs::path folder = fs::absolute(path).lexically_normal().parent_path();
        for (const std::string& p : r.filesRead) {
            f.text(fs::path(p).lexically_relative(folder).string());
            file(p);
        }
    };
    for (const ObjectDesc& o : scene.objects) mesh(o.meshPath, o.meshName, o.transform.units, !o.colorGiven);
    file(scene.render.environmentImage);  // the ambient light's image
    for (const ColliderDesc& c : scene.colliders) {
        mesh(c.meshPath, "", c.transform.units, false);
        file(c.levelSetPath);
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(f.h));
    return hex;
}

std::uint64_t sceneDynamicsKey(const SceneDesc& scene, const std::vector<const Lattice*>& lattices) {
    Fnv f;
    f.text(dynamicsJson(scene));
    // The rows a checkpoint carries must have stats.csv's current columns.
    f.text(statsCsvHeader());
    for (const ColliderDesc& c : scene.colliders)
        for (const std::string& path : {c.meshPath, c.levelSetPath}) {
            if (path.empty()) continue;
            std::ifstream in(path, std::ios::binary);
            f.text(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
        }
    for (const ObjectDesc& o : scene.objects)  // the step's solver (set by the file or by --solver)
        f.value(static_cast<std::int32_t>(o.material.solver));
    for (const ObjectDesc& o : scene.objects)  // a pinned vertex group's vertices (resolved from the mesh file)
        if (!o.pin.groupVertices.empty()) f.add(o.pin.groupVertices.data(), o.pin.groupVertices.size() * sizeof(Vec3));
    f.value(static_cast<std::uint64_t>(lattices.size()));
    for (const Lattice* lat : lattices) {
        if (!lat) {
            f.value(std::int64_t(-1));
            continue;
        }
        f.value(static_cast<std::int64_t>(lat->size()));
        f.value(lat->originWorld);
        f.value(lat->spacing);
        f.value(lat->dims);
        f.add(lat->coords.data(), lat->coords.size() * sizeof(Vec3i));
    }
    return f.h;
}

}  // namespace dgv
