// The shot's glTF (io/gltf_cache.hpp): the GLB's accessors, read back here byte by byte, give
// every frame's positions (the base plus that frame's morph target) and the one-hot weights at
// the frames' times; a body whose triangles change is split into segments shown one at a time;
// assimp (dgv's importer) reads the file with its morph targets; a mesh cache PLY frame reads
// back through readMeshCacheFrame; and `simulate --mesh gltf` writes the shot's file, which
// Blender 3.4 (headless) imports with the animation at the PLY frames' positions.
#include "io/gltf_cache.hpp"

#include "e2e/e2e_run.hpp"
#include "geom/primitives.hpp"
#include "geom/triangle_mesh.hpp"
#include "io/mesh_cache.hpp"
#include "io/mesh_import.hpp"
#include "io/texture.hpp"
#include "support/helpers.hpp"

#include <assimp/Importer.hpp>
#include <assimp/scene.h>
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>

using namespace dgv;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

/// A GLB split into its JSON and its binary chunk.
struct Glb {
    Json doc;
    std::string bin;

    explicit Glb(const std::string& bytes) {
        auto u32 = [&](std::size_t at) {
            std::uint32_t v;
            std::memcpy(&v, bytes.data() + at, 4);
            return v;
        };
        REQUIRE(bytes.size() >= 20);
        REQUIRE(u32(0) == 0x46546C67);  // "glTF"
        REQUIRE(u32(4) == 2);
        REQUIRE(u32(8) == bytes.size());
        const std::uint32_t jsonLength = u32(12);
        REQUIRE(u32(16) == 0x4E4F534A);
        REQUIRE(jsonLength % 4 == 0);
        doc = Json::parse(bytes.substr(20, jsonLength));
        const std::size_t binAt = 20 + jsonLength;
        if (binAt < bytes.size()) {
            REQUIRE(u32(binAt + 4) == 0x004E4942);
            bin = bytes.substr(binAt + 8, u32(binAt));
        }
    }

    /// The floats of accessor `a` (tightly packed, as dgv writes them).
    std::vector<float> floats(int a) const {
        const Json& acc = doc["accessors"][a];
        const Json& view = doc["bufferViews"][acc["bufferView"].get<int>()];
        const int per = acc["type"] == "VEC3" ? 3 : 1;
        std::vector<float> out(acc["count"].get<std::size_t>() * per);
        REQUIRE(out.size() * 4 == view["byteLength"].get<std::size_t>());
        std::memcpy(out.data(), bin.data() + view["byteOffset"].get<std::size_t>(), out.size() * 4);
        return out;
    }
};

/// A sphere squashed along y by s and lifted by h.
std::vector<Vec3> squashed(const TriangleMesh& m, Real s, Real h) {
    std::vector<Vec3> x = m.vertices;
    for (Vec3& p : x) p = Vec3(p.x() / std::sqrt(s), p.y() * s + h, p.z() / std::sqrt(s));
    return x;
}

}  // namespace

