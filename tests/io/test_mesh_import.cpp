// Tests of src/io/mesh_import.hpp: formats, node transforms, names, and broken files (assimp's
// own test models, package assimp-testmodels, a declared dependency).
#include <catch2/catch.hpp>

#include "base/errors.hpp"
#include "io/mesh_import.hpp"
#include "support/helpers.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace dgv;
namespace fs = std::filesystem;

namespace {

TriangleMesh import(const fs::path& p, const std::string& name = "", MeshImportReport* report = nullptr) {
    test::FpTrapsOff guard;
    MeshImportOptions options;
    options.meshName = name;
    return importMesh(p, options, report);
}

/// The InputError's problem text, or "no error".
std::string problemOf(const fs::path& p, const std::string& name = "") {
    try {
        import(p, name);
    } catch (const InputError& e) {
        CHECK(e.input() == p.string());
        CHECK(std::string(e.what()).find('\n') == std::string::npos);
        return e.problem();
    }
    return "no error";
}

/// "where: problem" of the InputError, or "no error".
std::string whereOf(const fs::path& p) {
    try {
        import(p);
    } catch (const InputError& e) {
        return e.where() + ": " + e.problem();
    }
    return std::string("no error");
}

const char* kCubeObj =
    "# unit cube, quads\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "vn 0 0 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

// A tetrahedron (outward, volume 1/6) instanced by three nodes: "Moved" (scale 2, translate x
// by 10), "Mirrored" (scale x by -1) and "Parent" (translate y by 5) > "Child" (translate z by 1).
// The buffer holds 4 float positions and 12 uint16 indices, base64-encoded.
std::string tetraGltf(const std::string& buffer) {
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2]}],
"nodes":[{"name":"Moved","mesh":0,"translation":[10,0,0],"scale":[2,2,2]},
{"name":"Mirrored","mesh":0,"scale":[-1,1,1]},
{"name":"Parent","translation":[0,5,0],"children":[3]},
{"name":"Child","mesh":0,"translation":[0,0,1]}],
"meshes":[{"name":"Tetra","primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":4}]}],
"buffers":[{"byteLength":72,"uri":"data:application/octet-stream;base64,)" +
           buffer + R"("}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48,"target":34962},
{"buffer":0,"byteOffset":48,"byteLength":24,"target":34963}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1]},
{"bufferView":1,"componentType":5123,"count":12,"type":"SCALAR"}]})";
}
const char* kTetraBuffer =
    "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAACAAEAAAABAAMAAAADAAIAAQACAAMA";
const char* kTetraBufferNaN =  // vertex 2 is (NaN, 1, 0)
    "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAADAfwAAgD8AAAAAAAAAAAAAAAAAAIA/AAACAAEAAAABAAMAAAADAAIAAQACAAMA";

}  // namespace

TEST_CASE("mesh_import: OBJ quads are triangulated into a closed cube", "[io]") {
    test::TempDir dir("mesh-import-obj");
    MeshImportReport report;
    const TriangleMesh m = import(test::writeFile(dir.path(), "cube.obj", kCubeObj), "", &report);
    CHECK(m.triangleCount() == 12);
    CHECK(m.vertexCount() == 8);
    const MeshReport r = analyseMesh(m);
    CHECK(r.closed);
    CHECK(r.manifold);
    CHECK(r.signedVolume == Approx(1.0).epsilon(1e-12));
    CHECK(report.meshesMerged == 1);
    CHECK(report.degenerateDropped == 0);
}

