#include "io/gltf_cache.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"
#include "io/png.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>

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

    /// A bufferView of `bytes` (4-byte aligned) without an accessor (an image).
    void addView(const std::string& bytes, int target = 0) {
        while (bin.size() % 4) bin.push_back('\0');
        Json view = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
        if (target) view["target"] = target;
        bufferViews.push_back(view);
        bin += bytes;
    }

    /// A bufferView of `bytes` (4-byte aligned), and an accessor on it; returns the accessor.
    int add(const std::string& bytes, int componentType, const char* type, std::size_t count, int target,
            Json minValue = nullptr, Json maxValue = nullptr) {
        addView(bytes, target);
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

    /// VEC2 floats (texture coordinates).
    int addVec2(const std::vector<Eigen::Vector2f>& v) {
        std::string bytes(v.size() * 8, '\0');
        for (std::size_t i = 0; i < v.size(); ++i) std::memcpy(&bytes[8 * i], v[i].data(), 8);
        return add(bytes, kFloat, "VEC2", v.size(), kArrayBuffer);
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

/// A segment's vertices as written: one per (vertex, texture coordinate) where it has a look (a
/// vertex on a UV seam once for each side), and its triangles in runs of one material.
struct SegmentLayout {
    std::vector<int> source;                 ///< written vertex -> the segment's vertex; empty: the same
    std::vector<Eigen::Vector2f> uv;         ///< written vertex -> glTF's (u, 1 − v); empty: none
    std::vector<int> runMaterial;            ///< per run: its material (−1: the track's colour)
    std::vector<std::vector<std::array<int, 3>>> runTriangles;  ///< per run, over written vertices
};

SegmentLayout layoutOf(const GltfSegment& seg) {
    SegmentLayout l;
    const std::size_t nt = seg.triangles.size();
    if (seg.cornerUvs.size() != nt || seg.triangleMaterials.size() != nt) {
        l.runMaterial = {-1};
        l.runTriangles = {seg.triangles};
        return l;
    }
    std::vector<std::vector<int>> copies(seg.positions.empty() ? 0 : seg.positions[0].size());
    std::vector<std::array<int, 3>> tris(nt);
    for (std::size_t f = 0; f < nt; ++f)
        for (std::size_t k = 0; k < 3; ++k) {
            const int v = seg.triangles[f][k];
            // glTF's texture coordinates start at the image's top row; dgv's (assimp's) at its bottom.
            const Eigen::Vector2f uv(seg.cornerUvs[f][k].x(), 1.0f - seg.cornerUvs[f][k].y());
            std::vector<int>& mine = copies[static_cast<std::size_t>(v)];
            auto same = std::find_if(mine.begin(), mine.end(), [&](int w) { return l.uv[static_cast<std::size_t>(w)] == uv; });
            if (same != mine.end()) {
                tris[f][k] = *same;
                continue;
            }
            tris[f][k] = static_cast<int>(l.source.size());
            mine.push_back(tris[f][k]);
            l.source.push_back(v);
            l.uv.push_back(uv);
        }
    std::vector<std::size_t> order(nt);
    for (std::size_t f = 0; f < nt; ++f) order[f] = f;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return seg.triangleMaterials[a] < seg.triangleMaterials[b]; });
    for (std::size_t f : order) {
        if (l.runMaterial.empty() || l.runMaterial.back() != seg.triangleMaterials[f]) {
            l.runMaterial.push_back(seg.triangleMaterials[f]);
            l.runTriangles.emplace_back();
        }
        l.runTriangles.back().push_back(tris[f]);
    }
    return l;
}

/// `v` (one per segment vertex) as written (one per written vertex).
std::vector<Vec3> written(const std::vector<Vec3>& v, const SegmentLayout& l) {
    if (l.source.empty()) return v;
    std::vector<Vec3> out(l.source.size());
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = v[static_cast<std::size_t>(l.source[i])];
    return out;
}