TEST_CASE("gltf: every frame reads back from the base and its morph target, keyed one-hot at frame / fps",
          "[io][meshcache][gltf]") {
    const TriangleMesh sphere = makeSphere(0.5, 16, 8);
    const TriangleMesh box = makeBox(Vec3(0.4, 0.4, 0.4));
    GltfTrack ball;
    ball.name = "ball";
    ball.colour = Vec3(0.2, 0.4, 0.9);
    GltfSegment a;
    a.firstFrame = 5;
    a.triangles = sphere.triangles;
    const Real squash[3] = {1.0, 0.6, 0.8};
    for (Real s : squash) {
        a.positions.push_back(squashed(sphere, s, 0.5 * s));
        a.normals.push_back(vertexNormals(a.positions.back(), a.triangles));
    }
    // Frames 8-9: other triangles (a goo body's re-parametrised surface).
    GltfSegment b;
    b.firstFrame = 8;
    b.triangles = box.triangles;
    for (int k = 0; k < 2; ++k) {
        std::vector<Vec3> x = box.vertices;
        for (Vec3& p : x) p += Vec3(0.1 * k, 0, 0);
        b.positions.push_back(x);
        b.normals.push_back(vertexNormals(x, b.triangles));
    }
    ball.segments = {a, b};
    GltfShotInfo info;
    info.fps = 24;
    info.generator = "dgv test";
    info.key = "k1";
    const Glb glb(gltfShotBytes({ball}, info));
    const Json& doc = glb.doc;
    CHECK(doc["asset"]["version"] == "2.0");
    CHECK(doc["asset"]["extras"]["dgv_key"] == "k1");
    REQUIRE(doc["nodes"].size() == 2);
    CHECK(doc["nodes"][0]["name"] == "ball");
    CHECK(doc["nodes"][1]["name"] == "ball.2");
    CHECK(doc["nodes"][1]["scale"] == Json({0.0, 0.0, 0.0}));  // hidden until its frames
    const auto colour = doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"].get<std::vector<double>>();
    CHECK(colour == std::vector<double>{0.2, 0.4, 0.9, 1.0});

    // Segment a: the base is frame 5; frames 6 and 7 are base + target 0 and 1.
    const Json& prim = doc["meshes"][0]["primitives"][0];
    REQUIRE(prim["targets"].size() == 2);
    CHECK(doc["meshes"][0]["extras"]["targetNames"] == Json({"frame_0006", "frame_0007"}));
    const std::vector<float> base = glb.floats(prim["attributes"]["POSITION"].get<int>());
    REQUIRE(base.size() == 3 * sphere.vertices.size());
    for (int k = 0; k < 3; ++k) {
        std::vector<float> x = base;
        if (k > 0) {
            const std::vector<float> d = glb.floats(prim["targets"][k - 1]["POSITION"].get<int>());
            for (std::size_t i = 0; i < x.size(); ++i) x[i] += d[i];
            // POSITION accessors carry bounds that hold every value.
            const Json& acc = doc["accessors"][prim["targets"][k - 1]["POSITION"].get<int>()];
            for (std::size_t i = 0; i < d.size(); ++i) {
                CHECK(d[i] >= acc["min"][i % 3].get<float>());
                CHECK(d[i] <= acc["max"][i % 3].get<float>());
            }
        }
        Real err = 0;
        for (std::size_t v = 0; v < sphere.vertices.size(); ++v)
            for (int c = 0; c < 3; ++c) err = std::max(err, std::abs(x[3 * v + c] - a.positions[k][v][c]));
        CHECK(err < 1e-6);
    }
    // Triangles: the indices are the segment's.
    const Json& idx = doc["accessors"][prim["indices"].get<int>()];
    CHECK(idx["componentType"] == 5125);
    CHECK(idx["count"] == 3 * sphere.triangles.size());

    // The animation: a weights channel per segment with morph targets (LINEAR) and a scale
    // channel per segment (STEP) when there are several.
    const Json& anim = doc["animations"][0];
    int weightChannels = 0, scaleChannels = 0;
    for (const Json& ch : anim["channels"]) {
        const Json& sampler = anim["samplers"][ch["sampler"].get<int>()];
        const std::vector<float> t = glb.floats(sampler["input"].get<int>());
        const std::vector<float> out = glb.floats(sampler["output"].get<int>());
        const int node = ch["target"]["node"];
        if (ch["target"]["path"] == "weights") {
            ++weightChannels;
            CHECK(sampler["interpolation"] == "LINEAR");
            const int frames = node == 0 ? 3 : 2, first = node == 0 ? 5 : 8;
            REQUIRE(t.size() == static_cast<std::size_t>(frames));
            REQUIRE(out.size() == static_cast<std::size_t>(frames * (frames - 1)));
            for (int k = 0; k < frames; ++k) {
                CHECK(t[k] == Approx((first + k) / 24.0).epsilon(1e-6));
                for (int j = 0; j < frames - 1; ++j) CHECK(out[k * (frames - 1) + j] == (j == k - 1 ? 1.0f : 0.0f));
            }
        } else {
            ++scaleChannels;
            CHECK(ch["target"]["path"] == "scale");
            CHECK(sampler["interpolation"] == "STEP");
            // ball shows from frame 5 until 8, ball.2 from 8 on.
            if (node == 0) {
                CHECK(t == std::vector<float>{5 / 24.0f, 8 / 24.0f});
                CHECK(out == std::vector<float>{1, 1, 1, 0, 0, 0});
            } else {
                CHECK(t == std::vector<float>{5 / 24.0f, 8 / 24.0f});
                CHECK(out == std::vector<float>{0, 0, 0, 1, 1, 1});
            }
        }
    }
    CHECK(weightChannels == 2);
    CHECK(scaleChannels == 2);
}

