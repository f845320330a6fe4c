#include "io/mesh_cache.hpp"

#include "base/errors.hpp"
#include "base/image.hpp"
#include "geom/triangle_mesh.hpp"
#include "io/atomic_file.hpp"
#include "io/checksum.hpp"
#include "io/read_file.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace dgv {

namespace fs = std::filesystem;

namespace {

constexpr const char* kObjEnd = "# end of dgv mesh cache frame";

/// Bytes per vertex and per face of the binary PLY this module writes.
constexpr std::size_t kPlyVertexBytes = 6 * 4 + 3 + 4, kPlyFaceBytes = 1 + 3 * 4;

std::string plyHeader(const MeshCacheFrame& f, std::size_t vertices, std::size_t faces) {
    std::ostringstream h;
    h << "ply\nformat binary_little_endian 1.0\n"
      << "comment dgv mesh cache: object " << f.object << "\n"
      << "comment dgv_frame " << f.frame << "\n"
      << "comment dgv_key " << f.key << "\n"
      << "comment " << checksumPlaceholder() << "\n"
      << "element vertex " << vertices << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property float nx\nproperty float ny\nproperty float nz\n"
      << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      << "property float contact\n"
      << "element face " << faces << "\n"
      << "property list uchar int vertex_indices\n"
      << "end_header\n";
    return h.str();
}

void putFloat(std::string& out, Real v) {
    const float f = static_cast<float>(v);
    unsigned char b[4];
    std::memcpy(b, &f, 4);  // little-endian hosts (x86-64, arm64)
    out.append(reinterpret_cast<const char*>(b), 4);
}

void putInt(std::string& out, int v) {
    unsigned char b[4];
    std::memcpy(b, &v, 4);
    out.append(reinterpret_cast<const char*>(b), 4);
}

}  // namespace

MeshCacheFormat meshCacheFormatFromName(const std::string& name, const std::string& where) {
    if (name == "ply") return MeshCacheFormat::Ply;
    if (name == "obj") return MeshCacheFormat::Obj;
    if (name == "gltf") return MeshCacheFormat::Gltf;
    throw InputError(where, "", "expected ply, obj or gltf, got \"" + name + "\"");
}

const char* meshCacheExtension(MeshCacheFormat format) { return format == MeshCacheFormat::Obj ? "obj" : "ply"; }

fs::path meshCachePath(const fs::path& dir, const std::string& object, int frame, MeshCacheFormat format) {
    char num[32];
    std::snprintf(num, sizeof num, "%04d", frame);
    return dir / (object + "." + num + "." + meshCacheExtension(format));
}

void writeMeshCacheFrame(const fs::path& path, MeshCacheFormat format, const MeshCacheFrame& f) {
    const std::vector<Vec3>& x = *f.positions;
    const std::vector<std::array<int, 3>>& tris = *f.triangles;
    const std::vector<Vec3> n = vertexNormals(x, tris);
    std::string out;
    if (format != MeshCacheFormat::Obj) {
        out = plyHeader(f, x.size(), tris.size());
        out.reserve(out.size() + x.size() * kPlyVertexBytes + tris.size() * kPlyFaceBytes);
        unsigned char rgb[3];
        for (int c = 0; c < 3; ++c) rgb[c] = static_cast<unsigned char>(std::lround(255 * encodeSrgb(f.colour[c])));
        for (std::size_t v = 0; v < x.size(); ++v) {
            for (int c = 0; c < 3; ++c) putFloat(out, x[v][c]);
            for (int c = 0; c < 3; ++c) putFloat(out, n[v][c]);
            out.append(reinterpret_cast<const char*>(rgb), 3);
            putFloat(out, f.contact && v < f.contact->size() ? (*f.contact)[v] : Real(0));
        }
        for (const auto& t : tris) {
            out.push_back(3);
            for (int k = 0; k < 3; ++k) putInt(out, t[k]);
        }
    } else {
        std::ostringstream o;
        o << "# dgv mesh cache: object " << f.object << "\n# dgv_frame " << f.frame << "\n# dgv_key " << f.key << "\n# "
          << checksumPlaceholder() << "\n";
        char line[128];
        for (const Vec3& p : x) {
            std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", p.x(), p.y(), p.z());
            o << line;
        }
        for (const Vec3& p : n) {
            std::snprintf(line, sizeof line, "vn %.6g %.6g %.6g\n", p.x(), p.y(), p.z());
            o << line;
        }
        for (const auto& t : tris)
            o << "f " << t[0] + 1 << "//" << t[0] + 1 << " " << t[1] + 1 << "//" << t[1] + 1 << " " << t[2] + 1 << "//"
              << t[2] + 1 << "\n";
        o << kObjEnd << "\n";
        out = o.str();
    }
    sealChecksum(out);
    writeTextAtomically(path, out);
}

