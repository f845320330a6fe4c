// The mesh cache (io/mesh_cache.hpp): a frame written as PLY or OBJ reads back through assimp
// (dgv's own importer) with its vertices and triangles; the PLY carries normals, the object's
// colour and the contact value; a truncated, garbled, foreign or other-frame file is named as such; and
// a simulation with --mesh writes every object's every frame and resumes without keeping a bad one.
#include "io/mesh_cache.hpp"

#include "e2e/e2e_run.hpp"
#include "geom/primitives.hpp"
#include "io/mesh_import.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

/// One object's frame of `mesh` (kept alive by the caller).
MeshCacheFrame frameOf(const std::string& object, int frame, const std::string& key, const TriangleMesh& mesh) {
    MeshCacheFrame f;
    f.object = object;
    f.frame = frame;
    f.key = key;
    f.positions = &mesh.vertices;
    f.triangles = &mesh.triangles;
    return f;
}

}  // namespace

TEST_CASE("mesh cache: a frame reads back through assimp, with normals, colour and contact", "[io][meshcache]") {
    test::TempDir dir("mesh_cache_roundtrip");
    const TriangleMesh sphere = makeSphere(0.5, 24, 12);
    std::vector<Real> contact(sphere.vertices.size(), 0.0);
    for (std::size_t v = 0; v < contact.size(); ++v) contact[v] = sphere.vertices[v].y() < -0.4 ? 1.0 : 0.0;
    MeshCacheFrame f = frameOf("ball", 7, "abc123", sphere);
    f.contact = &contact;
    f.colour = Vec3(0.3, 0.6, 0.85);
    for (MeshCacheFormat format : {MeshCacheFormat::Ply, MeshCacheFormat::Obj}) {
        const fs::path path = meshCachePath(dir.path(), "ball", 7, format);
        CHECK(path.filename() == (format == MeshCacheFormat::Ply ? "ball.0007.ply" : "ball.0007.obj"));
        writeMeshCacheFrame(path, format, f);
        CHECK(meshCacheFileProblem(path, format, 7, "abc123").empty());
        const TriangleMesh back = importMesh(path);
        CHECK(back.triangles.size() == sphere.triangles.size());
        // assimp welds nothing here (the sphere's vertices are distinct): the same count and
        // the same positions to float precision.
        REQUIRE(back.vertices.size() == sphere.vertices.size());
        Real err = 0;
        for (std::size_t v = 0; v < back.vertices.size(); ++v)
            err = std::max(err, (back.vertices[v] - sphere.vertices[v]).norm());
        CHECK(err < 1e-6);
    }
    // The PLY's vertex records: x y z nx ny nz (floats), r g b (bytes), contact (float).
    const std::string bytes = e2e::readAll(meshCachePath(dir.path(), "ball", 7, MeshCacheFormat::Ply));
    const std::size_t body = bytes.find("end_header\n") + 11;
    auto floatAt = [&](std::size_t at) {
        float v;
        std::memcpy(&v, bytes.data() + at, 4);
        return Real(v);
    };
    int inContact = 0;
    for (std::size_t v = 0; v < sphere.vertices.size(); ++v) {
        const std::size_t at = body + v * 31;
        const Vec3 n(floatAt(at + 12), floatAt(at + 16), floatAt(at + 20));
        CHECK(n.dot(sphere.vertices[v].normalized()) > 0.95);      // outward, unit
        CHECK(static_cast<unsigned char>(bytes[at + 24]) == 149);  // sRGB of 0.3, 8-bit
        CHECK(floatAt(at + 27) == contact[v]);
        inContact += floatAt(at + 27) > 0;
    }
    CHECK(inContact > 0);
}

