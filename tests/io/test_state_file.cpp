// State checkpoint files (src/io/state_file.hpp): an exact round trip; every truncation, a
// flipped byte and another format version are reported, never thrown; the scene key ignores
// what cannot change the dynamics and sees what can.
#include "io/state_file.hpp"
#include "io/scene_json.hpp"
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <sys/resource.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

StateCheckpoint sample() {
    StateCheckpoint c;
    c.dgvVersion = "9.8.7";
    c.sceneKey = 0x0123456789abcdefull;
    c.frame = 42;
    c.statsRows = {"1,0,0", "2,0.04,1e-3"};
    c.objects.resize(3);
    c.objects[1].present = true;
    DeformableBodyState& b = c.objects[1].body;
    const std::size_t n = 5;
    for (std::size_t p = 0; p < n; ++p) {
        const Real s = static_cast<Real>(p) + 0.1;
        b.positions.push_back(Vec3(s, -s, 1 / s));
        b.velocities.push_back(Vec3(std::nextafter(s, 9.0), 0, -0.0));
        for (std::size_t a = 0; a < 3; ++a) {
            b.tangentPrev[a].push_back(Vec3::Constant(s * static_cast<Real>(a + 1)));
            b.deltaGamma[a].push_back(Mat3::Constant(1e-300 * s));
            b.plasticGamma[a].push_back(Mat3::Constant(-0.25 * s * static_cast<Real>(a)));
        }
        b.contact.push_back(p % 2 ? 1 : 0);
        b.contactDepth.push_back(p % 2 ? 1e-3 * s : 0);
        b.displacement.push_back(Vec3(0, s * 1e-9, 0));
        b.displacementPrev.push_back(Vec3(s * 1e-9, 0, 0));
        b.volumeCachePositions.push_back(Vec3(s, s, s));
        b.volumeCachePinned.push_back(p == 0 ? 1 : 0);
    }
    b.havePrev = true;
    b.halfStep = true;
    b.centre = Vec3(1, 2, 3);
    b.centreVelocity = Vec3(-1, 0.5, 1e-17);
    b.flex = Mat3::Identity() * 1.0000001;
    b.flexVelocity = Mat3::Constant(-2);
    b.plasticFlex << 1.25, 0.125, 0, 0, 0.8, 0, 0, 0, 1;
    b.lastStep = 1.0 / 96;
    b.freeFlight = 0.3125;
    c.contactAges = {{}, {0, 1, 1 << 30, 7, 3}, {}};
    return c;
}

std::string bytesOf(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

template <typename T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

}  // namespace

TEST_CASE("state_file: a checkpoint round-trips bit for bit", "[io][checkpoint]") {
    test::TempDir dir("state_roundtrip");
    const StateCheckpoint c = sample();
    const fs::path path = stateFilePath(dir.path(), "shot", 42);
    CHECK(path == dir.path() / "state" / "shot.0042.dgvstate");
    fs::create_directories(path.parent_path());
    writeStateFile(path, c);
    StateCheckpoint r;
    REQUIRE(readStateFile(path, r).empty());
    CHECK(r.dgvVersion == c.dgvVersion);
    CHECK(r.sceneKey == c.sceneKey);
    CHECK(r.frame == 42);
    CHECK(r.statsRows == c.statsRows);
    REQUIRE(r.objects.size() == 3);
    CHECK_FALSE(r.objects[0].present);
    CHECK_FALSE(r.objects[2].present);
    REQUIRE(r.objects[1].present);
    const DeformableBodyState& a = c.objects[1].body;
    const DeformableBodyState& b = r.objects[1].body;
    CHECK(sameBits(a.positions, b.positions));
    CHECK(sameBits(a.velocities, b.velocities));
    for (std::size_t k = 0; k < 3; ++k) {
        CHECK(sameBits(a.tangentPrev[k], b.tangentPrev[k]));
        CHECK(sameBits(a.deltaGamma[k], b.deltaGamma[k]));
    }
    CHECK(a.contact == b.contact);
    CHECK(sameBits(a.contactDepth, b.contactDepth));
    CHECK(sameBits(a.displacement, b.displacement));
    CHECK(sameBits(a.displacementPrev, b.displacementPrev));
    CHECK(sameBits(a.volumeCachePositions, b.volumeCachePositions));
    CHECK(a.volumeCachePinned == b.volumeCachePinned);
    CHECK(b.havePrev);
    CHECK(b.halfStep);
    CHECK(a.centre == b.centre);
    CHECK(a.centreVelocity == b.centreVelocity);
    CHECK(a.flex == b.flex);
    CHECK(a.flexVelocity == b.flexVelocity);
    CHECK(a.plasticFlex == b.plasticFlex);
    for (std::size_t k = 0; k < 3; ++k) CHECK(sameBits(a.plasticGamma[k], b.plasticGamma[k]));
    CHECK(a.lastStep == b.lastStep);
    CHECK(a.freeFlight == b.freeFlight);
    CHECK(r.contactAges == c.contactAges);
    // Writing what was read gives the same bytes.
    writeStateFile(dir.path() / "again.dgvstate", r);
    CHECK(bytesOf(dir.path() / "again.dgvstate") == bytesOf(path));
}

