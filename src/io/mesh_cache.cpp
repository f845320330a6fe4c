#include "io/mesh_cache.hpp"

#include "base/errors.hpp"
#include "base/image.hpp"
#include "geom/triangle_mesh.hpp"
#include "io/atomic_file.hpp"

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
    throw InputError(where, "", "expected ply or obj, got \"" + name + "\"");
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
    if (format == MeshCacheFormat::Ply) {
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
        o << "# dgv mesh cache: object " << f.object << "\n# dgv_frame " << f.frame << "\n# dgv_key " << f.key << "\n";
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
    const std::string prefix = format == MeshCacheFormat::Ply ? "comment " : "# ";
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
    if (format == MeshCacheFormat::Ply) {
        if (!ended || size != headerBytes + vertices * kPlyVertexBytes + faces * kPlyFaceBytes) return "is truncated";
        return "";
    }
    // OBJ: the last line is the end line.
    const std::size_t tail = std::strlen(kObjEnd) + 1;
    if (size < tail) return "is truncated";
    in.clear();
    in.seekg(static_cast<std::streamoff>(size - tail));
    std::string last;
    std::getline(in, last);
    return last == kObjEnd ? "" : "is truncated";
}

}  // namespace dgv