/// The track's materials as glTF PBR materials, their textures as PNG images in the buffer
/// (each image once, `images` by texture); returns the first one's index.
int addMaterials(const GltfTrack& track, GlbBuilder& b, Json& materials, Json& textures, Json& images,
                 std::map<const TextureImage*, int>& textureOf) {
    const int first = static_cast<int>(materials.size());
    for (const SurfaceMaterial& m : track.materials) {
        Json pbr = {{"baseColorFactor", {m.baseColour.x(), m.baseColour.y(), m.baseColour.z(), 1.0}},
                    {"metallicFactor", m.metallic},
                    {"roughnessFactor", m.roughness >= 0 ? m.roughness : 0.5}};
        if (const TextureImage* t = m.baseColourMap.get(); t && t->width > 0) {
            auto found = textureOf.find(t);
            if (found == textureOf.end()) {
                Image img(t->width, t->height);
                for (std::size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = static_cast<std::uint16_t>(t->rgba[i] * 257);
                const std::vector<unsigned char> png = encodePng(img);
                b.addView(std::string(png.begin(), png.end()));
                images.push_back({{"bufferView", b.bufferViews.size() - 1}, {"mimeType", "image/png"}});
                textures.push_back({{"sampler", 0}, {"source", images.size() - 1}});
                found = textureOf.emplace(t, static_cast<int>(textures.size() - 1)).first;
            }
            pbr["baseColorTexture"] = {{"index", found->second}};
        }
        materials.push_back({{"name", m.name}, {"pbrMetallicRoughness", pbr}});
    }
    return first;
}

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
    Json textures = Json::array(), images = Json::array();
    std::map<const TextureImage*, int> textureOf;
    auto timeOf = [&](int frame) { return static_cast<float>((frame - info.firstFrame) / info.fps); };

    for (const GltfTrack& track : tracks) {
        materials.push_back({{"name", track.name},
                             {"pbrMetallicRoughness",
                              {{"baseColorFactor", {track.colour.x(), track.colour.y(), track.colour.z(), 1.0}},
                               {"metallicFactor", 0.0},
                               {"roughnessFactor", 0.5}}}});
        const int material = static_cast<int>(materials.size() - 1);
        const int firstLook = addMaterials(track, b, materials, textures, images, textureOf);
        const int trackFirst = track.segments.empty() ? 0 : track.segments.front().firstFrame;
        for (std::size_t s = 0; s < track.segments.size(); ++s) {
            const GltfSegment& seg = track.segments[s];
            const std::size_t frames = seg.positions.size();
            if (frames == 0) continue;
            const SegmentLayout layout = layoutOf(seg);
            const std::vector<Vec3> basePositions = written(seg.positions[0], layout);
            const std::vector<Vec3> baseNormals = written(seg.normals[0], layout);
            Json attributes = {{"POSITION", b.addVec3(basePositions, true)}, {"NORMAL", b.addVec3(baseNormals, false)}};
            if (!layout.uv.empty()) attributes["TEXCOORD_0"] = b.addVec2(layout.uv);
            Json targets = Json::array(), names = Json::array();
            std::vector<Vec3> delta(basePositions.size());
            for (std::size_t k = 1; k < frames; ++k) {
                const std::vector<Vec3> p = written(seg.positions[k], layout), n = written(seg.normals[k], layout);
                for (std::size_t v = 0; v < delta.size(); ++v) delta[v] = p[v] - basePositions[v];
                const int dp = b.addVec3(delta, true);
                for (std::size_t v = 0; v < delta.size(); ++v) delta[v] = n[v] - baseNormals[v];
                const int dn = b.addVec3(delta, false);
                targets.push_back({{"POSITION", dp}, {"NORMAL", dn}});
                names.push_back(frameName(seg.firstFrame + static_cast<int>(k)));
            }
            // One primitive per material, all on the same vertices and morph targets.
            Json primitives = Json::array();
            for (std::size_t r = 0; r < layout.runMaterial.size(); ++r) {
                const int m = layout.runMaterial[r];
                Json prim = {{"attributes", attributes},
                             {"indices", b.addIndices(layout.runTriangles[r])},
                             {"material", m >= 0 ? firstLook + m : material},
                             {"mode", 4}};
                if (!targets.empty()) prim["targets"] = targets;
                primitives.push_back(prim);
            }
            Json mesh = {{"name", track.name}};
            if (!targets.empty()) {
                mesh["weights"] = std::vector<float>(targets.size(), 0.0f);
                mesh["extras"] = {{"targetNames", names}};
            }
            mesh["primitives"] = primitives;
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
    if (!images.empty()) {
        doc["images"] = images;
        doc["textures"] = textures;
        // linear, trilinear, repeating: what dgv's renderer samples with
        doc["samplers"] = Json::array({{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}});
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
