#include "io/gltf_cache.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>

namespace dgv {

namespace {

using Json = nlohmann::json;

// glTF 2.0 constants.
constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr std::uint32_t kGlbMagic = 0x46546C67, kChunkJson = 0x4E4F534A, kChunkBin = 0x004E4942;

/// The binary buffer and the JSON arrays that index into it.
class GlbBuilder {
public:
    Json accessors = Json::array(), bufferViews = Json::array();
    std::string bin;

    /// A bufferView of `bytes` (4-byte aligned), and an accessor on it; returns the accessor.
    int add(const std::string& bytes, int componentType, const char* type, std::size_t count, int target,
            Json minValue = nullptr, Json maxValue = nullptr) {
        while (bin.size() % 4) bin.push_back('\0');
        Json view = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
        if (target) view["target"] = target;
        bufferViews.push_back(view);
        bin += bytes;
        Json acc = {
            {"bufferView", bufferViews.size() - 1}, {"componentType", componentType}, {"count", count}, {"type", type}};
        if (!minValue.is_null()) acc["min"] = minValue;
        if (!maxValue.is_null()) acc["max"] = maxValue;
        accessors.push_back(acc);
        return static_cast<int>(accessors.size() - 1);
    }

    /// VEC3 floats, with their bounds when `bounds` (POSITION and its targets must have them).
    int addVec3(const std::vector<Vec3>& v, bool bounds, int target = kArrayBuffer) {
        std::string bytes(v.size() * 12, '\0');
        float lo[3], hi[3];
        std::fill(lo, lo + 3, std::numeric_limits<float>::max());
        std::fill(hi, hi + 3, std::numeric_limits<float>::lowest());
        for (std::size_t i = 0; i < v.size(); ++i)
            for (int c = 0; c < 3; ++c) {
                const float f = static_cast<float>(v[i][c]);
                std::memcpy(&bytes[12 * i + 4 * c], &f, 4);
                lo[c] = std::min(lo[c], f);
                hi[c] = std::max(hi[c], f);
            }
        if (!bounds || v.empty()) return add(bytes, kFloat, "VEC3", v.size(), target);
        return add(bytes, kFloat, "VEC3", v.size(), target, Json{lo[0], lo[1], lo[2]}, Json{hi[0], hi[1], hi[2]});
    }

    /// SCALAR floats (animation inputs get bounds).
    int addScalars(const std::vector<float>& v, bool bounds) {
        std::string bytes(v.size() * 4, '\0');
        if (!v.empty()) std::memcpy(bytes.data(), v.data(), bytes.size());
        if (!bounds || v.empty()) return add(bytes, kFloat, "SCALAR", v.size(), 0);
        const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
        return add(bytes, kFloat, "SCALAR", v.size(), 0, Json{*lo}, Json{*hi});
    }

    int addIndices(const std::vector<std::array<int, 3>>& tris) {
        std::string bytes(tris.size() * 12, '\0');
        for (std::size_t t = 0; t < tris.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t i = static_cast<std::uint32_t>(tris[t][k]);
                std::memcpy(&bytes[12 * t + 4 * k], &i, 4);
            }
        return add(bytes, kUnsignedInt, "SCALAR", tris.size() * 3, kElementArrayBuffer);
    }
};

std::string frameName(int frame) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "frame_%04d", frame);
    return buf;
}

void putU32(std::string& out, std::uint32_t v) {
    char b[4];
    std::memcpy(b, &v, 4);  // little-endian hosts (x86-64, arm64)
    out.append(b, 4);
}

}  // namespace

