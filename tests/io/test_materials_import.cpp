// The file's look (MeshImportOptions::materials, io/texture): materials, their textures and the
// corners' texture coordinates read from OBJ/MTL written here and from assimp's test models
// (glTF with a texture beside it or inside the GLB, Collada with a TGA, OBJ with JPEGs), a
// texture that is not there, and images stb_image decodes against what was written.

#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "io/mesh_import.hpp"
#include "io/png.hpp"
#include "io/texture.hpp"
#include "support/helpers.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

TriangleMesh importLook(const fs::path& p, MeshImportReport* report = nullptr, bool materials = true) {
    test::FpTrapsOff guard;
    MeshImportOptions options;
    options.materials = materials;
    return importMesh(p, options, report);
}

/// A 2x1 PNG: a red texel, a blue one, at 8 bits.
void writeRedBluePng(const fs::path& p) {
    Image img(2, 1);
    const std::uint16_t texels[8] = {65535, 0, 0, 65535, 0, 0, 65535, 65535};
    std::copy(texels, texels + 8, img.rgba.begin());
    writePng(p, img);
}

// A unit square in two triangles: "red" on the first, "tex" (a texture, Kd 0.5 0.25 1) on the
// second, every corner with its own texture coordinate.
const char* kSquareObj =
    "mtllib square.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "usemtl red\nf 1/1 2/2 3/3\n"
    "usemtl tex\nf 1/1 3/3 4/4\n";

}  // namespace

TEST_CASE("materials import: an OBJ's MTL colours, its texture and the corners' coordinates", "[io][materials]") {
    test::TempDir dir("materials-obj");
    writeRedBluePng(dir.path() / "rb.png");
    test::writeFile(dir.path(), "square.mtl", "newmtl red\nKd 1 0 0\nnewmtl tex\nKd 0.5 0.25 1\nmap_Kd rb.png\n");
    const fs::path obj = test::writeFile(dir.path(), "square.obj", kSquareObj);
    MeshImportReport report;
    const TriangleMesh m = importLook(obj, &report);
    REQUIRE(m.hasMaterials());
    REQUIRE(m.triangleCount() == 2);
    CHECK(report.materials == 2);
    CHECK(report.textures == 1);
    CHECK(report.texturesMissing == 0);
    // which material each triangle has, by its name (assimp may list them in any order)
    std::set<std::string> names;
    for (int t = 0; t < 2; ++t) names.insert(m.materials[static_cast<std::size_t>(m.triangleMaterials[t])].name);
    CHECK(names == std::set<std::string>{"red", "tex"});
    for (std::size_t t = 0; t < 2; ++t) {
        const SurfaceMaterial& mat = m.materials[static_cast<std::size_t>(m.triangleMaterials[t])];
        if (mat.name == "red") {
            CHECK(mat.baseColour.isApprox(Vec3(1, 0, 0)));
            CHECK(!mat.baseColourMap);
        } else {
            CHECK(mat.baseColour.isApprox(Vec3(0.5, 0.25, 1)));
            REQUIRE(mat.baseColourMap);
            CHECK(mat.baseColourMap->width == 2);
            CHECK(mat.baseColourMap->height == 1);
            CHECK(mat.baseColourMap->rgba == std::vector<std::uint8_t>{255, 0, 0, 255, 0, 0, 255, 255});
        }
        // each corner's coordinate is the square's corner position (vt = v's x, y)
        for (std::size_t k = 0; k < 3; ++k) {
            const Vec3& p = m.vertices[static_cast<std::size_t>(m.triangles[t][k])];
            CHECK(m.cornerUvs[t][k].x() == Approx(p.x()));
            CHECK(m.cornerUvs[t][k].y() == Approx(p.y()));
        }
    }
    // The colour from afar: half the area red, half the texture's mean (red and blue texels,
    // each 0.5 in linear) times the factor.
    const Vec3 mean = meanSurfaceColour(m, Vec3::Zero());
    CHECK(mean.isApprox(0.5 * Vec3(1, 0, 0) + 0.5 * Vec3(0.5 * 0.5, 0, 0.5 * 1), 1e-12));

    SECTION("the files it read: the mesh, its MTL and the texture") {
        const std::vector<std::string> files = {obj.string(), (dir.path() / "square.mtl").string(),
                                                (dir.path() / "rb.png").string()};
        std::vector<std::string> sorted = files;
        std::sort(sorted.begin(), sorted.end());
        CHECK(report.filesRead == sorted);
        // found without decoding (the frames' key): the same files, no maps
        test::FpTrapsOff guard;
        MeshImportOptions o;
        o.materials = true;
        o.decodeTextures = false;
        MeshImportReport quiet;
        const TriangleMesh found = importMesh(obj, o, &quiet);
        CHECK(quiet.filesRead == sorted);
        for (const SurfaceMaterial& mat : found.materials) CHECK(!mat.baseColourMap);
    }
    SECTION("positions only, as colliders and pins import") {
        const TriangleMesh plain = importLook(obj, nullptr, false);
        CHECK(!plain.hasMaterials());
        CHECK(plain.materials.empty());
        CHECK(plain.triangles == m.triangles);
        CHECK(plain.vertices == m.vertices);
    }
}