TEST_CASE("mesh cache: truncated, foreign and other frames' files are named", "[io][meshcache]") {
    test::TempDir dir("mesh_cache_problems");
    const TriangleMesh box = makeBox(Vec3(1, 1, 1));
    const MeshCacheFrame f = frameOf("box", 3, "k1", box);
    for (MeshCacheFormat format : {MeshCacheFormat::Ply, MeshCacheFormat::Obj}) {
        const fs::path path = meshCachePath(dir.path(), "box", 3, format);
        CHECK(meshCacheFileProblem(path, format, 3, "k1") == "is missing");
        writeMeshCacheFrame(path, format, f);
        CHECK(meshCacheFileProblem(path, format, 3, "k1").empty());
        CHECK(meshCacheFileProblem(path, format, 4, "k1") == "holds frame 3");
        CHECK(meshCacheFileProblem(path, format, 3, "k2") == "is of another version of the scene");
        const std::string whole = e2e::readAll(path);
        std::ofstream(path, std::ios::binary) << whole.substr(0, whole.size() - 5);
        CHECK(meshCacheFileProblem(path, format, 3, "k1") == "is truncated");
        {
            // 64 bytes of garbage in the middle of a sphere's frame, its size and header
            // unchanged, and one flipped bit in its data: the file's own checksum finds both.
            const TriangleMesh sphere = makeSphere(0.5, 24, 12);
            writeMeshCacheFrame(path, format, frameOf("box", 3, "k1", sphere));
            const std::string sealed = e2e::readAll(path);
            std::string garbled = sealed;
            for (std::size_t i = 0; i < 64; ++i) garbled[sealed.size() / 2 + i] = static_cast<char>(i * 37);
            std::ofstream(path, std::ios::binary) << garbled;
            CHECK(meshCacheFileProblem(path, format, 3, "k1") == "is corrupt (its checksum does not match)");
            std::string flipped = sealed;
            flipped[sealed.size() * 3 / 4] = static_cast<char>(flipped[sealed.size() * 3 / 4] ^ 4);
            std::ofstream(path, std::ios::binary) << flipped;
            CHECK(meshCacheFileProblem(path, format, 3, "k1") == "is corrupt (its checksum does not match)");
        }
        std::ofstream(path, std::ios::binary) << "not a mesh\n";
        CHECK(meshCacheFileProblem(path, format, 3, "k1") == "has no dgv frame (not written by dgv)");
    }
}

TEST_CASE("e2e: simulate --mesh writes every object's frames, and --resume re-makes a bad one",
          "[e2e][meshcache][resume]") {
    test::TempDir dir("e2e_mesh_cache");
    std::ofstream(dir.path() / "s.json") << R"({"name": "s", "frames": {"start": 1, "end": 4},
      "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.2}, "resolution": 8,
                   "transform": {"translate": [0, 0.3, 0]}},
                  {"name": "cube", "primitive": {"type": "box", "size": [0.3, 0.3, 0.3]}, "resolution": 6,
                   "transform": {"translate": [1, 0.5, 0]}}],
      "forces": [{"type": "gravity"}], "colliders": [{"type": "ground", "height": 0}]})";
    REQUIRE(e2e::runDgvIn(dir.path(), "-q simulate s.json --out o --mesh ply").exitCode == 0);
    const fs::path mesh = dir.path() / "o" / "mesh";
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(mesh)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    CHECK(names == std::vector<std::string>{"ball.0001.ply", "ball.0002.ply", "ball.0003.ply", "ball.0004.ply",
                                            "cube.0001.ply", "cube.0002.ply", "cube.0003.ply", "cube.0004.ply"});
    // The ball falls: frame 4's surface lies lower than frame 1's.
    auto lowest = [&](const std::string& name) {
        Real y = 1e9;
        for (const Vec3& v : importMesh(mesh / name).vertices) y = std::min(y, v.y());
        return y;
    };
    CHECK(lowest("ball.0004.ply") < lowest("ball.0001.ply") - 0.01);
    const std::string frame3 = e2e::readAll(mesh / "ball.0003.ply");
    // A truncated frame 3: resuming from frame 4's checkpoint would keep it, so frames 3-4 are made again.
    std::ofstream(mesh / "ball.0003.ply", std::ios::binary) << frame3.substr(0, frame3.size() / 2);
    const e2e::Run r = e2e::runDgvIn(dir.path(), "--progress log simulate s.json --out o --mesh ply --resume");
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK_THAT(r.err, Catch::Contains("ball.0003.ply is truncated"));
    CHECK(e2e::readAll(mesh / "ball.0003.ply") == frame3);
    // 64 garbage bytes in the middle of frame 2, its size and header intact: found by its
    // checksum, and frames 2-4 are made again, one line saying why.
    const std::string frame2 = e2e::readAll(mesh / "ball.0002.ply");
    std::string garbled = frame2;
    for (std::size_t i = 0; i < 64; ++i) garbled[frame2.size() / 2 + i] = static_cast<char>(255 - i);
    std::ofstream(mesh / "ball.0002.ply", std::ios::binary) << garbled;
    const e2e::Run g = e2e::runDgvIn(dir.path(), "--progress log simulate s.json --out o --mesh ply --resume");
    INFO(g.err);
    REQUIRE(g.exitCode == 0);
    CHECK_THAT(g.err, Catch::Contains("resume: 3 state checkpoints (frames 2-4) not used: the mesh cache file"));
    CHECK_THAT(g.err, Catch::Contains("ball.0002.ply is corrupt (its checksum does not match)"));
    CHECK(e2e::readAll(mesh / "ball.0002.ply") == frame2);
}
