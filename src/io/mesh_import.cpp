#include "io/mesh_import.hpp"

#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/read_file.hpp"
#include "io/texture.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <assimp/DefaultIOSystem.h>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>
#include <system_error>
#include <vector>

namespace dgv {

namespace fs = std::filesystem;

namespace {

/// Node hierarchies deeper than this are refused (a cycle, or a file built to exhaust the stack).
constexpr int kMaxNodeDepth = 512;
/// Instanced meshes may not expand beyond this many vertices (indices are int).
constexpr std::size_t kMaxVertices = static_cast<std::size_t>(std::numeric_limits<int>::max());

std::string str(const aiString& s) { return std::string(s.C_Str()); }

/// The checks made before assimp sees the file, so that its message is never the first word
/// on a missing path.
void checkReadable(const fs::path& path) {
    const std::string p = path.string();
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st)) throw InputError(p, "", "file not found");
    if (fs::is_directory(st)) throw InputError(p, "", "is a directory, expected a mesh file");
    if (!fs::is_regular_file(st)) throw InputError(p, "", "is not a regular file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(p, "", "cannot be opened for reading (permission denied?)");
    // A failing disk's EIO is exit 1 (RuntimeError), not assimp's complaint about the content.
    checkInputReadable(path, "mesh file");
    char byte;
    if (!in.get(byte)) throw InputError(p, "", "the file is empty");
}

/// Object File Format headers declare their vertex and face counts, and assimp 5.2 reserves
/// memory for them before reading any: a 300-byte file declaring 10^12 vertices takes tens of
/// GiB and minutes. Such headers are refused here (each vertex takes at least 6 bytes of text).
/// OFF files are validated in full before assimp sees them: assimp 5.2's OFF reader trusts the
/// header's counts and each face's vertex count, and reads out of bounds (found by fuzzing:
/// tests/fuzz) or allocates what the header claims. Checked: the counts fit the file; every
/// vertex line has at least 3 finite numbers; every face has 1..64 vertices, each index an
/// integer in [0, vertex count). Comments ('#') and blank lines are skipped as assimp does.
/// Files that are not OFF (no OFF magic and not a .off extension) are left to assimp.
void checkOffFile(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::istringstream text(bytes);
    const std::string where = path.string();
    std::size_t lineNo = 0;
    // The next non-empty, comment-stripped line as words.
    auto nextLine = [&](std::vector<std::string>& words) {
        std::string line;
        while (std::getline(text, line)) {
            ++lineNo;
            line = line.substr(0, line.find('#'));
            std::istringstream ws(line);
            words.clear();
            for (std::string w; ws >> w;) words.push_back(w);
            if (!words.empty()) return true;
        }
        return false;
    };
    auto fail = [&](const std::string& what) { throw InputError(where, "line " + std::to_string(lineNo), what); };
    std::vector<std::string> words;
    if (!nextLine(words)) {
        if (ext == ".off") throw InputError(where, "", "empty OFF file");
        return;
    }
    const std::string& magic = words[0];
    const bool offMagic = magic.size() >= 3 && magic.size() <= 6 && magic.compare(magic.size() - 3, 3, "OFF") == 0;
    if (!offMagic && ext != ".off") return;
    std::size_t first = 0;  // where the counts start in `words`
    if (offMagic && words.size() > 1)
        first = 1;  // "OFF 8 6 12"
    else if (offMagic && !nextLine(words))
        fail("the OFF header has no vertex and face counts");
    if (words.size() < first + 2) fail("expected the OFF header's vertex and face counts");
    auto count = [&](const std::string& w, const char* what) {
        if (w.empty() || w.size() > 15 || w.find_first_not_of("0123456789") != std::string::npos)
            fail(std::string("expected a ") + what + " count, got '" + w + "'");
        return static_cast<std::size_t>(std::stoull(w));
    };
    const std::size_t nv = count(words[first], "vertex");
    const std::size_t nf = count(words[first + 1], "face");
    const std::size_t size = bytes.size();
    if (nv > size / 6 || nf > size / 6)
        fail("the OFF header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
             " faces, more than a " + std::to_string(size) + "-byte file can hold");
    auto number = [&](const std::string& w, double& v) {
        char* endp = nullptr;
        v = std::strtod(w.c_str(), &endp);
        return endp && *endp == '\0' && std::isfinite(v);
    };
    for (std::size_t i = 0; i < nv; ++i) {
        if (!nextLine(words))
            fail("the file ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
        double v = 0;
        if (words.size() < 3) fail("a vertex needs 3 coordinates");
        for (int k = 0; k < 3; ++k)
            if (!number(words[static_cast<std::size_t>(k)], v))
                fail("vertex coordinate '" + words[static_cast<std::size_t>(k)] + "' is not a finite number");
    }
    for (std::size_t f = 0; f < nf; ++f) {
        if (!nextLine(words)) fail("the file ends after " + std::to_string(f) + " of " + std::to_string(nf) + " faces");
        const std::string& nw = words[0];
        if (nw.size() > 3 || nw.find_first_not_of("0123456789") != std::string::npos)
            fail("expected a face's vertex count, got '" + nw + "'");
        const std::size_t n = static_cast<std::size_t>(std::stoul(nw));
        if (n < 1 || n > 64) fail("a face with " + nw + " vertices (expected 1 to 64)");
        if (words.size() < n + 1) fail("the face lists fewer than its " + nw + " vertex indices");
        for (std::size_t k = 1; k <= n; ++k) {
            const std::string& w = words[k];
            if (w.empty() || w.size() > 15 || w.find_first_not_of("0123456789") != std::string::npos ||
                std::stoull(w) >= nv)
                fail("face vertex index '" + w + "' is not in [0, " + std::to_string(nv) + ")");
        }
    }
}

/// PLY headers are validated before assimp sees the file: assimp 5.2's PLY reader loops forever
/// on a header without `end_header` (found by fuzzing: tests/fuzz/corpus/mesh). Checked, for
/// files with the `ply` magic or a .ply extension: the magic, a `format` line naming one of the
/// three encodings, version 1.0; then `element NAME COUNT` and `property TYPE NAME` /
/// `property list TYPE TYPE NAME` lines (a property after an element, known scalar types, counts
/// that fit the file) up to `end_header`. Other lines that start with a letter (`comment`,
/// `obj_info`, Blender 2.4's `Created by Blender ...`) are skipped as assimp skips them; a line
/// that starts with a digit or other non-letter is refused (the data began without `end_header`).
void checkPlyHeader(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    std::ifstream in(path, std::ios::binary);
    char magic[4] = {0, 0, 0, 0};
    in.read(magic, 4);
    const bool plyMagic = in.gcount() == 4 && magic[0] == 'p' && magic[1] == 'l' && magic[2] == 'y' &&
                          (magic[3] == '\n' || magic[3] == '\r' || magic[3] == ' ');
    if (!plyMagic && ext != ".ply") return;
    in.clear();
    in.seekg(0, std::ios::end);
    const auto size = static_cast<std::uintmax_t>(std::max<std::streamoff>(0, in.tellg()));
    in.seekg(0);
    const std::string where = path.string();
    std::size_t lineNo = 0;
    auto fail = [&](const std::string& what) { throw InputError(where, "line " + std::to_string(lineNo), what); };
    std::vector<std::string> words;
    // Headers are short; a line or a header that is not is refused rather than read in full.
    constexpr std::size_t kMaxLine = 4096, kMaxLines = 10000;
    auto nextLine = [&]() {
        std::string line;
        if (!std::getline(in, line)) return false;
        ++lineNo;
        if (line.size() > kMaxLine) fail("a PLY header line longer than " + std::to_string(kMaxLine) + " bytes");
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream ws(line);
        words.clear();
        for (std::string w; ws >> w;) words.push_back(w);
        return true;
    };
    if (!nextLine() || words.size() != 1 || words[0] != "ply") fail("not a PLY file: the first line must be 'ply'");
    if (!nextLine() || words.size() != 3 || words[0] != "format")
        fail("expected 'format ascii|binary_little_endian|binary_big_endian 1.0' as the second line");
    if (words[1] != "ascii" && words[1] != "binary_little_endian" && words[1] != "binary_big_endian")
        fail("unknown PLY format '" + words[1] + "' (expected ascii, binary_little_endian or binary_big_endian)");
    if (words[2] != "1.0") fail("PLY version '" + words[2] + "' (only 1.0 exists)");
    static const std::set<std::string> kTypes = {"char",  "uchar",  "short",   "ushort", "int",   "uint",
                                                 "float", "double", "int8",    "uint8",  "int16", "uint16",
                                                 "int32", "uint32", "float32", "float64"};
    auto type = [&](const std::string& t) {
        if (!kTypes.count(t)) fail("unknown PLY property type '" + t + "'");
    };
    bool haveElement = false;
    std::uintmax_t total = 0;  // elements declared; each takes at least one byte
    while (true) {
        if (lineNo > kMaxLines) fail("no 'end_header' in the first " + std::to_string(kMaxLines) + " lines");
        if (!nextLine()) fail("the PLY header has no 'end_header' line");
        if (words.empty()) continue;
        const std::string& key = words[0];
        if (key == "end_header") break;
        if (key == "element") {
            if (words.size() != 3) fail("expected 'element NAME COUNT'");
            const std::string& c = words[2];
            if (c.empty() || c.size() > 15 || c.find_first_not_of("0123456789") != std::string::npos)
                fail("expected an element count, got '" + c + "'");
            total += std::stoull(c);
            if (total > size)
                fail("the PLY header declares more elements than a " + std::to_string(size) + "-byte file can hold");
            haveElement = true;
        } else if (key == "property") {
            if (!haveElement) fail("a PLY property before any element");
            if (words.size() >= 2 && words[1] == "list") {
                if (words.size() != 5) fail("expected 'property list COUNT_TYPE ITEM_TYPE NAME'");
                type(words[2]);
                type(words[3]);
            } else {
                if (words.size() != 3) fail("expected 'property TYPE NAME'");
                type(words[1]);
            }
        } else if (!std::isalpha(static_cast<unsigned char>(key[0]))) {
            fail("unexpected '" + key + "' in the PLY header (expected element, property, comment or end_header)");
        }
    }
}

/// assimp's file system, noting every file it opens (the mesh's side files: MTL, buffers, ...).
class RecordingIOSystem : public Assimp::DefaultIOSystem {
public:
    explicit RecordingIOSystem(std::vector<std::string>& files) : mFiles(files) {}
    Assimp::IOStream* Open(const char* file, const char* mode) override {
        Assimp::IOStream* stream = DefaultIOSystem::Open(file, mode);
        if (stream && file) mFiles.push_back(file);
        return stream;
    }

private:
    std::vector<std::string>& mFiles;
};

struct Collector {
    const aiScene* scene = nullptr;
    const std::string& path;
    const std::string& wanted;  ///< empty: everything
    TriangleMesh mesh;
    MeshImportReport report;
    std::size_t meshesSelected = 0;  ///< with or without triangles
    bool look = false;               ///< MeshImportOptions::materials
    bool decode = true;              ///< MeshImportOptions::decodeTextures
    /// The file's materials as read so far: its index in mesh.materials, −1 none, −2 not read yet.
    std::vector<int> materialIndex;
    /// Textures decoded, by the reference the file makes (one decode for materials sharing one).
    std::map<std::string, std::shared_ptr<const TextureImage>> textures;

    Collector(const aiScene* s, const std::string& p, const std::string& w) : scene(s), path(p), wanted(w) {}

    void addMesh(const aiMesh* m, const Mat4& worldFromMesh) {
        const std::string name = str(m->mName).empty() ? "<unnamed>" : str(m->mName);
        std::size_t triangles = 0;
        for (unsigned f = 0; f < m->mNumFaces; ++f) {
            const aiFace& face = m->mFaces[f];
            if (face.mNumIndices == 3 && face.mIndices)
                ++triangles;
            else
                ++report.nonTriangleFaces;
        }
        ++meshesSelected;
        if (triangles == 0) return;
        ++report.meshesMerged;
        if (!m->mVertices) throw InputError(path, "", "mesh '" + name + "' has faces but no vertex positions");
        if (mesh.vertices.size() + m->mNumVertices > kMaxVertices)
            throw InputError(path, "", "more than 2^31 vertices after instancing");

        const Mat3 linear = worldFromMesh.topLeftCorner<3, 3>();
        const Vec3 translation = worldFromMesh.topRightCorner<3, 1>();
        const bool flip = linear.determinant() < 0;
        const int base = static_cast<int>(mesh.vertices.size());
        for (unsigned v = 0; v < m->mNumVertices; ++v) {
            const aiVector3D& q = m->mVertices[v];
            const Vec3 local(q.x, q.y, q.z);
            if (!allFiniteNoTrap(local))
                throw InputError(path, "",
                                 "mesh '" + name + "' vertex " + std::to_string(v) + " has a non-finite coordinate");
            const Vec3 world = linear * local + translation;
            if (!allFiniteNoTrap(world))
                throw InputError(
                    path, "",
                    "mesh '" + name + "' vertex " + std::to_string(v) + " is not finite after the node transforms");
            mesh.vertices.push_back(world);
        }
        for (unsigned f = 0; f < m->mNumFaces; ++f) {
            const aiFace& face = m->mFaces[f];
            if (face.mNumIndices != 3 || !face.mIndices) continue;
            std::array<int, 3> t{};
            for (int k = 0; k < 3; ++k) {
                const unsigned idx = face.mIndices[k];
                if (idx >= m->mNumVertices)
                    throw InputError(path, "",
                                     "mesh '" + name + "' face " + std::to_string(f) + " refers to vertex " +
                                         std::to_string(idx) + ", out of range (the mesh has " +
                                         std::to_string(m->mNumVertices) + " vertices)");
                t[static_cast<std::size_t>(k)] = base + static_cast<int>(idx);
            }
            if (flip) std::swap(t[1], t[2]);
            mesh.triangles.push_back(t);
            if (look) addCornerLook(m, face, flip);
        }
    }

    /// Triangle's material and its corners' texture coordinates (zero where the mesh has none).
    void addCornerLook(const aiMesh* m, const aiFace& face, bool flip) {
        mesh.triangleMaterials.push_back(materialOf(m->mMaterialIndex));
        std::array<Eigen::Vector2f, 3> uv;
        for (std::size_t k = 0; k < 3; ++k) {
            uv[k] = Eigen::Vector2f::Zero();
            if (!m->mTextureCoords[0]) continue;
            const aiVector3D& q = m->mTextureCoords[0][face.mIndices[k]];
            if (std::isfinite(q.x) && std::isfinite(q.y)) uv[k] = Eigen::Vector2f(q.x, q.y);
        }
        if (flip) std::swap(uv[1], uv[2]);
        mesh.cornerUvs.push_back(uv);
    }

    /// The file's material `mi` in mesh.materials (read once): its base colour (glTF's factor,
    /// else the diffuse colour), its base-colour texture, roughness and metalness. −1 for assimp's
    /// stand-in for files without materials (STL, PLY, an OBJ without its MTL): no look of its own.
    int materialOf(unsigned mi) {
        if (!scene->mMaterials || mi >= scene->mNumMaterials || !scene->mMaterials[mi]) return -1;
        if (materialIndex.size() != scene->mNumMaterials) materialIndex.assign(scene->mNumMaterials, -2);
        int& id = materialIndex[mi];
        if (id != -2) return id;
        const aiMaterial* am = scene->mMaterials[mi];
        SurfaceMaterial sm;
        aiString name;
        if (am->Get(AI_MATKEY_NAME, name) == AI_SUCCESS) sm.name = str(name);
        aiColor4D c;
        if (am->Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS || am->Get(AI_MATKEY_COLOR_DIFFUSE, c) == AI_SUCCESS) {
            const Vec3 colour(c.r, c.g, c.b);
            if (allFiniteNoTrap(colour)) sm.baseColour = colour.cwiseMax(0.0).cwiseMin(1.0);
        }
        aiString ref;
        if (am->GetTexture(aiTextureType_BASE_COLOR, 0, &ref) == AI_SUCCESS ||
            am->GetTexture(aiTextureType_DIFFUSE, 0, &ref) == AI_SUCCESS)
            sm.baseColourMap = texture(str(ref), sm.name);
        float f = 0;
        if (am->Get(AI_MATKEY_ROUGHNESS_FACTOR, f) == AI_SUCCESS && std::isfinite(f))
            sm.roughness = std::clamp(static_cast<Real>(f), 0.0, 1.0);
        if (am->Get(AI_MATKEY_METALLIC_FACTOR, f) == AI_SUCCESS && std::isfinite(f))
            sm.metallic = std::clamp(static_cast<Real>(f), 0.0, 1.0);
        if (sm.name == AI_DEFAULT_MATERIAL_NAME && !sm.baseColourMap) return id = -1;
        ++report.materials;
        if (sm.baseColourMap) ++report.textures;
        id = static_cast<int>(mesh.materials.size());
        mesh.materials.push_back(std::move(sm));
        return id;
    }

    /// The texture a material names: embedded in the file ("*0", or a name the file's own
    /// textures carry), else a file beside the mesh (the reference as written, then its last
    /// component alone: files exported elsewhere often carry a folder that is not there). Null,
    /// with one warning, when it cannot be read.
    std::shared_ptr<const TextureImage> texture(const std::string& ref, const std::string& material) {
        if (ref.empty()) return nullptr;
        auto cached = textures.find(ref);
        if (cached != textures.end()) return cached->second;
        std::shared_ptr<const TextureImage>& slot = textures[ref];
        try {
            if (const aiTexture* t = scene->GetEmbeddedTexture(ref.c_str())) {
                if (decode)
                    slot = std::make_shared<const TextureImage>(embeddedTexture(*t, path + " (embedded texture " + ref + ")"));
                return slot;
            }
            const fs::path file = textureFile(ref);
            std::error_code ec;
            if (!decode) {
                if (fs::is_regular_file(file, ec)) report.filesRead.push_back(file.string());
                return slot;
            }
            slot = std::make_shared<const TextureImage>(readTexture(file));
            report.filesRead.push_back(file.string());
        } catch (const InputError& e) {
            ++report.texturesMissing;
            logWarning(path + ": material '" + material + "': texture '" + ref + "': " + e.what() +
                       "; the material is drawn in its colour");
        }
        return slot;
    }

    /// The file a texture reference names, beside the mesh: as written (`\\` read as `/`), else
    /// its last component alone, else either with another letter case (files made on Windows
    /// name `TEST.PNG` for `test.png`). The first candidate when none is there.
    fs::path textureFile(const std::string& ref) const {
        std::string written = ref;
        std::replace(written.begin(), written.end(), '\\', '/');
        const fs::path folder = fs::path(path).parent_path();
        const fs::path candidates[2] = {(folder / written).lexically_normal(), folder / fs::path(written).filename()};
        std::error_code ec;
        for (const fs::path& c : candidates)
            if (fs::is_regular_file(c, ec)) return c;
        auto lower = [](std::string t) {
            for (char& ch : t) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
            return t;
        };
        for (const fs::path& c : candidates) {
            const std::string want = lower(c.filename().string());
            for (fs::directory_iterator it(c.parent_path(), ec), end; !ec && it != end; it.increment(ec))
                if (it->is_regular_file(ec) && lower(it->path().filename().string()) == want) return it->path();
        }
        return candidates[0];
    }

    /// An embedded texture: compressed bytes (PNG, JPEG, ...; mHeight 0) or raw BGRA texels.
    static TextureImage embeddedTexture(const aiTexture& t, const std::string& source) {
        if (!t.pcData) throw InputError(source, "", "no data");
        if (t.mHeight == 0) return decodeTexture(reinterpret_cast<const unsigned char*>(t.pcData), t.mWidth, source);
        if (t.mWidth > static_cast<unsigned>(kMaxTextureSide) || t.mHeight > static_cast<unsigned>(kMaxTextureSide))
            throw InputError(source, "", "larger than " + std::to_string(kMaxTextureSide) + " pixels on a side");
        TextureImage image;
        image.width = static_cast<int>(t.mWidth);
        image.height = static_cast<int>(t.mHeight);
        image.source = source;
        const std::size_t n = static_cast<std::size_t>(t.mWidth) * t.mHeight;
        image.rgba.resize(4 * n);
        for (std::size_t p = 0; p < n; ++p) {
            const aiTexel& q = t.pcData[p];
            image.rgba[4 * p] = q.r;
            image.rgba[4 * p + 1] = q.g;
            image.rgba[4 * p + 2] = q.b;
            image.rgba[4 * p + 3] = q.a;
        }
        return image;
    }

    void walk(const aiNode* node, const Mat4& parent, bool selected, int depth) {
        if (!node) return;
        if (depth > kMaxNodeDepth)
            throw InputError(
                path, "", "the node hierarchy is deeper than " + std::to_string(kMaxNodeDepth) + " levels (a cycle?)");
        const aiMatrix4x4& a = node->mTransformation;
        Mat4 local;
        local << a.a1, a.a2, a.a3, a.a4, a.b1, a.b2, a.b3, a.b4, a.c1, a.c2, a.c3, a.c4, a.d1, a.d2, a.d3, a.d4;
        if (!allFiniteNoTrap(local))
            throw InputError(path, "", "node '" + str(node->mName) + "' has a non-finite transform");
        const Mat4 world = parent * local;
        const bool nodeSelected = selected || (!wanted.empty() && str(node->mName) == wanted);
        for (unsigned i = 0; i < node->mNumMeshes; ++i) {
            const unsigned mi = node->mMeshes ? node->mMeshes[i] : scene->mNumMeshes;
            if (mi >= scene->mNumMeshes || !scene->mMeshes[mi])
                throw InputError(path, "", "node '" + str(node->mName) + "' refers to a mesh that does not exist");
            const aiMesh* m = scene->mMeshes[mi];
            if (wanted.empty() || nodeSelected || str(m->mName) == wanted) addMesh(m, world);
        }
        if (node->mNumChildren > 0 && !node->mChildren) return;
        for (unsigned i = 0; i < node->mNumChildren; ++i) walk(node->mChildren[i], world, nodeSelected, depth + 1);
    }

    void collectNames(const aiNode* node, std::set<std::string>& names, int depth) const {
        if (!node || depth > kMaxNodeDepth) return;
        if (node->mName.length > 0) names.insert(str(node->mName));
        if (!node->mChildren) return;
        for (unsigned i = 0; i < node->mNumChildren; ++i) collectNames(node->mChildren[i], names, depth + 1);
    }

    std::string availableNames() const {
        std::set<std::string> names;
        for (unsigned i = 0; i < scene->mNumMeshes; ++i)
            if (scene->mMeshes[i] && scene->mMeshes[i]->mName.length > 0) names.insert(str(scene->mMeshes[i]->mName));
        collectNames(scene->mRootNode, names, 0);
        if (names.empty()) return "the file names no meshes or nodes";
        std::string list;
        int shown = 0;
        for (const std::string& n : names) {
            if (shown == 30) {
                list += ", ... (" + std::to_string(names.size() - 30) + " more)";
                break;
            }
            list += (shown++ ? ", '" : "'") + n + "'";
        }
        return "available: " + list;
    }
};

/// Merges vertices at exactly the same position (after the node transforms) and drops those no
/// triangle uses, so that a mesh split into pieces (STL, per-face normals) is closed again.
void weldByPosition(TriangleMesh& mesh) {
    const std::vector<int> rep = samePositionRepresentatives(mesh.vertices);
    const std::size_t n = mesh.vertices.size();
    // New ids in order of first use by the triangles: deterministic and cache-friendly.
    std::vector<int> newId(n, -1);
    std::vector<Vec3> vertices;
    for (auto& t : mesh.triangles) {
        for (int& v : t) {
            const int r = rep[static_cast<std::size_t>(v)];
            int& id = newId[static_cast<std::size_t>(r)];
            if (id < 0) {
                id = static_cast<int>(vertices.size());
                vertices.push_back(mesh.vertices[static_cast<std::size_t>(r)]);
            }
            v = id;
        }
    }
    mesh.vertices = std::move(vertices);
}

/// Metres per file unit from the FBX global setting assimp passes on as scene metadata:
/// "UnitScaleFactor", the file's centimetres per unit (1: centimetres, 100: metres). 1 when the
/// file has none (every other format: assimp's Collada reader applies <unit> itself, glTF is in
/// metres) or when the value is not a finite positive number.
double unitScaleOf(const aiScene* scene) {
    const aiMetadata* meta = scene->mMetaData;
    if (!meta) return 1;
    double cm = 0;
    float f = 0;
    if (!meta->Get("UnitScaleFactor", cm)) {
        if (!meta->Get("UnitScaleFactor", f)) return 1;
        cm = f;
    }
    return std::isfinite(cm) && cm > 0 ? cm / 100 : 1;
}

}  // namespace

std::string unlikelySizeWarning(const TriangleMesh& mesh, const std::string& what, bool fromFile) {
    if (mesh.vertices.empty()) return "";
    Vec3 lo = mesh.vertices[0], hi = lo;
    for (const Vec3& v : mesh.vertices) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
    }
    const Real size = (hi - lo).maxCoeff();
    // Far from the origin for its size: a mesh file's floats (and the renderer's) keep about 7
    // digits, so the surface is stepped at distance × 1e-7 (a 0.5 m ball 1e6 m out lost its
    // closure and gained 1.4 % of its volume).
    const Real far = ((hi + lo) / 2).norm();
    char line[300];
    if (!fromFile && (size > 1e6 || size < 1e-6)) {
        // A primitive is given in metres: only sizes past what the renderer's floats resolve.
        std::snprintf(line, sizeof line,
                      " is %.3g m across: the renderer's floats resolve 1e-6 to 1e6 m objects; set its size in metres",
                      size);
    } else if (fromFile && size > 100) {
        std::snprintf(line, sizeof line,
                      " is %.4g m across: is the file in centimetres or millimetres? transform.units \"cm\" or "
                      "\"mm\" reads it so (or transform.scale)",
                      size);
    } else if (fromFile && size < 1e-3) {
        std::snprintf(line, sizeof line,
                      " is %.3g m across, under a millimetre: is the file in another unit? transform.units "
                      "(\"m\", \"cm\", \"mm\", \"in\", \"ft\" or metres per unit) or transform.scale sets it",
                      size);
    } else if (far > 1e4 * size) {
        std::snprintf(line, sizeof line,
                      " lies %.3g m from the origin, %.3g times its size: floats keep about 7 digits, so its "
                      "surface is stepped at ~%.2g m there; move the scene near the origin",
                      far, far / size, far * 1.2e-7);
    } else {
        return "";
    }
    return what + line;
}