TEST_CASE("mesh_import: PLY and unwelded STL import closed", "[io]") {
    test::TempDir dir("mesh-import-ply-stl");
    const fs::path ply = test::writeFile(dir.path(), "tetra.ply",
                               "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 4\n"
                               "property list uchar int vertex_indices\nend_header\n"
                               "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
    const TriangleMesh a = import(ply);
    CHECK(a.triangleCount() == 4);
    CHECK(analyseMesh(a).closed);
    CHECK(meshSignedVolume(a) == Approx(1.0 / 6).epsilon(1e-12));

    // STL stores every triangle with its own vertices (and normals that differ): welded here.
    std::string stl = "solid t\n";
    const int tris[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    const char* v[4] = {"0 0 0", "1 0 0", "0 1 0", "0 0 1"};
    for (const auto& t : tris) {
        stl += "facet normal 0 0 0\nouter loop\n";
        for (int k : t) stl += std::string("vertex ") + v[k] + "\n";
        stl += "endloop\nendfacet\n";
    }
    stl += "endsolid t\n";
    const TriangleMesh b = import(test::writeFile(dir.path(), "tetra.stl", stl));
    CHECK(b.vertexCount() == 4);
    CHECK(analyseMesh(b).closed);
    CHECK(meshSignedVolume(b) == Approx(1.0 / 6).epsilon(1e-6));
}

TEST_CASE("mesh_import: node transforms are applied and mirrors keep normals outward", "[io]") {
    test::TempDir dir("mesh-import-gltf");
    const fs::path p = test::writeFile(dir.path(), "tetras.gltf", tetraGltf(kTetraBuffer));

    MeshImportReport report;
    const TriangleMesh all = import(p, "", &report);
    CHECK(report.meshesMerged == 3);
    CHECK(all.triangleCount() == 12);
    CHECK(meshSignedVolume(all) == Approx(10.0 / 6).epsilon(1e-9));  // 8/6 + 1/6 + 1/6

    const TriangleMesh moved = import(p, "Moved");
    CHECK(meshSignedVolume(moved) == Approx(8.0 / 6).epsilon(1e-9));
    const Box3 bm = meshBounds(moved);
    CHECK((bm.min - Vec3(10, 0, 0)).norm() < 1e-6);
    CHECK((bm.max - Vec3(12, 2, 2)).norm() < 1e-6);

    const TriangleMesh mirrored = import(p, "Mirrored");
    CHECK(meshSignedVolume(mirrored) == Approx(1.0 / 6).epsilon(1e-9));
    CHECK(meshBounds(mirrored).min.x() == Approx(-1.0));

    // A node name selects its subtree, with the parents' transforms.
    const Box3 bc = meshBounds(import(p, "Parent"));
    CHECK((bc.min - Vec3(0, 5, 1)).norm() < 1e-6);
    CHECK(meshBounds(import(p, "Child")).min == bc.min);

    // A mesh name selects every instance of it.
    CHECK(import(p, "Tetra").triangleCount() == 12);

    const std::string missing = problemOf(p, "Nope");
    CHECK(missing.find("no mesh or node named 'Nope'") != std::string::npos);
    CHECK(missing.find("'Moved'") != std::string::npos);
    CHECK(missing.find("'Tetra'") != std::string::npos);
}

TEST_CASE("mesh_import: non-finite coordinates are input errors", "[io]") {
    test::TempDir dir("mesh-import-nan");
    CHECK(problemOf(test::writeFile(dir.path(), "nan.gltf", tetraGltf(kTetraBufferNaN))) ==
          "mesh 'Tetra' vertex 2 has a non-finite coordinate");
    CHECK(problemOf(test::writeFile(dir.path(), "inf.obj", "v 0 0 0\nv 1 0 0\nv inf 1 0\nf 1 2 3\n"))
              .find("has a non-finite coordinate") != std::string::npos);
    REQUIRE(fs::exists(test::kAssimpModels / "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb"));
    CHECK(problemOf(test::kAssimpModels / "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb").find("non-finite") !=
          std::string::npos);
}

TEST_CASE("mesh_import: files without triangles are input errors", "[io]") {
    test::TempDir dir("mesh-import-empty");
    CHECK(problemOf(test::writeFile(dir.path(), "lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\np 1\n")) ==
          "no triangles (the file holds only points and lines)");
    CHECK(problemOf(test::writeFile(dir.path(), "points.ply",
                          "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                          "property float z\nend_header\n0 0 0\n1 1 1\n"))
              .rfind("no triangles", 0) == 0);
    CHECK(problemOf(test::writeFile(dir.path(), "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")) ==
          "no triangles (all 1 triangles are degenerate)");
    CHECK(problemOf(test::writeFile(dir.path(), "bad-index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"))
              .rfind("assimp could not read it: ", 0) == 0);
}

TEST_CASE("mesh_import: missing files, folders and empty files are input errors", "[io]") {
    test::TempDir dir("mesh-import-missing");
    CHECK(problemOf(dir.path() / "nothing.obj") == "file not found");
    CHECK(problemOf(dir.path()) == "is a directory, expected a mesh file");
    CHECK(problemOf(test::writeFile(dir.path(), "empty.obj", "")) == "the file is empty");
    CHECK(problemOf(test::writeFile(dir.path(), "text.obj", "this is not a mesh\n")).rfind("no triangles", 0) == 0);
}

TEST_CASE("mesh_import: assimp's broken test models are input errors, never crashes", "[io]") {
    REQUIRE(fs::is_directory(test::kAssimpModels));  // package assimp-testmodels (scripts/install-deps.sh)
    std::vector<fs::path> broken;
    for (const auto& e : fs::directory_iterator(test::kAssimpModels / "invalid"))
        if (e.is_regular_file()) broken.push_back(e.path());
    for (const char* f : {"OFF/invalid.off", "glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf",
                          "glTF2/RecursiveNodes/RecursiveNodes.gltf", "glTF2/MissingBin/BoxTextured.gltf",
                          "glTF2/TestNoRootNode/NoScene.gltf", "glTF2/wrongTypes/badArray.gltf",
                          "glTF2/SchemaFailures/sceneWrongType.gltf", "OBJ/point_cloud.obj"})
        broken.push_back(test::kAssimpModels / f);
    REQUIRE(broken.size() >= 20);
    for (const fs::path& p : broken) {
        INFO(p.string());
        if (p.filename() == "malformed2.obj") {
            // Only an unknown material: assimp reads it, and so do we.
            CHECK(import(p).triangleCount() > 0);
            continue;
        }
        CHECK(problemOf(p) != "no error");
    }
    // A header declaring 3.5e11 vertices in 309 bytes: refused before assimp reserves memory.
    CHECK(problemOf(test::kAssimpModels / "invalid/OutOfMemory.off").find("OFF header declares") != std::string::npos);
}

// assimp 5.2's OFF reader trusts the counts it reads; these files crashed it (found by
// scripts/fuzz.sh). dgv checks OFF files in full first and names the line.
TEST_CASE("mesh_import: OFF files are checked in full before assimp reads them", "[io]") {
    test::TempDir dir("mesh-import-off");
    const std::string verts = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
    const std::string faces = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    CHECK(import(test::writeFile(dir.path(), "tet.off", "OFF\n4 4 0\n" + verts + faces)).triangleCount() == 4);
    CHECK(import(test::writeFile(dir.path(), "tet1.off", "OFF 4 4 0\n# a comment\n" + verts + faces)).triangleCount() == 4);
    CHECK(import(test::kAssimpModels / "OFF/Cube.off").triangleCount() == 12);

    // The fuzzer's crash: a fourth face with 0 vertices followed by junk.
    CHECK(whereOf(test::writeFile(dir.path(), "zero.off", "OFF\n4 4 0\n" + verts + "3 0 2 1\n3 0 1 3\n3 0 3 2\n0v 0 0\n")) ==
          "line 10: expected a face's vertex count, got '0v'");
    CHECK(whereOf(test::writeFile(dir.path(), "zero2.off", "OFF\n4 4 0\n" + verts + "3 0 2 1\n3 0 1 3\n3 0 3 2\n0\n")) ==
          "line 10: a face with 0 vertices (expected 1 to 64)");
    CHECK(whereOf(test::writeFile(dir.path(), "index.off", "OFF\n4 1 0\n" + verts + "3 0 2 4\n")) ==
          "line 7: face vertex index '4' is not in [0, 4)");
    CHECK(whereOf(test::writeFile(dir.path(), "short.off", "OFF\n4 1 0\n" + verts + "4 0 2 1\n")) ==
          "line 7: the face lists fewer than its 4 vertex indices");
    CHECK(whereOf(test::writeFile(dir.path(), "trunc.off", "OFF\n4 4 0\n" + verts + "3 0 2 1\n")) ==
          "line 7: the file ends after 1 of 4 faces");
    CHECK(whereOf(test::writeFile(dir.path(), "vnan.off", "OFF\n4 1 0\n0 0 0\n1 nan 0\n0 1 0\n0 0 1\n3 0 1 2\n")) ==
          "line 4: vertex coordinate 'nan' is not a finite number");
    CHECK(whereOf(test::writeFile(dir.path(), "counts.off", "OFF\nfour 4 0\n" + verts + faces)) ==
          "line 2: expected a vertex count, got 'four'");
}

// assimp 5.2's PLY reader never returns on a header without end_header (found by scripts/fuzz.sh
// in CI: 6 inputs, then a timeout). dgv checks PLY headers first and names the line.
TEST_CASE("mesh_import: PLY headers are checked before assimp reads them", "[io]") {
    test::TempDir dir("mesh-import-ply");
    const std::string head =
        "ply\nformat ascii 1.0\ncomment tetrahedron\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\n"
        "element face 4\nproperty list uchar int vertex_indices\n";
    const std::string body = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    CHECK(import(test::writeFile(dir.path(), "tet.ply", head + "end_header\n" + body)).triangleCount() == 4);
    std::string crlf;
    for (char c : head + "end_header\n" + body) {
        if (c == '\n') crlf += '\r';
        crlf += c;
    }
    CHECK(import(test::writeFile(dir.path(), "crlf.ply", crlf)).triangleCount() == 4);
    CHECK(import(test::kAssimpModels / "PLY/cube.ply").triangleCount() == 12);
    // Header lines starting with an unknown word are skipped as assimp skips them: Blender 2.47
    // writes "Created by Blender3D 247 ..." as the third line.
    const std::string created =
        "ply\nformat ascii 1.0\nCreated by Blender3D 247 - www.blender.org, source file: \n"
        "obj_info num_cols 4\n" +
        head.substr(head.find("element"));
    CHECK(import(test::writeFile(dir.path(), "created.ply", created + "end_header\n" + body)).triangleCount() == 4);
    REQUIRE(fs::exists(test::kAssimpModels / "PLY/Wuson.ply"));
    CHECK(import(test::kAssimpModels / "PLY/Wuson.ply").triangleCount() > 3000);

    // The fuzzer's input: the header runs into the data and the file ends without end_header.
    CHECK(whereOf(test::writeFile(dir.path(), "fuzz.ply", head + "en3\n3 0 3 2\n3 1 2 3\n")) ==
          "line 11: unexpected '3' in the PLY header (expected element, property, comment or end_header)");
    CHECK(whereOf(test::writeFile(dir.path(), "fuzz2.ply", head + "en3\n")) ==
          "line 10: the PLY header has no 'end_header' line");
    CHECK(whereOf(test::writeFile(dir.path(), "noend.ply", head)) == "line 9: the PLY header has no 'end_header' line");
    // Detected by the magic whatever the extension, as assimp does.
    CHECK(whereOf(test::writeFile(dir.path(), "noend.mesh", head)) == "line 9: the PLY header has no 'end_header' line");
    CHECK(whereOf(test::writeFile(dir.path(), "format.ply", "ply\nformat text 1.0\nend_header\n")) ==
          "line 2: unknown PLY format 'text' (expected ascii, binary_little_endian or binary_big_endian)");
    CHECK(whereOf(test::writeFile(dir.path(), "type.ply",
                        "ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n0\n")) ==
          "line 4: unknown PLY property type 'real'");
    CHECK(whereOf(test::writeFile(dir.path(), "orphan.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n")) ==
          "line 3: a PLY property before any element");
    CHECK(whereOf(test::writeFile(dir.path(), "count.ply", "ply\nformat ascii 1.0\nelement vertex 99999999\nend_header\n")) ==
          "line 3: the PLY header declares more elements than a 56-byte file can hold");
    CHECK(whereOf(test::writeFile(dir.path(), "magic.ply", "plyx\nformat ascii 1.0\n")) ==
          "line 1: not a PLY file: the first line must be 'ply'");
}

TEST_CASE("mesh_import: inside-out parts are turned around, each part on its own", "[io]") {
    test::TempDir dir("mesh-import-orient");
    // Two unit cubes: the first wound inside out, the second (moved by 3 in x) outward.
    std::string two =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "v 3 0 0\nv 4 0 0\nv 4 1 0\nv 3 1 0\nv 3 0 1\nv 4 0 1\nv 4 1 1\nv 3 1 1\n"
        "f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n"
        "f 9 12 11 10\nf 13 14 15 16\nf 9 10 14 13\nf 10 11 15 14\nf 11 12 16 15\nf 12 9 13 16\n";
    MeshImportReport report;
    const TriangleMesh m = import(test::writeFile(dir.path(), "two.obj", two), "", &report);
    CHECK(report.orientation.parts == 2);
    CHECK(report.orientation.flippedParts == 1);
    CHECK(report.orientation.volumeBefore == Approx(0.0).margin(1e-12));  // -1 + 1
    const MeshReport r = analyseMesh(m);
    CHECK(r.closed);
    CHECK(r.manifold);
    CHECK(r.signedVolume == Approx(2.0).epsilon(1e-12));
    // A cavity (an inward cube inside an outward one) is left as it is: a hollow box.
    std::string hollow =
        "v -1 -1 -1\nv 2 -1 -1\nv 2 2 -1\nv -1 2 -1\nv -1 -1 2\nv 2 -1 2\nv 2 2 2\nv -1 2 2\n"
        "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "f 9 10 11 12\nf 13 16 15 14\nf 9 13 14 10\nf 10 14 15 11\nf 11 15 16 12\nf 12 16 13 9\n";
    const TriangleMesh box = import(test::writeFile(dir.path(), "hollow.obj", hollow), "", &report);
    CHECK(report.orientation.parts == 2);
    CHECK(report.orientation.flippedParts == 0);
    CHECK(analyseMesh(box).signedVolume == Approx(27.0 - 1.0).epsilon(1e-12));
    // An outward mesh is left as it is.
    const TriangleMesh cube = import(test::writeFile(dir.path(), "cube.obj", kCubeObj), "", &report);
    CHECK(report.orientation.flippedParts == 0);
    CHECK(analyseMesh(cube).signedVolume == Approx(1.0).epsilon(1e-12));
    // assimp's OFF/Wuson.off is wound inside out (signed volume about -1.1): it comes in outward.
    const TriangleMesh wuson = import(test::kAssimpModels / "OFF/Wuson.off", "", &report);
    CHECK(report.orientation.volumeBefore < -1);
    CHECK(report.orientation.flippedParts >= 1);
    CHECK(analyseMesh(wuson).signedVolume > 1);
}

TEST_CASE("mesh_import: real models from assimp's test set", "[io]") {
    MeshImportReport report;
    const TriangleMesh duck = import(test::kAssimpModels / "Collada/duck.dae", "", &report);
    CHECK(duck.triangleCount() > 4000);
    const TriangleMesh teapots = import(test::kAssimpModels / "Collada/teapot_instancenodes.DAE", "", &report);
    CHECK(report.meshesMerged > 1);  // instanced nodes each contribute
    CHECK(teapots.triangleCount() > 0);
}

// FBX files carry their unit (UnitScaleFactor, centimetres per unit); dgv works in metres.
// spider.fbx is in centimetres: 15,059 x 7,974 x 19,338 units after its node transforms (each
// node scales by 100: Blender's exporter writing metres as centimetres), so 150 m across.
TEST_CASE("mesh_import: FBX units are scaled to metres", "[io]") {
    REQUIRE(fs::exists(test::kAssimpModels / "FBX/spider.fbx"));
    MeshImportReport report;
    const TriangleMesh spider = import(test::kAssimpModels / "FBX/spider.fbx", "", &report);
    CHECK(report.unitScale == Approx(0.01));
    const Vec3 size = analyseMesh(spider).bounds.size();
    CHECK(size.x() == Approx(150.59).epsilon(1e-3));
    CHECK(size.y() == Approx(79.74).epsilon(1e-3));
    CHECK(size.z() == Approx(193.38).epsilon(1e-3));
    // Files without a unit are taken as they are.
    CHECK(import(test::kAssimpModels / "PLY/cube.ply", "", &report).triangleCount() == 12);
    CHECK(report.unitScale == 1);
}

// Every file of assimp-testmodels imports or fails with an InputError (about 20 s; run with
// dgv_tests "[sweep]").
TEST_CASE("mesh_import: sweep over every assimp test model", "[.][sweep]") {
    std::size_t imported = 0, refused = 0;
    for (const auto& e : fs::recursive_directory_iterator(test::kAssimpModels)) {
        if (!e.is_regular_file()) continue;
        try {
            import(e.path());
            ++imported;
        } catch (const InputError&) {
            ++refused;
        }
    }
    WARN("imported " << imported << ", refused " << refused);
    CHECK(imported > 300);
}