TEST_CASE("materials import: a texture named in another letter case or with a Windows folder is found beside the mesh",
          "[io][materials]") {
    test::TempDir dir("materials-case");
    writeRedBluePng(dir.path() / "rb.png");
    test::writeFile(dir.path(), "square.mtl", "newmtl red\nKd 1 0 0\nnewmtl tex\nKd 1 1 1\nmap_Kd C:\\textures\\RB.PNG\n");
    MeshImportReport report;
    const TriangleMesh m = importLook(test::writeFile(dir.path(), "square.obj", kSquareObj), &report);
    CHECK(report.texturesMissing == 0);
    CHECK(report.textures == 1);
    bool found = false;
    for (const SurfaceMaterial& mat : m.materials)
        if (mat.baseColourMap) found = mat.baseColourMap->source == (dir.path() / "rb.png").string();
    CHECK(found);
}

TEST_CASE("materials import: a texture that is not there is one warning, the material keeps its colour",
          "[io][materials]") {
    test::TempDir dir("materials-missing");
    test::writeFile(dir.path(), "square.mtl", "newmtl red\nKd 1 0 0\nnewmtl tex\nKd 0.5 0.25 1\nmap_Kd gone.png\n");
    const fs::path obj = test::writeFile(dir.path(), "square.obj", kSquareObj);
    MeshImportReport report;
    const TriangleMesh m = importLook(obj, &report);
    REQUIRE(m.hasMaterials());
    CHECK(report.texturesMissing == 1);
    CHECK(report.textures == 0);
    for (const SurfaceMaterial& mat : m.materials) CHECK(!mat.baseColourMap);
    SECTION("a file that is not an image") {
        test::writeFile(dir.path(), "gone.png", "not a png at all");
        MeshImportReport r2;
        importLook(obj, &r2);
        CHECK(r2.texturesMissing == 1);
    }
}