std::string meshCacheFileProblem(const fs::path& path, MeshCacheFormat format, int frame, const std::string& key) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return "is missing";
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) return "cannot be read";
    std::ifstream in(path, std::ios::binary);
    std::string line, gotFrame, gotKey;
    std::size_t vertices = 0, faces = 0, headerBytes = 0;
    bool ended = false;
    const bool ply = format != MeshCacheFormat::Obj;
    const std::string prefix = ply ? "comment " : "# ";
    for (int lines = 0; std::getline(in, line) && lines < 64; ++lines) {
        headerBytes += line.size() + 1;
        if (line.rfind(prefix + "dgv_frame ", 0) == 0)
            gotFrame = line.substr(prefix.size() + 10);
        else if (line.rfind(prefix + "dgv_key ", 0) == 0)
            gotKey = line.substr(prefix.size() + 8);
        else if (line.rfind("element vertex ", 0) == 0)
            vertices = std::strtoull(line.c_str() + 15, nullptr, 10);
        else if (line.rfind("element face ", 0) == 0)
            faces = std::strtoull(line.c_str() + 13, nullptr, 10);
        else if (line == "end_header") {
            ended = true;
            break;
        }
        if (format == MeshCacheFormat::Obj && !gotKey.empty()) break;
    }
    if (gotFrame != std::to_string(frame))
        return gotFrame.empty() ? "has no dgv frame (not written by dgv)" : "holds frame " + gotFrame;
    if (gotKey != key) return "is of another version of the scene";
    if (ply) {
        if (!ended || size != headerBytes + vertices * kPlyVertexBytes + faces * kPlyFaceBytes) return "is truncated";
        return fileChecksumProblem(path);  // the seal: any other byte changed
    }
    // OBJ: the last line is the end line.
    const std::size_t tail = std::strlen(kObjEnd) + 1;
    if (size < tail) return "is truncated";
    in.clear();
    in.seekg(static_cast<std::streamoff>(size - tail));
    std::string last;
    std::getline(in, last);
    return last == kObjEnd ? fileChecksumProblem(path) : "is truncated";
}

MeshCacheData readMeshCacheFrame(const fs::path& path) {
    const std::string bytes = readInputFile(path, "mesh cache frame", std::uintmax_t(1) << 34);
    auto bad = [&](const std::string& why) -> MeshCacheData {
        throw RuntimeError(path.string() + ": not a dgv mesh cache frame (" + why + ")");
    };
    const std::size_t end = bytes.find("end_header\n");
    if (bytes.rfind("ply\nformat binary_little_endian 1.0\n", 0) != 0 || end == std::string::npos)
        return bad("no binary PLY header");
    // The header must be the one plyHeader writes, but for its counts and comments.
    std::size_t vertices = 0, faces = 0;
    std::istringstream header(bytes.substr(0, end));
    std::string line, layout;
    while (std::getline(header, line)) {
        if (line.rfind("comment ", 0) == 0) continue;
        if (line.rfind("element vertex ", 0) == 0) {
            vertices = std::strtoull(line.c_str() + 15, nullptr, 10);
            line = "element vertex";
        } else if (line.rfind("element face ", 0) == 0) {
            faces = std::strtoull(line.c_str() + 13, nullptr, 10);
            line = "element face";
        }
        layout += line + "\n";
    }
    MeshCacheFrame probe;
    std::string expected;
    {
        std::istringstream h(plyHeader(probe, 0, 0));
        while (std::getline(h, line)) {
            if (line.rfind("comment ", 0) == 0 || line == "end_header") continue;
            if (line.rfind("element vertex", 0) == 0) line = "element vertex";
            if (line.rfind("element face", 0) == 0) line = "element face";
            expected += line + "\n";
        }
    }
    if (layout != expected) return bad("another PLY layout");
    const std::size_t body = end + 11;
    if (bytes.size() != body + vertices * kPlyVertexBytes + faces * kPlyFaceBytes) return bad("truncated");
    MeshCacheData d;
    d.positions.resize(vertices);
    d.normals.resize(vertices);
    d.contact.resize(vertices);
    const char* p = bytes.data() + body;
    auto getFloat = [&]() {
        float f;
        std::memcpy(&f, p, 4);
        p += 4;
        return f;
    };
    for (std::size_t v = 0; v < vertices; ++v) {
        for (int c = 0; c < 3; ++c) d.positions[v][c] = getFloat();
        for (int c = 0; c < 3; ++c) d.normals[v][c] = getFloat();
        if (v == 0)
            for (int c = 0; c < 3; ++c) d.colour[c] = decodeSrgb(static_cast<unsigned char>(p[c]) / 255.0);
        p += 3;
        d.contact[v] = getFloat();
    }
    d.triangles.resize(faces);
    for (std::size_t t = 0; t < faces; ++t) {
        if (*p++ != 3) return bad("a face that is not a triangle");
        for (int k = 0; k < 3; ++k) {
            int i;
            std::memcpy(&i, p, 4);
            p += 4;
            if (i < 0 || static_cast<std::size_t>(i) >= vertices) return bad("a vertex index out of range");
            d.triangles[t][k] = i;
        }
    }
    return d;
}

}  // namespace dgv