TEST_CASE("state_file: truncated, corrupt, foreign and missing files are reported", "[io][checkpoint]") {
    test::TempDir dir("state_bad");
    const fs::path good = dir.path() / "good.dgvstate";
    writeStateFile(good, sample());
    const std::string bytes = bytesOf(good);
    const fs::path bad = dir.path() / "bad.dgvstate";
    StateCheckpoint r;
    // Every cut short of the whole file, and one extra byte.
    for (std::size_t n = 0; n < bytes.size(); ++n) {
        std::ofstream(bad, std::ios::binary | std::ios::trunc) << bytes.substr(0, n);
        const std::string why = readStateFile(bad, r);
        INFO("cut at " << n << " of " << bytes.size() << ": " << why);
        CHECK_FALSE(why.empty());
        if (n >= 8) CHECK_THAT(why, Catch::StartsWith("truncated: "));
    }
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << bytes << 'x';
    CHECK_THAT(readStateFile(bad, r), Catch::StartsWith("trailing bytes: "));
    // Every flipped byte of the payload (header fields are checked by the caller or above).
    std::string flipped = bytes;
    flipped[flipped.size() - 20] ^= 0x10;
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << flipped;
    CHECK(readStateFile(bad, r) == "checksum mismatch (corrupt)");
    std::string version = bytes;
    const std::uint32_t other = kStateFormatVersion + 1;  // a version this dgv does not read
    version[8] = static_cast<char>(other);                // the format version, little-endian u32 after the magic
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << version;
    CHECK(readStateFile(bad, r) ==
          "format version " + std::to_string(other) + ", this dgv reads " + std::to_string(kStateFormatVersion));
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << "DGVSTATX and more";
    CHECK(readStateFile(bad, r) == "not a dgv state file");
    CHECK(readStateFile(dir.path() / "absent.dgvstate", r) == "no such file");
    CHECK(readStateFile(dir.path(), r) == "not a regular file");
    CHECK(readStateFile(good, r).empty());
}

TEST_CASE("state_file: a large foreign file is refused by its first bytes, not read whole", "[io][checkpoint]") {
    // A 2 GB file was read whole (4 GB resident) before its header was refused. A sparse 1 GiB
    // file with a foreign header and one of another format version: refused without the
    // process growing by anything like their size.
    test::TempDir dir("state_big");
    const fs::path big = dir.path() / "big.dgvstate";
    rusage before{};
    getrusage(RUSAGE_SELF, &before);
    const std::uint32_t other = kStateFormatVersion + 1;  // a version this dgv does not read
    for (const std::string& head :
         {std::string("NOTADGV!"), std::string("DGVSTATE") + static_cast<char>(other) + std::string(3, '\0')}) {
        std::ofstream(big, std::ios::binary | std::ios::trunc) << head;
        fs::resize_file(big, std::uintmax_t(1) << 30);
        StateCheckpoint r;
        const std::string why = readStateFile(big, r);
        CHECK((why == "not a dgv state file" || why.rfind("format version " + std::to_string(other), 0) == 0));
    }
    rusage after{};
    getrusage(RUSAGE_SELF, &after);
    CHECK(after.ru_maxrss - before.ru_maxrss < 256 * 1024);  // kB
}

