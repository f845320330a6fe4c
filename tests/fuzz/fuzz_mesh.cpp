// libFuzzer target: mesh import through assimp. The first byte picks the file extension (so
// assimp's format detection sees every importer dgv users feed it), the rest is the file.
// Seed corpus files start with a digit: 0 obj, 1 ply, 2 stl, 3 off, 4 gltf, 5 dae, 6 3ds, 7 glb.
// Any input must import (finite coordinates, valid indices, at least one triangle) or throw
// dgv::InputError. A crash inside assimp itself is reported as such by the sanitizer trace.
#include "io/mesh_import.hpp"
#include "base/errors.hpp"

#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const char* const kExt[] = {".obj", ".ply", ".stl", ".off", ".gltf", ".dae", ".3ds", ".glb"};
    if (size < 1) return 0;
    const std::string ext = kExt[data[0] % (sizeof kExt / sizeof kExt[0])];
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("dgv_fuzz_mesh_" + std::to_string(getpid()) + ext);
    {
        std::ofstream f(path, std::ios::binary | std::ios::trunc);
        f.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
    }
    try {
        const dgv::TriangleMesh mesh = dgv::importMesh(path);
        if (mesh.triangles.empty()) std::abort();
        for (const auto& v : mesh.vertices)
            if (!dgv::allFiniteNoTrap(v)) std::abort();
        for (const auto& t : mesh.triangles)
            for (int k = 0; k < 3; ++k)
                if (t[k] < 0 || static_cast<std::size_t>(t[k]) >= mesh.vertices.size()) std::abort();
    } catch (const dgv::InputError&) {
    }
    std::filesystem::remove(path);
    return 0;
}