TriangleMesh importMesh(const fs::path& path, const MeshImportOptions& options, MeshImportReport* report) {
    const std::string p = path.string();
    checkReadable(path);
    checkOffFile(path);
    checkPlyHeader(path);

    Assimp::DefaultLogger::kill();  // the null logger: assimp prints nothing
    std::vector<std::string> opened{p};  // outlives the importer and its file system
    Assimp::Importer importer;
    importer.SetIOHandler(new RecordingIOSystem(opened));  // the importer owns it
    // Positions (and, with the materials, texture coordinates and embedded textures) are all
    // dgv uses: drop the rest before post-processing so that vertices that differ only in
    // normals are joined, and less memory is spent. UV seams are kept per corner (addCornerLook).
    const int lookComponents = options.materials ? 0 : (aiComponent_TEXCOORDS | aiComponent_TEXTURES);
    importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                                aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                    aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS | aiComponent_LIGHTS |
                                    aiComponent_CAMERAS | lookComponents);
    // Read without post-processing, drop what dgv ignores (lights and cameras without nodes
    // would fail validation), then validate and triangulate.
    const unsigned flags = aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                           aiProcess_SortByPType;
    const aiScene* scene = nullptr;
    try {
        scene = importer.ReadFile(p, 0);
        if (scene) scene = importer.ApplyPostProcessing(aiProcess_RemoveComponent);
        if (scene) scene = importer.ApplyPostProcessing(flags);
    } catch (const std::exception& e) {
        throw InputError(p, "", "assimp could not read it: " + libraryMessage(e.what()));
    } catch (...) {
        throw InputError(p, "", "assimp could not read it: unknown error");
    }
    if (!scene) {
        std::string why = importer.GetErrorString();
        std::replace(why.begin(), why.end(), '\n', ' ');
        while (!why.empty() && why.back() == ' ') why.pop_back();
        // Validation's words for a scene without faces, in dgv's.
        if (why.find("contains no faces") != std::string::npos || why.find("has no faces") != std::string::npos)
            throw InputError(p, "", "no triangles (the file holds only points and lines)");
        if (why.find("mNumMeshes is 0") != std::string::npos)
            throw InputError(p, "", "no triangles (the file holds no meshes)");
        throw InputError(p, "", "assimp could not read it: " + (why.empty() ? "unknown error" : libraryMessage(why)));
    }

    // The file's unit scale comes before its node transforms (and so before a scene's transform).
    const double fileScale = unitScaleOf(scene);
    const double unitScale = options.unitScale > 0 ? options.unitScale : fileScale;
    Mat4 root = Mat4::Identity();
    root.topLeftCorner<3, 3>() *= unitScale;
    if (options.unitScale > 0) {
        if (fileScale != 1 && fileScale != unitScale && options.logUnitScale) {
            char line[200];
            std::snprintf(line, sizeof line, "the file's unit is %.6g m; transform.units makes it %.6g m", fileScale,
                          unitScale);
            logInfo(p + ": " + line);
        }
    } else if (unitScale != 1 && options.logUnitScale) {
        char line[200];
        std::snprintf(line, sizeof line,
                      "the file's unit is %.6g m (FBX UnitScaleFactor %.6g); scaled by %.6g to metres", unitScale,
                      unitScale * 100, unitScale);
        logInfo(p + ": " + line);
    }
    Collector c(scene, p, options.meshName);
    c.look = options.materials;
    c.decode = options.decodeTextures;
    c.report.unitScale = unitScale;
    if (scene->mRootNode) {
        c.walk(scene->mRootNode, root, false, 0);
    } else {
        for (unsigned i = 0; i < scene->mNumMeshes; ++i)
            if (scene->mMeshes[i] && (options.meshName.empty() || str(scene->mMeshes[i]->mName) == options.meshName))
                c.addMesh(scene->mMeshes[i], root);
    }

    if (!options.meshName.empty() && c.meshesSelected == 0)
        throw InputError(p, "", "no mesh or node named '" + options.meshName + "'; " + c.availableNames());
    if (c.mesh.triangles.empty()) {
        if (c.report.nonTriangleFaces > 0)
            throw InputError(p, "", "no triangles (the file holds only points and lines)");
        throw InputError(p, "", "no triangles (the file holds no meshes)");
    }

    TriangleMesh mesh = std::move(c.mesh);
    if (mesh.materials.empty()) mesh.clearMaterials();  // nothing of its own: the object's colour
    weldByPosition(mesh);
    const std::size_t before = mesh.triangles.size();
    c.report.degenerateDropped = dropDegenerateTriangles(mesh);
    if (mesh.triangles.empty())
        throw InputError(p, "", "no triangles (all " + std::to_string(before) + " triangles are degenerate)");
    if (options.orientOutward) {
        c.report.orientation = orientOutward(mesh);
        const OrientReport& o = c.report.orientation;
        if (o.flippedParts > 0) {
            char line[200];
            if (o.parts == 1)
                std::snprintf(line, sizeof line,
                              "the mesh is inside out (signed volume %.4g); its triangles were turned around",
                              o.volumeBefore);
            else
                std::snprintf(line, sizeof line,
                              "%zu of its %zu parts are inside out; their triangles were turned around", o.flippedParts,
                              o.parts);
            logWarning(p + ": " + line);
        }
    }
    if (report) {
        *report = c.report;
        report->filesRead.insert(report->filesRead.end(), opened.begin(), opened.end());
        for (std::string& f : report->filesRead) f = fs::absolute(f).lexically_normal().string();
        std::sort(report->filesRead.begin(), report->filesRead.end());
        report->filesRead.erase(std::unique(report->filesRead.begin(), report->filesRead.end()),
                                report->filesRead.end());
    }
    return mesh;
}

}  // namespace dgv