TEST_CASE("state_file: the scene key ignores what cannot change the dynamics", "[io][checkpoint]") {
    test::TempDir dir("state_key");
    auto keyOf = [&](const std::string& json, const std::string& name = "s.json") {
        const fs::path p = dir.path() / name;
        std::ofstream(p) << json;
        const SceneDesc scene = loadScene(p);
        const Lattice lat = buildLattice(Vec3::Zero(), 0.1, Vec3i(2, 2, 2), std::vector<unsigned char>(8, 1));
        return sceneDynamicsKey(scene, {&lat});
    };
    const std::string base =
        R"({"frames": {"start": 1, "end": 10}, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8, "color": [1, 0, 0]}],
            "forces": [{"type": "gravity"}], "camera": {"type": "turntable"}, "render": {"width": 64, "height": 48}})";
    const auto k = keyOf(base);
    // Key order, white space, the name, frames.end, camera, render, output and colours: the same key.
    CHECK(keyOf(R"({"render": {"height": 48, "width": 64}, "camera": {"type": "turntable"},
        "forces": [{"type": "gravity"}], "objects": [{"resolution": 8, "primitive": {"type": "sphere"}, "color": [1, 0, 0]}],
        "frames": {"end": 10, "start": 1}})") == k);
    CHECK(
        keyOf(
            R"({"name": "other", "frames": {"start": 1, "end": 99}, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8, "color": [0, 1, 0]}],
        "forces": [{"type": "gravity"}], "camera": {"type": "look_at"}, "render": {"width": 640, "height": 480}, "output": {"vdb": true}})") ==
        k);
    // The dynamics: another key.
    CHECK(keyOf(R"({"frames": {"start": 1, "end": 10}, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8}],
        "forces": [{"type": "gravity", "strength": 9}]})") != k);
    CHECK(keyOf(R"({"frames": {"start": 2, "end": 10}, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8}],
        "forces": [{"type": "gravity"}]})") != k);
    CHECK(
        keyOf(
            R"({"frames": {"start": 1, "end": 10}, "substeps": 2, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8}],
        "forces": [{"type": "gravity"}]})") != k);
    CHECK(
        keyOf(
            R"({"frames": {"start": 1, "end": 10}, "objects": [{"primitive": {"type": "sphere"}, "resolution": 8, "material": {"damping": 2}}],
        "forces": [{"type": "gravity"}]})") != k);
    // The lattice: another key.
    const fs::path p = dir.path() / "s.json";
    std::ofstream(p) << base;
    const SceneDesc scene = loadScene(p);
    const Lattice a = buildLattice(Vec3::Zero(), 0.1, Vec3i(2, 2, 2), std::vector<unsigned char>(8, 1));
    std::vector<unsigned char> mask(8, 1);
    mask[7] = 0;
    const Lattice b = buildLattice(Vec3::Zero(), 0.1, Vec3i(2, 2, 2), mask);
    const Lattice c = buildLattice(Vec3::Zero(), 0.11, Vec3i(2, 2, 2), std::vector<unsigned char>(8, 1));
    CHECK(sceneDynamicsKey(scene, {&a}) == k);
    CHECK(sceneDynamicsKey(scene, {&b}) != k);
    CHECK(sceneDynamicsKey(scene, {&c}) != k);
    CHECK(sceneDynamicsKey(scene, {nullptr}) != k);
}