TEST_CASE("gltf: assimp reads the shot with its morph targets", "[io][meshcache][gltf]") {
    test::TempDir dir("gltf_assimp");
    const TriangleMesh sphere = makeSphere(0.5, 16, 8);
    GltfTrack t;
    t.name = "jelly";
    GltfSegment s;
    s.firstFrame = 1;
    s.triangles = sphere.triangles;
    for (Real q : {1.0, 0.5, 0.75, 1.1}) {
        s.positions.push_back(squashed(sphere, q, 0.5 * q));
        s.normals.push_back(vertexNormals(s.positions.back(), s.triangles));
    }
    t.segments = {s};
    const fs::path path = dir.path() / "shot.glb";
    writeGltfShot(path, {t}, GltfShotInfo());
    Assimp::Importer importer;
    const aiScene* scene = importer.ReadFile(path.string(), 0);
    INFO(importer.GetErrorString());
    REQUIRE(scene);
    REQUIRE(scene->mNumMeshes == 1);
    const aiMesh* m = scene->mMeshes[0];
    CHECK(m->mNumVertices == sphere.vertices.size());
    CHECK(m->mNumFaces == sphere.triangles.size());
    REQUIRE(m->mNumAnimMeshes == 3);
    // assimp gives each morph target as whole positions (base + delta): frame 2 is squashed to
    // half its height.
    Real lo = 1e9, hi = -1e9;
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
        lo = std::min<Real>(lo, m->mAnimMeshes[0]->mVertices[v].y);
        hi = std::max<Real>(hi, m->mAnimMeshes[0]->mVertices[v].y);
    }
    CHECK(hi - lo == Approx(0.5).epsilon(1e-3));
}