TEST_CASE("materials import: files without materials have no look of their own", "[io][materials]") {
    test::TempDir dir("materials-none");
    const fs::path obj = test::writeFile(dir.path(), "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    const TriangleMesh m = importLook(obj);
    CHECK(!m.hasMaterials());
    CHECK(m.materials.empty());
    CHECK(m.triangleMaterials.empty());
    CHECK(m.cornerUvs.empty());
    CHECK(meanSurfaceColour(m, Vec3(0.1, 0.2, 0.3)) == Vec3(0.1, 0.2, 0.3));
}

TEST_CASE("materials import: assimp's textured models", "[io][materials]") {
    SECTION("glTF 2 with its PNG beside it, and the same box as a GLB with the PNG inside") {
        for (const char* file : {"glTF2/BoxTextured-glTF/BoxTextured.gltf", "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"}) {
            INFO(file);
            MeshImportReport report;
            const TriangleMesh m = importLook(test::kAssimpModels / file, &report);
            REQUIRE(m.hasMaterials());
            REQUIRE(m.materials.size() == 1);
            const SurfaceMaterial& mat = m.materials[0];
            REQUIRE(mat.baseColourMap);
            CHECK(mat.baseColourMap->width == 211);
            CHECK(mat.baseColourMap->height == 211);
            CHECK(mat.metallic == 0);  // the file's metallicFactor
            CHECK(mat.roughness == 1);  // glTF's default
            // The coordinates span what the file's accessor states: u over [0, 6] (the faces
            // laid side by side), v over [0, 1].
            Eigen::Vector2f lo = m.cornerUvs[0][0], hi = lo;
            for (const auto& corners : m.cornerUvs)
                for (const Eigen::Vector2f& uv : corners) {
                    lo = lo.cwiseMin(uv);
                    hi = hi.cwiseMax(uv);
                }
            CHECK(lo == Eigen::Vector2f(0, 0));
            CHECK(hi == Eigen::Vector2f(6, 1));
        }
    }
    SECTION("Collada's duck with its TGA") {
        const TriangleMesh m = importLook(test::kAssimpModels / "Collada/duck.dae");
        REQUIRE(m.hasMaterials());
        REQUIRE(m.materials.size() == 1);
        REQUIRE(m.materials[0].baseColourMap);
        CHECK(m.materials[0].baseColourMap->width == 512);
        CHECK(m.materials[0].baseColourMap->height == 512);
    }
    SECTION("the OBJ spider: JPEGs named with Windows paths") {
        MeshImportReport report;
        const TriangleMesh m = importLook(test::kAssimpModels / "OBJ/spider.obj", &report);
        REQUIRE(m.hasMaterials());
        // the four materials its meshes use, each with its JPEG found beside the file
        CHECK(report.materials == 4);
        CHECK(report.texturesMissing == 0);
        CHECK(report.textures == 4);
        bool body = false;
        for (const SurfaceMaterial& mat : m.materials)
            if (mat.name == "HLeibTex") {
                body = true;
                REQUIRE(mat.baseColourMap);
                CHECK(mat.baseColourMap->width == 249);
                CHECK(mat.baseColourMap->height == 250);
                CHECK(mat.baseColour.isApprox(Vec3(0.690196, 0.639216, 0.615686), 1e-6));
            }
        CHECK(body);
    }
}

TEST_CASE("texture: images decode to what was written, what is not an image is refused by name", "[io][materials]") {
    test::TempDir dir("texture");
    SECTION("a 16-bit PNG to the nearest 8-bit codes") {
        Image img(2, 2);
        const std::uint16_t s[16] = {65535, 32896, 0, 65535, 257, 514, 771, 65535,
                                     0, 0, 0, 0, 65535, 65535, 65535, 32896};
        std::copy(s, s + 16, img.rgba.begin());
        PngWriteOptions o;
        o.bitDepth = 16;
        writePng(dir.path() / "t.png", img, o);
        const TextureImage t = readTexture(dir.path() / "t.png");
        CHECK(t.width == 2);
        CHECK(t.height == 2);
        std::vector<std::uint8_t> expect;
        for (std::uint16_t v : s) expect.push_back(to8bit(v));
        CHECK(t.rgba == expect);
        CHECK(t.source == (dir.path() / "t.png").string());
    }
    SECTION("the mean colour in linear light") {
        TextureImage t;
        t.width = 2;
        t.height = 1;
        t.rgba = {255, 0, 188, 255, 0, 0, 188, 255};
        CHECK(t.meanLinear().isApprox(Vec3(0.5, 0, decodeSrgb(188 / 255.0)), 1e-12));
    }
    SECTION("refusals") {
        const std::string junk = "this is no image at all";
        CHECK_THROWS_WITH(decodeTexture(reinterpret_cast<const unsigned char*>(junk.data()), junk.size(), "junk.png"),
                          Catch::StartsWith("junk.png: ") && Catch::Contains("not an image dgv reads"));
        CHECK_THROWS_WITH(readTexture(dir.path() / "none.png"), Catch::Contains("none.png: no such file"));
        CHECK_THROWS_WITH(decodeTexture(nullptr, 0, "empty.png"), Catch::Contains("empty.png: the image is empty"));
    }
}