std::string gltfShotBytes(const std::vector<GltfTrack>& tracks, const GltfShotInfo& info) {
    GlbBuilder b;
    Json nodes = Json::array(), meshes = Json::array(), materials = Json::array();
    Json samplers = Json::array(), channels = Json::array();
    auto timeOf = [&](int frame) { return static_cast<float>((frame - info.firstFrame) / info.fps); };

    for (const GltfTrack& track : tracks) {
        materials.push_back({{"name", track.name},
                             {"pbrMetallicRoughness",
                              {{"baseColorFactor", {track.colour.x(), track.colour.y(), track.colour.z(), 1.0}},
                               {"metallicFactor", 0.0},
                               {"roughnessFactor", 0.5}}}});
        const int material = static_cast<int>(materials.size() - 1);
        const int trackFirst = track.segments.empty() ? 0 : track.segments.front().firstFrame;
        for (std::size_t s = 0; s < track.segments.size(); ++s) {
            const GltfSegment& seg = track.segments[s];
            const std::size_t frames = seg.positions.size();
            if (frames == 0) continue;
            Json prim = {
                {"attributes",
                 {{"POSITION", b.addVec3(seg.positions[0], true)}, {"NORMAL", b.addVec3(seg.normals[0], false)}}},
                {"indices", b.addIndices(seg.triangles)},
                {"material", material},
                {"mode", 4}};
            Json targets = Json::array(), names = Json::array();
            std::vector<Vec3> delta(seg.positions[0].size());
            for (std::size_t k = 1; k < frames; ++k) {
                for (std::size_t v = 0; v < delta.size(); ++v) delta[v] = seg.positions[k][v] - seg.positions[0][v];
                const int dp = b.addVec3(delta, true);
                for (std::size_t v = 0; v < delta.size(); ++v) delta[v] = seg.normals[k][v] - seg.normals[0][v];
                const int dn = b.addVec3(delta, false);
                targets.push_back({{"POSITION", dp}, {"NORMAL", dn}});
                names.push_back(frameName(seg.firstFrame + static_cast<int>(k)));
            }
            Json mesh = {{"name", track.name}};
            if (!targets.empty()) {
                prim["targets"] = targets;
                mesh["weights"] = std::vector<float>(targets.size(), 0.0f);
                mesh["extras"] = {{"targetNames", names}};
            }
            mesh["primitives"] = Json::array({prim});
            meshes.push_back(mesh);
            const std::string nodeName = s == 0 ? track.name : track.name + "." + std::to_string(s + 1);
            Json node = {{"name", nodeName}, {"mesh", meshes.size() - 1}};
            // Only the first segment shows before the animation starts.
            if (s > 0) node["scale"] = {0.0, 0.0, 0.0};
            nodes.push_back(node);
            const std::size_t nodeIndex = nodes.size() - 1;

            if (!targets.empty()) {
                // Weights keyed at every frame: one-hot on the frame's target (none at the first).
                std::vector<float> times(frames), weights(frames * targets.size(), 0.0f);
                for (std::size_t k = 0; k < frames; ++k) {
                    times[k] = timeOf(seg.firstFrame + static_cast<int>(k));
                    if (k > 0) weights[k * targets.size() + (k - 1)] = 1.0f;
                }
                samplers.push_back({{"input", b.addScalars(times, true)},
                                    {"output", b.addScalars(weights, false)},
                                    {"interpolation", "LINEAR"}});
                channels.push_back(
                    {{"sampler", samplers.size() - 1}, {"target", {{"node", nodeIndex}, {"path", "weights"}}}});
            }
            if (track.segments.size() > 1) {
                // Visible (scale 1) from the segment's first frame to the next segment's first.
                std::vector<float> times, scales;
                auto key = [&](int frame, float scale) {
                    times.push_back(timeOf(frame));
                    scales.insert(scales.end(), {scale, scale, scale});
                };
                if (seg.firstFrame > trackFirst) key(trackFirst, 0);
                key(seg.firstFrame, 1);
                if (s + 1 < track.segments.size()) key(track.segments[s + 1].firstFrame, 0);
                std::string bytes(scales.size() * 4, '\0');
                std::memcpy(bytes.data(), scales.data(), bytes.size());
                const int out = b.add(bytes, kFloat, "VEC3", times.size(), 0);
                samplers.push_back({{"input", b.addScalars(times, true)}, {"output", out}, {"interpolation", "STEP"}});
                channels.push_back(
                    {{"sampler", samplers.size() - 1}, {"target", {{"node", nodeIndex}, {"path", "scale"}}}});
            }
        }
    }

    Json sceneNodes = Json::array();
    for (std::size_t i = 0; i < nodes.size(); ++i) sceneNodes.push_back(i);
    Json doc = {{"asset",
                 {{"version", "2.0"},
                  {"generator", info.generator},
                  {"extras", {{"dgv_key", info.key}, {"dgv_fps", info.fps}, {"dgv_checksum", checksumPlaceholder()}}}}},
                {"scene", 0},
                {"scenes", Json::array({{{"nodes", sceneNodes}}})},
                {"nodes", nodes},
                {"meshes", meshes},
                {"materials", materials}};
    while (b.bin.size() % 4) b.bin.push_back('\0');
    if (!b.bin.empty()) {
        doc["accessors"] = b.accessors;
        doc["bufferViews"] = b.bufferViews;
        doc["buffers"] = Json::array({{{"byteLength", b.bin.size()}}});
    }
    if (!channels.empty())
        doc["animations"] = Json::array({{{"name", "dgv"}, {"samplers", samplers}, {"channels", channels}}});

    std::string json = doc.dump();
    while (json.size() % 4) json.push_back(' ');
    if (json.size() + b.bin.size() + 28 > std::numeric_limits<std::uint32_t>::max())
        throw RuntimeError("the shot's glTF would be " + std::to_string((json.size() + b.bin.size()) >> 20) +
                           " MiB, past the GLB format's 4 GiB; write output.mesh \"ply\" instead");
    std::string out;
    out.reserve(12 + 8 + json.size() + 8 + b.bin.size());
    putU32(out, kGlbMagic);
    putU32(out, 2);
    putU32(out, static_cast<std::uint32_t>(12 + 8 + json.size() + (b.bin.empty() ? 0 : 8 + b.bin.size())));
    putU32(out, static_cast<std::uint32_t>(json.size()));
    putU32(out, kChunkJson);
    out += json;
    if (!b.bin.empty()) {
        putU32(out, static_cast<std::uint32_t>(b.bin.size()));
        putU32(out, kChunkBin);
        out += b.bin;
    }
    sealChecksum(out);
    return out;
}

void writeGltfShot(const std::filesystem::path& path, const std::vector<GltfTrack>& tracks, const GltfShotInfo& info) {
    writeTextAtomically(path, gltfShotBytes(tracks, info));
}

}  // namespace dgv