TEST_CASE("gltf: a mesh file's look is kept: materials, textures and texture coordinates across a seam",
          "[io][meshcache][gltf][materials]") {
    // A unit square in two triangles over 4 vertices; vertex 0 has another coordinate in the
    // second triangle (a seam), so 5 vertices are written. Triangle 0 is "tex" (a 2x1 texture),
    // triangle 1 "blue"; two frames, the second lifted by 0.25 in y.
    test::TempDir dir("gltf_look");
    GltfTrack t;
    t.name = "square";
    t.colour = Vec3(0.5, 0.5, 0.5);
    auto texture = std::make_shared<TextureImage>();
    texture->width = 2;
    texture->height = 1;
    texture->rgba = {255, 0, 0, 255, 0, 0, 255, 255};
    SurfaceMaterial tex, blue;
    tex.name = "tex";
    tex.baseColourMap = texture;
    tex.roughness = 0.3;
    blue.name = "blue";
    blue.baseColour = Vec3(0, 0, 1);
    blue.metallic = 1;
    t.materials = {tex, blue};
    GltfSegment s;
    s.firstFrame = 1;
    s.triangles = {{0, 1, 2}, {0, 2, 3}};
    const std::vector<Vec3> square = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
    for (Real lift : {0.0, 0.25}) {
        std::vector<Vec3> x = square;
        for (Vec3& p : x) p.y() += lift;
        s.positions.push_back(x);
        s.normals.push_back(vertexNormals(x, s.triangles));
    }
    s.triangleMaterials = {0, 1};
    s.cornerUvs = {{Eigen::Vector2f(0, 0), Eigen::Vector2f(1, 0), Eigen::Vector2f(1, 1)},
                   {Eigen::Vector2f(0.5f, 0.25f), Eigen::Vector2f(1, 1), Eigen::Vector2f(0, 1)}};
    t.segments = {s};
    const std::string bytes = gltfShotBytes({t}, GltfShotInfo());
    const Glb glb(bytes);
    const Json& doc = glb.doc;
    const Json& prims = doc["meshes"][0]["primitives"];
    REQUIRE(prims.size() == 2);
    // one material per primitive: the file's, after the track's own colour
    CHECK(doc["materials"][prims[0]["material"].get<int>()]["name"] == "tex");
    CHECK(doc["materials"][prims[1]["material"].get<int>()]["name"] == "blue");
    const Json& texPbr = doc["materials"][prims[0]["material"].get<int>()]["pbrMetallicRoughness"];
    CHECK(texPbr["roughnessFactor"].get<double>() == Approx(0.3));
    CHECK(doc["materials"][prims[1]["material"].get<int>()]["pbrMetallicRoughness"]["metallicFactor"] == 1.0);
    // 5 vertices; each written vertex's coordinate is its corner's (u, 1 − v), its positions its
    // source vertex's in both frames
    const int uvAccessor = prims[0]["attributes"]["TEXCOORD_0"].get<int>();
    CHECK(prims[1]["attributes"]["TEXCOORD_0"] == uvAccessor);
    const Json& uvAcc = doc["accessors"][uvAccessor];
    CHECK(uvAcc["type"] == "VEC2");
    REQUIRE(uvAcc["count"] == 5);
    std::vector<float> uv(10);
    std::memcpy(uv.data(), glb.bin.data() + doc["bufferViews"][uvAcc["bufferView"].get<int>()]["byteOffset"].get<std::size_t>(), 40);
    const std::vector<float> base = glb.floats(prims[0]["attributes"]["POSITION"].get<int>());
    const std::vector<float> lift = glb.floats(prims[0]["targets"][0]["POSITION"].get<int>());
    REQUIRE(base.size() == 15);
    for (int w = 0; w < 5; ++w) {
        // the square's corner at (x, y) has uv (x, y) but for vertex 0's second copy, (0.5, 0.25)
        const float x = base[3 * w], y = base[3 * w + 1];
        const bool seamCopy = x == 0 && y == 0 && uv[2 * w] == 0.5f;
        CHECK(uv[2 * w] == (seamCopy ? 0.5f : x));
        CHECK(uv[2 * w + 1] == 1 - (seamCopy ? 0.25f : y));
        CHECK(lift[3 * w + 1] == Approx(0.25));
        CHECK(lift[3 * w] == 0);
    }
    // the texture inside the file decodes to its texels
    REQUIRE(doc["images"].size() == 1);
    const Json& view = doc["bufferViews"][doc["images"][0]["bufferView"].get<int>()];
    const std::string png = glb.bin.substr(view["byteOffset"].get<std::size_t>(), view["byteLength"].get<std::size_t>());
    CHECK(doc["images"][0]["mimeType"] == "image/png");
    const TextureImage back = decodeTexture(reinterpret_cast<const unsigned char*>(png.data()), png.size(), "glb");
    CHECK(back.rgba == texture->rgba);
    CHECK(doc["textures"][texPbr["baseColorTexture"]["index"].get<int>()]["source"] == 0);

    SECTION("dgv's own importer reads the look back: the same materials, texture and corners") {
        const fs::path path = dir.path() / "shot.glb";
        std::ofstream(path, std::ios::binary) << bytes;
        test::FpTrapsOff guard;
        MeshImportOptions o;
        o.materials = true;
        o.orientOutward = false;
        const TriangleMesh m = importMesh(path, o);
        REQUIRE(m.hasMaterials());
        REQUIRE(m.triangles.size() == 2);
        for (std::size_t f = 0; f < 2; ++f) {
            const SurfaceMaterial& mat = m.materials[static_cast<std::size_t>(m.triangleMaterials[f])];
            const bool isTex = mat.name == "tex";
            CHECK((isTex ? bool(mat.baseColourMap) : !mat.baseColourMap));
            if (isTex) CHECK(mat.baseColourMap->rgba == texture->rgba);
            // each corner's coordinate as written, matched by its position
            const std::size_t src = isTex ? 0 : 1;
            for (std::size_t k = 0; k < 3; ++k) {
                const Vec3& p = m.vertices[static_cast<std::size_t>(m.triangles[f][k])];
                bool found = false;
                for (std::size_t j = 0; j < 3; ++j)
                    if ((square[static_cast<std::size_t>(s.triangles[src][j])] - p).norm() < 1e-6) {
                        found = true;
                        CHECK(m.cornerUvs[f][k].isApprox(s.cornerUvs[src][j]));
                    }
                CHECK(found);
            }
        }
    }
}

TEST_CASE("mesh cache: a PLY frame reads back whole, and another file is refused by name", "[io][meshcache][gltf]") {
    test::TempDir dir("mesh_cache_read");
    const TriangleMesh sphere = makeSphere(0.5, 12, 6);
    std::vector<Real> contact(sphere.vertices.size(), 0.0);
    contact[3] = 1;
    MeshCacheFrame f;
    f.object = "ball";
    f.frame = 2;
    f.key = "k";
    f.positions = &sphere.vertices;
    f.triangles = &sphere.triangles;
    f.contact = &contact;
    f.colour = Vec3(0.3, 0.6, 0.85);
    const fs::path path = meshCachePath(dir.path(), "ball", 2, MeshCacheFormat::Gltf);
    CHECK(path.extension() == ".ply");
    writeMeshCacheFrame(path, MeshCacheFormat::Gltf, f);
    const MeshCacheData d = readMeshCacheFrame(path);
    CHECK(d.triangles == sphere.triangles);
    REQUIRE(d.positions.size() == sphere.vertices.size());
    Real err = 0;
    for (std::size_t v = 0; v < d.positions.size(); ++v)
        err = std::max(err, (d.positions[v] - sphere.vertices[v]).norm());
    CHECK(err < 1e-6);
    CHECK(d.contact[3] == 1.0f);
    CHECK(d.contact[4] == 0.0f);
    CHECK(d.colour.x() == Approx(0.3).epsilon(0.02));  // 8-bit sRGB
    const std::string whole = e2e::readAll(path);
    std::ofstream(path, std::ios::binary) << whole.substr(0, whole.size() - 3);
    CHECK_THROWS_WITH(readMeshCacheFrame(path), Catch::Contains("ball.0002.ply") && Catch::Contains("truncated"));
}

TEST_CASE("e2e: simulate --mesh gltf writes the shot's glTF, which Blender imports with its animation",
          "[e2e][meshcache][gltf][slow]") {
    INFO("blender is not on PATH: scripts/install-deps.sh --tests installs Debian's blender");
    REQUIRE(std::system("command -v blender >/dev/null 2>&1") == 0);
    test::TempDir dir("e2e_gltf");
    std::ofstream(dir.path() / "s.json") << R"({"name": "s", "frames": {"start": 1, "end": 16},
      "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.2}, "resolution": 8,
                   "transform": {"translate": [0, 0.25, 0]}, "velocity": [0, -2, 0]}],
      "forces": [{"type": "gravity"}], "colliders": [{"type": "ground", "height": 0}]})";
    const e2e::Run r = e2e::runDgvIn(dir.path(), "simulate s.json --out o --mesh gltf");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const fs::path mesh = dir.path() / "o" / "mesh", glb = mesh / "s.glb";
    REQUIRE(fs::exists(glb));
    CHECK_THAT(r.err, Catch::Contains("s.glb"));
    // The frame where the ball is lowest (the squash) and the first: Blender's frame N at the
    // scene's 24 fps is the shot's frame N, at float precision.
    int squash = 1;
    Real lowest = 1e9;
    for (int f = 1; f <= 16; ++f) {
        const MeshCacheData d = readMeshCacheFrame(meshCachePath(mesh, "ball", f, MeshCacheFormat::Gltf));
        Real top = -1e9;
        for (const Vec3& p : d.positions) top = std::max(top, p.y());
        if (top < lowest) lowest = top, squash = f;
    }
    CHECK(squash > 1);
    const fs::path script = test::sourcePath("tests/e2e/blender_gltf_check.py");
    auto blender = [&](int frame, int plyFrame) {
        const std::string cmd = "blender -b --factory-startup -noaudio --python-exit-code 1 -P " + e2e::quote(script) +
                                " -- " + e2e::quote(glb) + " ball " + std::to_string(frame) + " " +
                                e2e::quote(meshCachePath(mesh, "ball", plyFrame, MeshCacheFormat::Gltf)) + " 1e-5 > " +
                                e2e::quote(dir.path() / "blender.log") + " 2>&1";
        const int status = std::system(cmd.c_str());
        INFO(e2e::readAll(dir.path() / "blender.log"));
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    };
    CHECK(blender(1, 1) == 0);
    CHECK(blender(squash, squash) == 0);
    CHECK(blender(16, 16) == 0);
    // The check can fail: frame 1's surface is not the squash's.
    CHECK(blender(squash, 1) == 1);

    // A run that replaces frames removes the old shot file first and remakes it at the end; a
    // resume that keeps every frame remakes it from the files on disk, byte for byte.
    const std::string before = e2e::readAll(glb);
    fs::remove(glb);
    REQUIRE(e2e::runDgvIn(dir.path(), "-q simulate s.json --out o --mesh gltf --resume").exitCode == 0);
    CHECK(e2e::readAll(glb) == before);
}
