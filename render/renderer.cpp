#include "render/renderer.hpp"

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "render/gl_context.hpp"
#include "render/shader_program.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#include <Eigen/Geometry>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <numeric>

namespace dgv {

namespace fs = std::filesystem;
using render::GlContext;
using render::ShaderProgram;

namespace {

constexpr int kShadowMapSize = 2048;
constexpr int kMaxTextureSize = 16384;
/// The texture unit of a material's base-colour map (0: the shadow map, 2: the ground's marks,
/// 3: the shadow map's depths).
constexpr int kBaseColourUnit = 4;

/// The Blinn-Phong exponent whose lobe matches a GGX highlight of perceptual roughness r
/// (α = r², s = 2/α² − 2), kept within 2..4096 so a mirror stays a small bright spot.
double shininessOfRoughness(double r) {
    const double alpha = std::max(r * r, 1e-3);
    return std::clamp(2.0 / (alpha * alpha) - 2.0, 2.0, 4096.0);
}

/// IEEE half (binary16) bits -> float (subnormals, infinities and NaN included).
float halfToFloat(std::uint16_t h) {
    const int sign = h >> 15, exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
    float v;
    if (exponent == 0)
        v = std::ldexp(static_cast<float>(mantissa), -24);
    else if (exponent == 31)
        v = mantissa ? std::numeric_limits<float>::quiet_NaN() : std::numeric_limits<float>::infinity();
    else
        v = std::ldexp(static_cast<float>(mantissa | 0x400), exponent - 25);
    return sign ? -v : v;
}

bool hasGlExtension(const char* name) {
    GLint count = 0;
    glGetIntegerv(GL_NUM_EXTENSIONS, &count);
    for (GLint i = 0; i < count; ++i) {
        const auto* e = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
        if (e && std::strcmp(e, name) == 0) return true;
    }
    return false;
}

bool hasShaders(const fs::path& dir) {
    std::error_code ec;
    return fs::is_regular_file(dir / "mesh.vert", ec) && fs::is_regular_file(dir / "mesh.frag", ec);
}

/// Column-major float copy of an Eigen double matrix, for glUniformMatrix4fv.
struct Mat4f {
    float v[16];
    explicit Mat4f(const Mat4& m) {
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) v[c * 4 + r] = static_cast<float>(m(r, c));
    }
};

void setMat4(const ShaderProgram& p, const char* name, const Mat4& m) {
    Mat4f f(m);
    glUniformMatrix4fv(p.uniform(name), 1, GL_FALSE, f.v);
}
void setVec3(const ShaderProgram& p, const char* name, const Vec3& v) {
    glUniform3f(p.uniform(name), static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
}
void setFloat(const ShaderProgram& p, const char* name, double v) {
    glUniform1f(p.uniform(name), static_cast<float>(v));
}
void setInt(const ShaderProgram& p, const char* name, int v) { glUniform1i(p.uniform(name), v); }

Mat4 orthographic(Real l, Real r, Real b, Real t, Real n, Real f) {
    Mat4 m = Mat4::Identity();
    m(0, 0) = 2 / (r - l);
    m(1, 1) = 2 / (t - b);
    m(2, 2) = -2 / (f - n);
    m(0, 3) = -(r + l) / (r - l);
    m(1, 3) = -(t + b) / (t - b);
    m(2, 3) = -(f + n) / (f - n);
    return m;
}

/// GPU buffers of one mesh, kept across frames and grown when needed.
struct MeshSlot {
    GLuint vao = 0, vbo = 0, ebo = 0;
    std::size_t vboCapacity = 0;  // bytes
    std::size_t eboCapacity = 0;  // bytes
    GLsizei indexCount = 0;
    // Topology cache, rebuilt only when the triangle list (or the crease angle) changes: the
    // triangles last seen, the render vertices (a mesh vertex is split into one render vertex
    // per smoothing group around it), the triangles over render vertices, and the render
    // vertex -> triangle map (CSR) used to sum the area-weighted normals in a fixed order.
    std::vector<std::array<int, 3>> triangles;
    std::size_t vertexCount = 0;
    double creaseDegrees = -1;
    bool closed = false;            // every edge shared by exactly 2 opposite triangles
    bool inverted = false;          // closed but CW from outside (negative volume)
    std::vector<int> triangleMaterials;  // the look as last seen (DrawMesh), part of the topology
    std::vector<std::array<Eigen::Vector2f, 3>> cornerUvs;
    std::vector<int> sourceVertex;  // render vertex -> mesh vertex
    std::vector<int> normalGroup;   // render vertex -> its smoothing group (normals are per group)
    std::vector<Eigen::Vector2f> renderUv;  // render vertex -> texture coordinate (empty: none)
    std::vector<std::array<int, 3>> renderTriangles;  // in the index buffer's order (by material)
    std::vector<int> adjacencyStart;  // smoothing group -> range in `adjacency`
    std::vector<int> adjacency;       // triangles of the group
    std::vector<float> interleaved;   // position xyz, normal xyz, scalar, uv per render vertex
    std::vector<Vec3f> faceNormals;   // area-weighted (cross product of two edges)
    /// The index buffer's runs of one material (−1: the mesh's colour), in material order.
    struct Range {
        int material = -1;
        GLsizei first = 0, count = 0;  // in indices
    };
    std::vector<Range> ranges;
};

/// True when every directed edge (a, b) of the triangles is matched by exactly one (b, a) and
/// appears once: a closed, consistently oriented 2-manifold, whose back faces are never seen.
bool isClosedOriented(const std::vector<std::array<int, 3>>& triangles) {
    if (triangles.empty()) return false;
    std::vector<std::pair<int, int>> edges;
    edges.reserve(triangles.size() * 3);
    for (const auto& t : triangles)
        for (int k = 0; k < 3; ++k) edges.emplace_back(t[k], t[(k + 1) % 3]);
    std::sort(edges.begin(), edges.end());
    if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;
    for (const auto& [a, b] : edges)
        if (a == b || !std::binary_search(edges.begin(), edges.end(), std::make_pair(b, a))) return false;
    return true;
}

/// The index buffer (slot.renderTriangles) from the triangles over render vertices, in runs of
/// one material (stable: triangle order within a run), and the runs (slot.ranges).
void orderByMaterial(MeshSlot& slot, const std::vector<std::array<int, 3>>& byTriangle) {
    const std::size_t nt = byTriangle.size();
    slot.ranges.clear();
    const bool materials = slot.triangleMaterials.size() == nt;
    std::vector<std::size_t> order(nt);
    std::iota(order.begin(), order.end(), std::size_t{0});
    if (materials)
        std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return slot.triangleMaterials[a] < slot.triangleMaterials[b];
        });
    slot.renderTriangles.resize(nt);
    for (std::size_t i = 0; i < nt; ++i) {
        slot.renderTriangles[i] = byTriangle[order[i]];
        const int m = materials ? slot.triangleMaterials[order[i]] : -1;
        if (slot.ranges.empty() || slot.ranges.back().material != m)
            slot.ranges.push_back({m, static_cast<GLsizei>(3 * i), 0});
        slot.ranges.back().count += 3;
    }
}

/// Splits mesh vertices along crease edges. Around each vertex, two triangles that share an
/// edge through it belong to the same smoothing group when the angle between their face
/// normals is at most `creaseDegrees`; each group becomes one render vertex, whose normal is
/// the area-weighted sum over the group. Groups are numbered by their first triangle in the
/// vertex's (ascending) triangle list, render vertices by (mesh vertex, group): deterministic.
/// `faceNormals` are the unnormalised normals of the positions the split is decided on.
void buildRenderTopology(MeshSlot& slot, std::size_t nv, const std::vector<Vec3f>& faceNormals, double creaseDegrees) {
    const auto& tris = slot.triangles;
    const std::size_t nt = tris.size();
    // mesh vertex -> incident triangles, ascending
    std::vector<int> start(nv + 1, 0);
    for (const auto& t : tris)
        for (int k = 0; k < 3; ++k) ++start[static_cast<std::size_t>(t[k]) + 1];
    for (std::size_t i = 0; i < nv; ++i) start[i + 1] += start[i];
    std::vector<int> fan(static_cast<std::size_t>(start[nv]));
    {
        std::vector<int> fill(start.begin(), start.end() - 1);
        for (std::size_t f = 0; f < nt; ++f)
            for (int k = 0; k < 3; ++k)
                fan[static_cast<std::size_t>(fill[static_cast<std::size_t>(tris[f][k])]++)] = static_cast<int>(f);
    }
    const bool split = creaseDegrees < 180.0;
    const float cosCrease = static_cast<float>(std::cos(creaseDegrees * 3.14159265358979323846 / 180.0));
    // Per corner (f, k): the group index of triangle f around its vertex t[k].
    std::vector<int> cornerGroup(nt * 3, 0);
    std::vector<int> groupCount(nv, 1);
    if (split) {
        std::vector<int> parent;
        for (std::size_t v = 0; v < nv; ++v) {
            const int b = start[v], e = start[v + 1], n = e - b;
            if (n <= 1) continue;
            parent.resize(static_cast<std::size_t>(n));
            for (int i = 0; i < n; ++i) parent[static_cast<std::size_t>(i)] = i;
            auto find = [&](int i) {
                while (parent[static_cast<std::size_t>(i)] != i) i = parent[static_cast<std::size_t>(i)];
                return i;
            };
            for (int i = 0; i < n; ++i) {
                const auto& ti = tris[static_cast<std::size_t>(fan[static_cast<std::size_t>(b + i)])];
                const Vec3f ni = faceNormals[static_cast<std::size_t>(fan[static_cast<std::size_t>(b + i)])];
                for (int j = i + 1; j < n; ++j) {
                    const auto& tj = tris[static_cast<std::size_t>(fan[static_cast<std::size_t>(b + j)])];
                    // Do they share an edge through v (another common vertex)?
                    bool shareEdge = false;
                    for (int a = 0; a < 3 && !shareEdge; ++a)
                        if (ti[a] != static_cast<int>(v))
                            for (int c = 0; c < 3; ++c)
                                if (tj[c] == ti[a]) shareEdge = true;
                    if (!shareEdge) continue;
                    const Vec3f nj = faceNormals[static_cast<std::size_t>(fan[static_cast<std::size_t>(b + j)])];
                    const float li = ni.norm(), lj = nj.norm();
                    // Degenerate triangles join any group (they add nothing to the normal).
                    const bool smooth = !(li > 0 && lj > 0) || ni.dot(nj) >= cosCrease * li * lj;
                    if (smooth) {
                        const int ri = find(i), rj = find(j);
                        if (ri != rj) parent[static_cast<std::size_t>(std::max(ri, rj))] = std::min(ri, rj);
                    }
                }
            }
            // Number the groups by first appearance; record each corner's group.
            std::vector<int> label(static_cast<std::size_t>(n), -1);
            int groups = 0;
            for (int i = 0; i < n; ++i) {
                const int r = find(i);
                if (label[static_cast<std::size_t>(r)] < 0) label[static_cast<std::size_t>(r)] = groups++;
                const int f = fan[static_cast<std::size_t>(b + i)];
                for (int k = 0; k < 3; ++k)
                    if (tris[static_cast<std::size_t>(f)][k] == static_cast<int>(v))
                        cornerGroup[static_cast<std::size_t>(f) * 3 + static_cast<std::size_t>(k)] =
                            label[static_cast<std::size_t>(r)];
            }
            groupCount[v] = groups;
        }
    }
    // Smoothing groups: (v, group) in order. A render vertex is a group's corners with one
    // texture coordinate: a UV seam splits the vertex but not its normal.
    std::vector<int> firstGroup(nv + 1, 0);
    for (std::size_t v = 0; v < nv; ++v) firstGroup[v + 1] = firstGroup[v] + groupCount[v];
    const std::size_t ng = static_cast<std::size_t>(firstGroup[nv]);
    const bool uvs = slot.cornerUvs.size() == nt;
    std::vector<int> cornerRender(nt * 3);
    slot.sourceVertex.clear();
    slot.normalGroup.clear();
    slot.renderUv.clear();
    if (!uvs) {
        slot.sourceVertex.resize(ng);
        slot.normalGroup.resize(ng);
        for (std::size_t v = 0; v < nv; ++v)
            for (int g = 0; g < groupCount[v]; ++g) {
                const std::size_t r = static_cast<std::size_t>(firstGroup[v] + g);
                slot.sourceVertex[r] = static_cast<int>(v);
                slot.normalGroup[r] = static_cast<int>(r);
            }
        for (std::size_t c = 0; c < nt * 3; ++c)
            cornerRender[c] = firstGroup[static_cast<std::size_t>(tris[c / 3][c % 3])] + cornerGroup[c];
    } else {
        for (std::size_t v = 0; v < nv; ++v) {
            const std::size_t first = slot.sourceVertex.size();
            for (int a = start[v]; a < start[v + 1]; ++a) {
                const std::size_t f = static_cast<std::size_t>(fan[static_cast<std::size_t>(a)]);
                for (std::size_t k = 0; k < 3; ++k) {
                    if (tris[f][k] != static_cast<int>(v)) continue;
                    const int g = firstGroup[v] + cornerGroup[f * 3 + k];
                    const Eigen::Vector2f& uv = slot.cornerUvs[f][k];
                    std::size_t r = first;
                    while (r < slot.sourceVertex.size() && !(slot.normalGroup[r] == g && slot.renderUv[r] == uv)) ++r;
                    if (r == slot.sourceVertex.size()) {
                        slot.sourceVertex.push_back(static_cast<int>(v));
                        slot.normalGroup.push_back(g);
                        slot.renderUv.push_back(uv);
                    }
                    cornerRender[f * 3 + k] = static_cast<int>(r);
                }
            }
        }
    }
    std::vector<std::array<int, 3>> byTriangle(nt);
    for (std::size_t f = 0; f < nt; ++f)
        for (std::size_t k = 0; k < 3; ++k) byTriangle[f][k] = cornerRender[f * 3 + k];
    slot.adjacencyStart.assign(ng + 1, 0);
    for (std::size_t c = 0; c < nt * 3; ++c)
        ++slot.adjacencyStart[static_cast<std::size_t>(slot.normalGroup[static_cast<std::size_t>(cornerRender[c])]) + 1];
    for (std::size_t i = 0; i < ng; ++i) slot.adjacencyStart[i + 1] += slot.adjacencyStart[i];
    slot.adjacency.assign(static_cast<std::size_t>(slot.adjacencyStart[ng]), 0);
    std::vector<int> fill(slot.adjacencyStart.begin(), slot.adjacencyStart.end() - 1);
    for (std::size_t c = 0; c < nt * 3; ++c) {
        const std::size_t g = static_cast<std::size_t>(slot.normalGroup[static_cast<std::size_t>(cornerRender[c])]);
        slot.adjacency[static_cast<std::size_t>(fill[g]++)] = static_cast<int>(c / 3);
    }
    orderByMaterial(slot, byTriangle);
    slot.closed = isClosedOriented(tris);
}

}  // namespace

std::vector<std::string> RenderSettings::validate() const {
    std::vector<std::string> problems;
    if (width < 1 || width > kMaxTextureSize)
        problems.push_back("width: expected 1.." + std::to_string(kMaxTextureSize) + ", got " + std::to_string(width));
    if (height < 1 || height > kMaxTextureSize)
        problems.push_back("height: expected 1.." + std::to_string(kMaxTextureSize) + ", got " +
                           std::to_string(height));
    if (supersample < 1 || supersample > 4) {
        problems.push_back("supersample: expected 1..4, got " + std::to_string(supersample));
    } else if (static_cast<long>(width) * supersample > kMaxTextureSize ||
               static_cast<long>(height) * supersample > kMaxTextureSize) {
        problems.push_back("supersample: width and height times supersample must stay within " +
                           std::to_string(kMaxTextureSize));
    }
    if (!(creaseDegrees >= 0 && creaseDegrees <= 180))
        problems.push_back("crease_degrees: expected 0..180, got " + std::to_string(creaseDegrees));
    if (!(shadowSoftness >= 0 && shadowSoftness <= 15))
        problems.push_back("shadow_softness: expected 0..15 degrees, got " + std::to_string(shadowSoftness));
    if (lights.size() > static_cast<std::size_t>(kMaxLights))
        problems.push_back("lights: at most " + std::to_string(kMaxLights) + ", got " + std::to_string(lights.size()));
    int shadowing = 0;
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const Light& l = lights[i];
        const std::string name = "lights[" + std::to_string(i) + "]";
        if (!l.vector.allFinite() || (l.type == Light::Type::Directional && !(l.vector.norm() > 0)))
            problems.push_back(name + ": a directional light needs a nonzero, finite direction");
        if (!l.colour.allFinite() || l.colour.minCoeff() < 0)
            problems.push_back(name + ": colour times intensity must be finite and not negative");
        if (!(l.shininess >= 0 && l.shininess <= 1e4)) problems.push_back(name + ": shininess must be 0..10000");
        if (l.shadows && l.type != Light::Type::Directional)
            problems.push_back(name + ": only a directional light casts shadows");
        else if (l.shadows && !(l.vector.y() > 0))  // the floor's shadow needs a light above it
            problems.push_back(name + ": a light that casts shadows must shine from above (direction y > 0)");
        shadowing += l.shadows ? 1 : 0;
    }
    if (shadowing > 1) problems.push_back("lights: one light casts shadows, " + std::to_string(shadowing) + " ask to");
    if (environment)
        for (const Vec3& c : environment->coefficients)
            if (!c.allFinite()) {
                problems.push_back("environment: its light must be finite");
                break;
            }
    for (int i = 0; i < 3; ++i) {
        if (!(background[i] >= 0 && background[i] <= 1)) {
            problems.push_back("background: expected linear RGB components in [0,1]");
            break;
        }
    }
    return problems;
}

std::vector<Light> defaultLightRig() {
    auto light = [](Vec3 towards, Vec3 colour, bool shadows, Real shininess, bool floor) {
        Light l;
        l.vector = towards;
        l.colour = colour;
        l.cameraRelative = true;
        l.shadows = shadows;
        l.shininess = shininess;
        l.floor = floor;
        return l;
    };
    return {light(Vec3(-0.55, 1.0, 0.65), Vec3(1.00, 0.96, 0.90) * 0.95, true, 48, true),
            light(Vec3(0.9, 0.25, 0.6), Vec3(0.80, 0.88, 1.00) * 0.22, false, 0, true),
            light(Vec3(0.35, 0.7, -1.0), Vec3(1.0, 1.0, 1.0) * 0.7, false, 24, false)};
}

std::string findShaderDir() {
    if (const char* env = std::getenv("DGV_SHADER_DIR"); env && *env) {
        if (hasShaders(env)) return env;
        throw RuntimeError(std::string("DGV_SHADER_DIR=") + env + ": no mesh.vert/mesh.frag there");
    }
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        const fs::path exeDir = exe.parent_path();
        for (const fs::path& dir : {exeDir / "shaders", exeDir / ".." / "share" / "dgv" / "shaders"}) {
            if (hasShaders(dir)) return fs::weakly_canonical(dir, ec).string();
        }
    }
#ifdef DGV_SHADER_DIR
    if (hasShaders(DGV_SHADER_DIR)) return DGV_SHADER_DIR;
#endif
    throw RuntimeError(
        "cannot find dgv's shaders (mesh.vert, ...): set DGV_SHADER_DIR, or install "
        "them in <dgv dir>/shaders or <dgv dir>/../share/dgv/shaders");
}

struct Renderer::Impl {
    RenderSettings settings;
    std::vector<Light> rig;  ///< settings.lights, or the studio rig
    GlContext context;
    // meshProgram reads the per-vertex highlight scalar; meshPlainProgram (DGV_SCALAR 0) is for
    // meshes without one: one varying less to set up and interpolate per triangle and fragment
    // (about -7% of the benchmark's scene pass).
    ShaderProgram meshProgram, meshPlainProgram, groundProgram, groundPlainProgram, shadowProgram, resolveProgram,
        overlayProgram;

    // Supersampled target: RGBA16F colour texture + 24-bit depth renderbuffer (+ the contact
    // matte, R16F, with RenderSettings::linearPlanes).
    GLuint sceneFbo = 0, sceneColour = 0, sceneDepth = 0, sceneContact = 0;
    // Final target: RGBA16F at output size (linear, composited), read back as half floats and
    // encoded to 16-bit sRGB on the CPU through exact lookup tables.
    GLuint outFbo = 0, outColour = 0;
    // The ground at output size (premultiplied linear), composited under the meshes.
    GLuint groundFbo = 0, groundColour = 0, groundContact = 0;
    int targetWidth = 0, targetHeight = 0, targetFactor = 0;
    // Key-light shadow map; depthSampler reads it without comparison (the soft shadows'
    // blocker search, texture unit 3).
    GLuint shadowFbo = 0, shadowDepth = 0, depthSampler = 0;
    bool softShadows = false;
    // Ground: a 4x4 grid of vertices (3x3 cells, no T-junctions); the centre cell covers where
    // shadows can fall and is drawn with the shadowed program, the other 8 without shadows.
    GLuint groundVao = 0, groundVbo = 0, groundEbo = 0;
    static constexpr int kGroundOuterIndices = 8 * 6;
    GLuint emptyVao = 0;
    // Ground marks (FrameScene::groundMarks) as a texture over their bounding rectangle.
    GLuint decalTexture = 0;
    std::vector<float> decalTexels;
    std::vector<MeshSlot> meshes;
    /// Materials' textures by image (textureOf), the images kept alive so the keys stay theirs.
    std::map<const TextureImage*, GLuint> textures;
    std::vector<std::shared_ptr<const TextureImage>> texturesKept;
    std::vector<std::uint16_t> readback;
    // Half-float bits -> 16-bit code: sRGB-encoded colour, linear alpha (exact, in double).
    std::vector<std::uint16_t> srgbOfHalf, unormOfHalf;
    // Overlays: screen-space quads (clip xyzw, corner uv) rebuilt every frame.
    GLuint overlayVao = 0, overlayVbo = 0;
    std::size_t overlayCapacity = 0;  // bytes
    std::vector<float> overlayData;
    struct OverlayDraw {
        GLint first = 0;
        GLsizei count = 0;
        Vec3 colour;
        bool round = false, onTop = false;
    };
    std::vector<OverlayDraw> overlayDraws;
    Renderer::Timings timings;

    explicit Impl(const RenderSettings& s)
        : settings(s), rig(s.lights.empty() ? defaultLightRig() : s.lights), context(s.backend) {
        const std::string dir = s.shaderDir.empty() ? findShaderDir() : s.shaderDir;
        // Supersampled: the mesh pass shares its PCF taps across each 2x2 fragment quad
        // (lighting.glsl, DGV_QUAD_PCF; fine derivatives, core in GL 4.5). At 1x a quad spans
        // 2x2 output pixels, which would show as blocks in the penumbra: four taps each there.
        const bool quadPcf = s.sharedShadowTaps && s.supersample >= 2 && hasGlExtension("GL_ARB_derivative_control");
        // Soft shadows: the blocker search gathers depths (GL 4.0 / GL_ARB_texture_gather); the
        // ground at output size shares its search over 2x2 pixels where fine derivatives exist.
        softShadows = s.shadowSoftness > 0 && hasGlExtension("GL_ARB_texture_gather");
        const std::string soft = softShadows ? "#define DGV_SOFT_SHADOWS 1\n" : "";
        const std::string groundSoft =
            soft + (softShadows && hasGlExtension("GL_ARB_derivative_control") ? "#define DGV_QUAD_SEARCH 1\n" : "");
        const std::string pcf = soft + (quadPcf ? "#define DGV_QUAD_PCF 1\n" : "");
        // The default rig has its own unrolled sums (shaders/mesh.frag, DGV_STUDIO_RIG).
        const std::string contactOut = std::string(s.linearPlanes ? "#define DGV_CONTACT_OUT 1\n" : "") +
                                       (s.lights.empty() ? "#define DGV_STUDIO_RIG 1\n" : "");
        meshProgram = ShaderProgram(dir, "mesh.vert", "mesh.frag", "lighting.glsl", pcf + contactOut);
        meshPlainProgram = ShaderProgram(dir, "mesh.vert", "mesh.frag", "lighting.glsl",
                                         pcf + contactOut + "#define DGV_SCALAR 0\n");
        groundProgram = ShaderProgram(dir, "ground.vert", "ground.frag", "lighting.glsl", groundSoft + contactOut);
        groundPlainProgram = ShaderProgram(dir, "ground.vert", "ground.frag", "lighting.glsl",
                                           contactOut + "#define DGV_SHADOWS 0\n");
        shadowProgram = ShaderProgram(dir, "shadow.vert", "shadow.frag");
        resolveProgram = ShaderProgram(dir, "resolve.vert", "resolve.frag", "",
                                       "#define DGV_FACTOR " + std::to_string(s.supersample) + "\n");
        overlayProgram = ShaderProgram(dir, "overlay.vert", "overlay.frag");
        glGenVertexArrays(1, &overlayVao);
        glGenBuffers(1, &overlayVbo);
        glBindVertexArray(overlayVao);
        glBindBuffer(GL_ARRAY_BUFFER, overlayVbo);
        glEnableVertexAttribArray(0);
        glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
        glEnableVertexAttribArray(1);
        glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                              reinterpret_cast<const void*>(4 * sizeof(float)));
        glBindVertexArray(0);

        srgbOfHalf.resize(65536);
        unormOfHalf.resize(65536);
        for (std::uint32_t hbits = 0; hbits < 65536; ++hbits) {
            const double v = halfToFloat(static_cast<std::uint16_t>(hbits));
            const double c = std::isnan(v) ? 0.0 : std::clamp(v, 0.0, 1.0);  // clamps +-inf too
            srgbOfHalf[hbits] = static_cast<std::uint16_t>(std::lround(65535.0 * encodeSrgb(c)));
            unormOfHalf[hbits] = static_cast<std::uint16_t>(std::lround(65535.0 * c));
        }

        glGenVertexArrays(1, &emptyVao);
        glGenVertexArrays(1, &groundVao);
        glGenBuffers(1, &groundVbo);
        glGenBuffers(1, &groundEbo);
        glBindVertexArray(groundVao);
        glBindBuffer(GL_ARRAY_BUFFER, groundVbo);
        glBufferData(GL_ARRAY_BUFFER, 16 * 3 * sizeof(float), nullptr, GL_DYNAMIC_DRAW);
        glEnableVertexAttribArray(0);
        glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
        {
            // Cells (i, j) of the 4x4 vertex grid (vertex = j * 4 + i); the centre cell last.
            std::vector<unsigned> indices;
            auto cell = [&](unsigned i, unsigned j) {
                const unsigned a = j * 4 + i, b = a + 1, c = a + 5, d = a + 4;
                indices.insert(indices.end(), {a, d, b, b, d, c});
            };
            for (unsigned j = 0; j < 3; ++j)
                for (unsigned i = 0; i < 3; ++i)
                    if (i != 1 || j != 1) cell(i, j);
            cell(1, 1);
            glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, groundEbo);
            glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(unsigned)),
                         indices.data(), GL_STATIC_DRAW);
        }
        glBindVertexArray(0);

        // Shadow map: depth texture with hardware comparison (bilinear PCF per tap).
        glGenTextures(1, &shadowDepth);
        glBindTexture(GL_TEXTURE_2D, shadowDepth);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, kShadowMapSize, kShadowMapSize, 0, GL_DEPTH_COMPONENT,
                     GL_UNSIGNED_INT, nullptr);
        // Linear: resolve.frag sums the box from bilinear samples at 2x2 block centres.
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
        glGenFramebuffers(1, &shadowFbo);
        glBindFramebuffer(GL_FRAMEBUFFER, shadowFbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, shadowDepth, 0);
        glDrawBuffer(GL_NONE);
        glReadBuffer(GL_NONE);
        checkFramebuffer("shadow map");
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glGenSamplers(1, &depthSampler);
        glSamplerParameteri(depthSampler, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glSamplerParameteri(depthSampler, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glSamplerParameteri(depthSampler, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glSamplerParameteri(depthSampler, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glSamplerParameteri(depthSampler, GL_TEXTURE_COMPARE_MODE, GL_NONE);
        checkGlError("setting up the renderer");
    }

    ~Impl() {
        context.makeCurrent();
        for (MeshSlot& m : meshes) {
            glDeleteVertexArrays(1, &m.vao);
            glDeleteBuffers(1, &m.vbo);
            glDeleteBuffers(1, &m.ebo);
        }
        glDeleteVertexArrays(1, &emptyVao);
        glDeleteVertexArrays(1, &overlayVao);
        glDeleteBuffers(1, &overlayVbo);
        glDeleteVertexArrays(1, &groundVao);
        glDeleteBuffers(1, &groundVbo);
        glDeleteBuffers(1, &groundEbo);
        glDeleteFramebuffers(1, &shadowFbo);
        glDeleteTextures(1, &shadowDepth);
        for (const auto& [image, id] : textures) glDeleteTextures(1, &id);
        glDeleteSamplers(1, &depthSampler);
        if (decalTexture) glDeleteTextures(1, &decalTexture);
        releaseTargets();
    }

    static void checkFramebuffer(const char* what) {
        const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
        if (status != GL_FRAMEBUFFER_COMPLETE) {
            throw RuntimeError(std::string("OpenGL: the ") + what + " framebuffer is incomplete (status 0x" + [&] {
                char buf[16];
                std::snprintf(buf, sizeof buf, "%x", status);
                return std::string(buf);
            }() + ")");
        }
    }

    static void checkGlError(const char* what) {
        const GLenum err = glGetError();
        if (err != GL_NO_ERROR) {
            char buf[16];
            std::snprintf(buf, sizeof buf, "0x%x", err);
            throw RuntimeError(std::string("OpenGL error ") + buf + " while " + what);
        }
    }

    void releaseTargets() {
        if (sceneFbo) glDeleteFramebuffers(1, &sceneFbo);
        if (sceneColour) glDeleteTextures(1, &sceneColour);
        if (sceneDepth) glDeleteRenderbuffers(1, &sceneDepth);
        if (sceneContact) glDeleteTextures(1, &sceneContact);
        if (groundContact) glDeleteTextures(1, &groundContact);
        if (outFbo) glDeleteFramebuffers(1, &outFbo);
        if (outColour) glDeleteTextures(1, &outColour);
        if (groundFbo) glDeleteFramebuffers(1, &groundFbo);
        if (groundColour) glDeleteTextures(1, &groundColour);
        sceneFbo = sceneColour = sceneDepth = sceneContact = outFbo = outColour = groundFbo = groundColour = 0;
        groundContact = 0;
        targetWidth = targetHeight = targetFactor = 0;
    }

    /// A w x h half-float texture (`internal`: GL_RGBA16F or GL_R16F; nearest sampling, no
    /// mipmaps), left bound.
    static GLuint makeHalfTexture(int w, int h, GLenum internal) {
        GLuint texture = 0;
        glGenTextures(1, &texture);
        glBindTexture(GL_TEXTURE_2D, texture);
        glTexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(internal), w, h, 0, internal == GL_R16F ? GL_RED : GL_RGBA,
                     GL_HALF_FLOAT, nullptr);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
        return texture;
    }

    /// A w x h RGBA16F texture (makeHalfTexture) and a framebuffer with it as the only colour
    /// attachment, left bound; `what` names it if the framebuffer is incomplete.
    static void makeColourTarget(int w, int h, GLuint& texture, GLuint& fbo, const char* what) {
        texture = makeHalfTexture(w, h, GL_RGBA16F);
        glGenFramebuffers(1, &fbo);
        glBindFramebuffer(GL_FRAMEBUFFER, fbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
        checkFramebuffer(what);
    }

    /// (Re)creates the render targets only when the size or the supersampling changes.
    void ensureTargets(int w, int h, int factor) {
        if (w == targetWidth && h == targetHeight && factor == targetFactor) return;
        releaseTargets();
        const int sw = w * factor, sh = h * factor;
        glGenTextures(1, &sceneColour);
        glBindTexture(GL_TEXTURE_2D, sceneColour);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA16F, sw, sh, 0, GL_RGBA, GL_HALF_FLOAT, nullptr);
        // Linear: resolve.frag sums the box from bilinear samples at 2x2 block centres.
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
        glGenRenderbuffers(1, &sceneDepth);
        glBindRenderbuffer(GL_RENDERBUFFER, sceneDepth);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, sw, sh);
        glGenFramebuffers(1, &sceneFbo);
        glBindFramebuffer(GL_FRAMEBUFFER, sceneFbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, sceneColour, 0);
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, sceneDepth);
        if (settings.linearPlanes) {
            sceneContact = makeHalfTexture(sw, sh, GL_R16F);
            glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, sceneContact, 0);
        }
        checkFramebuffer("supersampled colour");

        makeColourTarget(w, h, outColour, outFbo, "output");
        makeColourTarget(w, h, groundColour, groundFbo, "ground");
        if (settings.linearPlanes) {  // the ground marks' share of the contact matte
            groundContact = makeHalfTexture(w, h, GL_R16F);
            glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, groundContact, 0);
            checkFramebuffer("ground with its contact matte");
        }
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        checkGlError("creating the render targets");
        targetWidth = w;
        targetHeight = h;
        targetFactor = factor;
    }

    /// The look's lists are empty or one entry a triangle, and name materials the mesh has.
    static void checkLook(const DrawMesh& mesh) {
        const std::size_t nt = mesh.triangles.size();
        if (!mesh.triangleMaterials.empty() && mesh.triangleMaterials.size() != nt)
            throw InputError("", "render",
                             "the per-triangle materials have " + std::to_string(mesh.triangleMaterials.size()) +
                                 " entries for a mesh with " + std::to_string(nt) + " triangles");
        if (!mesh.cornerUvs.empty() && mesh.cornerUvs.size() != nt)
            throw InputError("", "render",
                             "the texture coordinates have " + std::to_string(mesh.cornerUvs.size()) +
                                 " triangles' worth for a mesh with " + std::to_string(nt) + " triangles");
        for (int m : mesh.triangleMaterials)
            if (m < -1 || m >= static_cast<int>(mesh.materials.size()))
                throw InputError("", "render",
                                 "a triangle refers to material " + std::to_string(m) + " of a mesh with " +
                                     std::to_string(mesh.materials.size()));
    }

    /// Area-weighted vertex normals (sum of the unnormalised face normals of each render
    /// vertex's smoothing group, in triangle order), the interleaved vertex data, the upload.
    void uploadMesh(MeshSlot& slot, const DrawMesh& mesh) {
        constexpr int kStride = 9;  // position xyz, normal xyz, scalar, uv
        if (!slot.vao) {
            glGenVertexArrays(1, &slot.vao);
            glGenBuffers(1, &slot.vbo);
            glGenBuffers(1, &slot.ebo);
            glBindVertexArray(slot.vao);
            glBindBuffer(GL_ARRAY_BUFFER, slot.vbo);
            glEnableVertexAttribArray(0);
            glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kStride * sizeof(float), nullptr);
            glEnableVertexAttribArray(1);
            glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, kStride * sizeof(float),
                                  reinterpret_cast<const void*>(3 * sizeof(float)));
            glEnableVertexAttribArray(2);
            glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, kStride * sizeof(float),
                                  reinterpret_cast<const void*>(6 * sizeof(float)));
            glEnableVertexAttribArray(3);
            glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, kStride * sizeof(float),
                                  reinterpret_cast<const void*>(7 * sizeof(float)));
            glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, slot.ebo);  // recorded in the VAO
            glBindVertexArray(0);
        }
        const std::size_t nv = mesh.positions.size();
        const std::size_t nt = mesh.triangles.size();
        for (const auto& t : mesh.triangles) {
            for (int k = 0; k < 3; ++k) {
                if (t[k] < 0 || static_cast<std::size_t>(t[k]) >= nv)
                    throw InputError("", "render",
                                     "a triangle refers to vertex " + std::to_string(t[k]) + " of a mesh with " +
                                         std::to_string(nv));
            }
        }
        if (!mesh.scalar.empty() && mesh.scalar.size() != nv)
            throw InputError("", "render",
                             "the per-vertex scalar has " + std::to_string(mesh.scalar.size()) +
                                 " values for a mesh with " + std::to_string(nv) + " vertices");
        checkLook(mesh);
        slot.faceNormals.resize(nt);
        parallelFor(static_cast<Index>(nt), [&](Index f) {
            const auto& t = mesh.triangles[static_cast<std::size_t>(f)];
            const Vec3 e1 =
                mesh.positions[static_cast<std::size_t>(t[1])] - mesh.positions[static_cast<std::size_t>(t[0])];
            const Vec3 e2 =
                mesh.positions[static_cast<std::size_t>(t[2])] - mesh.positions[static_cast<std::size_t>(t[0])];
            slot.faceNormals[static_cast<std::size_t>(f)] = e1.cross(e2).cast<float>();
        });
        const bool topologyChanged = slot.vertexCount != nv || slot.triangles != mesh.triangles ||
                                     slot.creaseDegrees != settings.creaseDegrees ||
                                     slot.triangleMaterials != mesh.triangleMaterials || slot.cornerUvs != mesh.cornerUvs;
        if (topologyChanged) {
            // The split is decided on the positions of this frame and kept while the triangles
            // stay the same, so a deforming mesh keeps its vertex count and index buffer.
            slot.triangles = mesh.triangles;
            slot.triangleMaterials = mesh.triangleMaterials;
            slot.cornerUvs = mesh.cornerUvs;
            slot.vertexCount = nv;
            slot.creaseDegrees = settings.creaseDegrees;
            if (mesh.creasePositions.size() == nv) {
                std::vector<Vec3f> restNormals(nt);
                for (std::size_t f = 0; f < nt; ++f) {
                    const auto& t = mesh.triangles[f];
                    const Vec3& a = mesh.creasePositions[static_cast<std::size_t>(t[0])];
                    restNormals[f] = (mesh.creasePositions[static_cast<std::size_t>(t[1])] - a)
                                         .cross(mesh.creasePositions[static_cast<std::size_t>(t[2])] - a)
                                         .cast<float>();
                }
                buildRenderTopology(slot, nv, restNormals, settings.creaseDegrees);
            } else {
                buildRenderTopology(slot, nv, slot.faceNormals, settings.creaseDegrees);
            }
            // A closed mesh wound inside out (negative signed volume) culls its front faces
            // instead: the visible outside is then its back faces, whose normals the shader flips.
            double volume = 0;
            for (const auto& t : mesh.triangles)
                volume += mesh.positions[static_cast<std::size_t>(t[0])].dot(
                    mesh.positions[static_cast<std::size_t>(t[1])].cross(
                        mesh.positions[static_cast<std::size_t>(t[2])]));
            slot.inverted = slot.closed && volume < 0;
        }
        const std::size_t nr = slot.sourceVertex.size();
        slot.interleaved.resize(nr * kStride);
        parallelFor(static_cast<Index>(nr), [&](Index ri) {
            const std::size_t r = static_cast<std::size_t>(ri);
            const std::size_t v = static_cast<std::size_t>(slot.sourceVertex[r]);
            const std::size_t g = static_cast<std::size_t>(slot.normalGroup[r]);
            Vec3f n = Vec3f::Zero();
            for (int a = slot.adjacencyStart[g]; a < slot.adjacencyStart[g + 1]; ++a)
                n += slot.faceNormals[static_cast<std::size_t>(slot.adjacency[static_cast<std::size_t>(a)])];
            const float len = n.norm();
            if (len > 0 && std::isfinite(len))
                n /= len;
            else
                n = Vec3f(0, 1, 0);
            float* out = slot.interleaved.data() + r * kStride;
            out[0] = static_cast<float>(mesh.positions[v].x());
            out[1] = static_cast<float>(mesh.positions[v].y());
            out[2] = static_cast<float>(mesh.positions[v].z());
            out[3] = n.x();
            out[4] = n.y();
            out[5] = n.z();
            out[6] = mesh.scalar.empty() ? 0.0f : static_cast<float>(mesh.scalar[v]);
            // t = 1 − v: the texture's rows go up from its top row (TextureImage), v from its bottom
            out[7] = slot.renderUv.empty() ? 0.0f : slot.renderUv[r].x();
            out[8] = slot.renderUv.empty() ? 0.0f : 1.0f - slot.renderUv[r].y();
        });

        glBindBuffer(GL_ARRAY_BUFFER, slot.vbo);
        const std::size_t vbytes = slot.interleaved.size() * sizeof(float);
        if (vbytes > slot.vboCapacity) {
            glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vbytes), slot.interleaved.data(), GL_DYNAMIC_DRAW);
            slot.vboCapacity = vbytes;
        } else if (vbytes > 0) {
            glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(vbytes), slot.interleaved.data());
        }
        if (topologyChanged) {
            glBindVertexArray(slot.vao);
            const std::size_t ibytes = nt * 3 * sizeof(int);
            static_assert(sizeof(std::array<int, 3>) == 3 * sizeof(int), "packed triangles");
            if (ibytes > slot.eboCapacity) {
                glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(ibytes), slot.renderTriangles.data(),
                             GL_STATIC_DRAW);
                slot.eboCapacity = ibytes;
            } else if (ibytes > 0) {
                glBufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(ibytes),
                                slot.renderTriangles.data());
            }
            glBindVertexArray(0);
            slot.indexCount = static_cast<GLsizei>(nt * 3);
        }
    }

    /// Screen-space quads for the overlays (two triangles each, clip coordinates plus a corner
    /// coordinate in [-1,1]^2): a segment becomes a quad `width` output pixels wide, extended
    /// by half the width at both ends (square caps, so consecutive segments join); a dot a
    /// square `size` pixels across that the shader rounds. Segments or dots with a point behind
    /// the eye (clip w <= 0) are skipped. Uploaded to overlayVbo; draws in overlayDraws.
    void buildOverlays(const FrameScene& scene, const Mat4& clipFromWorld, int w, int h) {
        overlayData.clear();
        overlayDraws.clear();
        const double sx = 0.5 * w, sy = 0.5 * h;  // NDC -> output pixels
        auto clip = [&](const Vec3& p) -> Vec4 { return clipFromWorld * p.homogeneous(); };
        auto emit = [&](const Vec4& c, double ox, double oy, float u, float v) {
            // (ox, oy): offset in output pixels, turned into clip units at this vertex's w.
            overlayData.insert(overlayData.end(), {static_cast<float>(c.x() + ox / sx * c.w()),
                                                   static_cast<float>(c.y() + oy / sy * c.w()),
                                                   static_cast<float>(c.z()), static_cast<float>(c.w()), u, v});
        };
        auto quad = [&](const Vec4& a, const Vec4& b, double px, double py, double dx, double dy) {
            // a - perp - dir, a + perp - dir, b + perp + dir, b - perp + dir
            emit(a, -px - dx, -py - dy, -1, -1);
            emit(a, px - dx, py - dy, -1, 1);
            emit(b, px + dx, py + dy, 1, 1);
            emit(a, -px - dx, -py - dy, -1, -1);
            emit(b, px + dx, py + dy, 1, 1);
            emit(b, -px + dx, -py + dy, 1, -1);
        };
        const double kMinW = 1e-9;
        for (const Polyline& line : scene.lines) {
            OverlayDraw d;
            d.first = static_cast<GLint>(overlayData.size() / 6);
            d.colour = line.colour;
            d.onTop = line.onTop;
            const std::size_t n = line.points.size();
            const std::size_t segments = n < 2 ? 0 : (line.closed && n > 2 ? n : n - 1);
            const double half = 0.5 * std::max(line.width, Real(0));
            for (std::size_t i = 0; i < segments; ++i) {
                const Vec4 a = clip(line.points[i]), b = clip(line.points[(i + 1) % n]);
                if (!(a.w() > kMinW && b.w() > kMinW)) continue;
                double ex = (b.x() / b.w() - a.x() / a.w()) * sx, ey = (b.y() / b.w() - a.y() / a.w()) * sy;
                const double len = std::hypot(ex, ey);
                if (len > 1e-12)
                    ex /= len, ey /= len;
                else
                    ex = 1, ey = 0;
                quad(a, b, -ey * half, ex * half, ex * half, ey * half);
            }
            d.count = static_cast<GLsizei>(overlayData.size() / 6) - d.first;
            if (d.count > 0) overlayDraws.push_back(d);
        }
        for (const PointSet& set : scene.points) {
            OverlayDraw d;
            d.first = static_cast<GLint>(overlayData.size() / 6);
            d.colour = set.colour;
            d.onTop = set.onTop;
            d.round = true;
            const double half = 0.5 * std::max(set.size, Real(0));
            for (const Vec3& p : set.points) {
                const Vec4 c = clip(p);
                if (!(c.w() > kMinW)) continue;
                quad(c, c, 0, half, half, 0);  // a square 2*half across, corners at (+-1, +-1)
            }
            d.count = static_cast<GLsizei>(overlayData.size() / 6) - d.first;
            if (d.count > 0) overlayDraws.push_back(d);
        }
        if (overlayData.empty()) return;
        glBindBuffer(GL_ARRAY_BUFFER, overlayVbo);
        const std::size_t bytes = overlayData.size() * sizeof(float);
        if (bytes > overlayCapacity) {
            glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(bytes), overlayData.data(), GL_DYNAMIC_DRAW);
            overlayCapacity = bytes;
        } else {
            glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(bytes), overlayData.data());
        }
    }

    /// Draws mesh i's triangles (its VAO stays bound). A closed mesh culls the faces turned away
    /// from the eye, or towards the light in the shadow map (`fromLight`: only its back faces go
    /// in, so lit surfaces never compare against themselves); one wound inside out the opposite
    /// ones; an open mesh is two-sided.
    void drawTriangles(std::size_t i, bool fromLight) {
        bindTriangles(i, fromLight);
        glDrawElements(GL_TRIANGLES, meshes[i].indexCount, GL_UNSIGNED_INT, nullptr);
    }

    /// drawTriangles' culling and VAO, for drawing mesh i's runs one by one.
    void bindTriangles(std::size_t i, bool fromLight) {
        if (meshes[i].closed)
            glEnable(GL_CULL_FACE);
        else
            glDisable(GL_CULL_FACE);
        glCullFace(meshes[i].inverted != fromLight ? GL_FRONT : GL_BACK);
        glBindVertexArray(meshes[i].vao);
    }

    /// The GL texture of a material's image, made on first use (sRGB, so samples come back
    /// linear; mipmapped, repeating as glTF's default sampler) and kept while the renderer lives.
    GLuint textureOf(const std::shared_ptr<const TextureImage>& image) {
        auto found = textures.find(image.get());
        if (found != textures.end()) return found->second;
        GLuint id = 0;
        glGenTextures(1, &id);
        glActiveTexture(GL_TEXTURE0 + kBaseColourUnit);
        glBindTexture(GL_TEXTURE_2D, id);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_SRGB8_ALPHA8, image->width, image->height, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                     image->rgba.data());
        glGenerateMipmap(GL_TEXTURE_2D);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
        glActiveTexture(GL_TEXTURE0);
        checkGlError("uploading a material's texture");
        textures.emplace(image.get(), id);
        texturesKept.push_back(image);
        return id;
    }

    /// A material's uniforms (mesh.frag): albedo, texture, highlight width and metalness; null:
    /// the mesh's own colour, as before materials.
    void setSurface(const ShaderProgram& p, const DrawMesh& m, const SurfaceMaterial* mat) {
        setVec3(p, "uAlbedo", (mat ? mat->baseColour : m.colour).cwiseMax(0.0).cwiseMin(1.0));
        const bool textured = mat && mat->baseColourMap && mat->baseColourMap->width > 0;
        setInt(p, "uTextured", textured ? 1 : 0);
        if (textured) {
            const GLuint id = textureOf(mat->baseColourMap);
            glActiveTexture(GL_TEXTURE0 + kBaseColourUnit);
            glBindTexture(GL_TEXTURE_2D, id);
            glActiveTexture(GL_TEXTURE0);
        }
        setFloat(p, "uSurfaceShininess", mat && mat->roughness >= 0 ? shininessOfRoughness(mat->roughness) : 0.0);
        setFloat(p, "uMetallic", mat ? std::clamp(mat->metallic, 0.0, 1.0) : 0.0);
    }

    /// Sets the lights and shadow uniforms shared by mesh.frag and ground.frag (lighting.glsl).
    struct Lights {
        /// In world space: direction (w = 0) or position (w = 1), colour, and the rig's light
        /// whose shadow map keyVisibility reads (-1: none), keyDir its direction.
        std::vector<Eigen::Vector4d> vectors;
        std::vector<Vec3> colours;
        std::vector<Real> shininess;
        std::vector<int> floor;
        int shadowLight = -1;
        Vec3 keyDir = Vec3::UnitY();
        Mat4 shadowFromWorld = Mat4::Identity();
        Real shadowRadius = 0, normalOffset = 0;
        // Soft shadows (lighting.glsl): filter radius per unit of map depth, its largest value
        // (both in texture units), and the map depth of the scene's nearest point to the light.
        Real penumbraPerDepth = 0, searchRadius = 0, blockerNear = 0;
        bool shadows = false;
    };

    void setLighting(const ShaderProgram& p, const Lights& l) {
        const int n = static_cast<int>(l.vectors.size());
        std::vector<float> vectors, colours, shininess;
        for (int i = 0; i < n; ++i) {
            for (int c = 0; c < 4; ++c) vectors.push_back(static_cast<float>(l.vectors[static_cast<std::size_t>(i)][c]));
            for (int c = 0; c < 3; ++c) colours.push_back(static_cast<float>(l.colours[static_cast<std::size_t>(i)][c]));
            shininess.push_back(static_cast<float>(l.shininess[static_cast<std::size_t>(i)]));
        }
        setInt(p, "uLightCount", n);
        if (n > 0) {
            glUniform4fv(p.uniform("uLightVector"), n, vectors.data());
            glUniform3fv(p.uniform("uLightColour"), n, colours.data());
            glUniform1fv(p.uniform("uLightShininess"), n, shininess.data());
            glUniform1iv(p.uniform("uLightFloor"), n, l.floor.data());
        }
        setInt(p, "uShadowLight", l.shadowLight);
        setVec3(p, "uSkyColour", Vec3(0.80, 0.87, 1.00) * 0.20);
        setVec3(p, "uBounceColour", Vec3(1.00, 0.95, 0.90) * 0.06);
        setInt(p, "uEnvironment", settings.environment ? 1 : 0);
        if (settings.environment) {
            float c[27];
            for (int k = 0; k < 9; ++k)
                for (int j = 0; j < 3; ++j)
                    c[3 * k + j] = static_cast<float>(settings.environment->coefficients[static_cast<std::size_t>(k)][j]);
            glUniform3fv(p.uniform("uEnvironmentSH"), 9, c);
        }
        setMat4(p, "uShadowFromWorld", l.shadowFromWorld);
        setFloat(p, "uShadowRadius", l.shadowRadius);
        setFloat(p, "uNormalOffset", l.normalOffset);
        setInt(p, "uShadowsOn", l.shadows ? 1 : 0);
        setInt(p, "uShadowMap", 0);
        if (softShadows) {
            setInt(p, "uShadowDepth", 3);
            setFloat(p, "uPenumbraPerDepth", l.penumbraPerDepth);
            setFloat(p, "uSearchRadius", l.searchRadius);
            setFloat(p, "uBlockerNear", l.blockerNear);
        }
    }

    /// Rasterises the ground marks into decalTexture; returns the rectangle (x0, z0, 1/width,
    /// 1/depth) it covers. Texels of a quarter of the smallest mark's radius, at most 512 a side.
    std::array<Real, 4> uploadGroundMarks(const std::vector<GroundMark>& marks) {
        Real x0 = std::numeric_limits<Real>::infinity(), z0 = x0, x1 = -x0, z1 = -x0, rMin = x0;
        for (const GroundMark& m : marks) {
            x0 = std::min(x0, m.x - m.radius);
            x1 = std::max(x1, m.x + m.radius);
            z0 = std::min(z0, m.z - m.radius);
            z1 = std::max(z1, m.z + m.radius);
            rMin = std::min(rMin, m.radius);
        }
        constexpr int kMaxSide = 512;
        const Real texel = std::max({0.25 * rMin, (x1 - x0) / kMaxSide, (z1 - z0) / kMaxSide});
        const int nx = std::clamp(static_cast<int>(std::ceil((x1 - x0) / texel)), 2, kMaxSide);
        const int nz = std::clamp(static_cast<int>(std::ceil((z1 - z0) / texel)), 2, kMaxSide);
        const Real dx = (x1 - x0) / nx, dz = (z1 - z0) / nz;
        // Per texel: Π(1 − a), Σ a·colour, Σ a.
        std::vector<double> clear(static_cast<std::size_t>(nx) * nz, 1.0),
            sum(static_cast<std::size_t>(nx) * nz * 4, 0.0);
        for (const GroundMark& m : marks) {
            const Real a0 = std::clamp(m.strength, Real(0), Real(1));
            const int i0 = std::max(0, static_cast<int>(std::floor((m.x - m.radius - x0) / dx)));
            const int i1 = std::min(nx - 1, static_cast<int>(std::ceil((m.x + m.radius - x0) / dx)));
            const int j0 = std::max(0, static_cast<int>(std::floor((m.z - m.radius - z0) / dz)));
            const int j1 = std::min(nz - 1, static_cast<int>(std::ceil((m.z + m.radius - z0) / dz)));
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    const Real t = std::hypot(x0 + (i + 0.5) * dx - m.x, z0 + (j + 0.5) * dz - m.z) / m.radius;
                    if (t >= 1) continue;
                    const Real a = a0 * (1 - t * t * (3 - 2 * t));
                    const std::size_t k = static_cast<std::size_t>(j) * nx + i;
                    clear[k] *= 1 - a;
                    for (int c = 0; c < 3; ++c) sum[4 * k + c] += a * m.colour[c];
                    sum[4 * k + 3] += a;
                }
        }
        decalTexels.assign(static_cast<std::size_t>(nx) * nz * 4, 0.0f);
        for (std::size_t k = 0; k < clear.size(); ++k) {
            if (!(sum[4 * k + 3] > 0)) continue;
            const double alpha = 1 - clear[k];
            for (int c = 0; c < 3; ++c)
                decalTexels[4 * k + c] =
                    static_cast<float>(std::clamp(sum[4 * k + c] / sum[4 * k + 3], 0.0, 1.0) * alpha);
            decalTexels[4 * k + 3] = static_cast<float>(alpha);
        }
        if (!decalTexture) {
            glGenTextures(1, &decalTexture);
            glBindTexture(GL_TEXTURE_2D, decalTexture);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        }
        glBindTexture(GL_TEXTURE_2D, decalTexture);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, nx, nz, 0, GL_RGBA, GL_FLOAT, decalTexels.data());
        return {x0, z0, 1 / (x1 - x0), 1 / (z1 - z0)};
    }

    static double msSince(std::chrono::steady_clock::time_point t0) {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }

    /// The rig (RenderSettings::lights, else the default) in world space for this camera: a
    /// camera-relative light turns with the camera's azimuth (a classic turntable: the object
    /// turns under studio lights), level with the horizon.
    Lights worldLights(const Camera& camera) const {
        const Vec3 forward = (camera.target - camera.eye).normalized();
        Vec3 backH(-forward.x(), 0, -forward.z());
        if (backH.norm() < 1e-9) backH = Vec3(0, 0, 1);
        backH.normalize();
        const Vec3 rightH = Vec3::UnitY().cross(backH).normalized();
        Lights out;
        for (const Light& l : rig) {
            const Vec3& v = l.vector;
            const Vec3 turned = v.x() * rightH + v.y() * Vec3::UnitY() + v.z() * backH;
            Eigen::Vector4d world;
            if (l.type == Light::Type::Directional) {
                world << (l.cameraRelative ? turned : v).normalized(), 0;
            } else {
                world << (l.cameraRelative ? Vec3(camera.eye + turned) : v), 1;
            }
            if (l.shadows) {
                out.shadowLight = static_cast<int>(out.vectors.size());
                out.keyDir = world.head<3>();
            }
            out.vectors.push_back(world);
            out.colours.push_back(l.colour);
            out.shininess.push_back(l.shininess);
            out.floor.push_back(l.floor ? 1 : 0);
        }
        return out;
    }

    /// The frame for compositing (Renderer::render's `linear`) from the resolve's half floats in
    /// `readback` (bottom row first) and the scene pass's depth and contact matte. groundAtOutput:
    /// the height of a ground drawn at output size, outside the depth buffer; its depth is the
    /// view ray's, where the ground shows.
    LinearImage linearPlanes(const Camera& camera, Real nearZ, Real farZ, std::optional<Real> groundAtOutput) {
        const int w = settings.width, h = settings.height, factor = settings.supersample;
        const int sw = w * factor, sh = h * factor;
        std::vector<float> depth(static_cast<std::size_t>(sw) * sh), contact(depth.size());
        glBindFramebuffer(GL_FRAMEBUFFER, sceneFbo);
        glPixelStorei(GL_PACK_ALIGNMENT, 4);
        glReadPixels(0, 0, sw, sh, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
        glReadBuffer(GL_COLOR_ATTACHMENT1);
        glReadPixels(0, 0, sw, sh, GL_RED, GL_FLOAT, contact.data());
        glReadBuffer(GL_COLOR_ATTACHMENT0);
        std::vector<std::uint16_t> ground;
        std::vector<float> groundMatte;  // the ground marks' coverage where the ground shows
        if (groundAtOutput) {
            ground.resize(static_cast<std::size_t>(w) * h * 4);
            groundMatte.resize(static_cast<std::size_t>(w) * h);
            glBindFramebuffer(GL_FRAMEBUFFER, groundFbo);
            glPixelStorei(GL_PACK_ALIGNMENT, 2);
            glReadPixels(0, 0, w, h, GL_RGBA, GL_HALF_FLOAT, ground.data());
            glPixelStorei(GL_PACK_ALIGNMENT, 4);
            glReadBuffer(GL_COLOR_ATTACHMENT1);
            glReadPixels(0, 0, w, h, GL_RED, GL_FLOAT, groundMatte.data());
            glReadBuffer(GL_COLOR_ATTACHMENT0);
        }
        checkGlError("reading the depth and the contact matte");
        glBindFramebuffer(GL_FRAMEBUFFER, 0);

        // Window depth d -> NDC z = 2d - 1 -> view depth B / (z + A) (camera.cpp's projection).
        const Real A = (farZ + nearZ) / (nearZ - farZ), B = 2 * farZ * nearZ / (nearZ - farZ);
        const Mat3 worldFromView = camera.viewFromWorld().inverse().block<3, 3>(0, 0);
        const Real ty = std::tan(0.5 * camera.fovYDegrees * 3.14159265358979323846 / 180), tx = ty * w / h;
        const bool transparent = settings.transparentBackground;
        LinearImage out(w, h);
        parallelFor(
            static_cast<Index>(h),
            [&](Index yi) {
                const int y = static_cast<int>(yi), gy = h - 1 - y;  // GL rows are bottom-up
                for (int x = 0; x < w; ++x) {
                    const std::size_t o = static_cast<std::size_t>(y) * w + x;
                    const std::uint16_t* src = readback.data() + (static_cast<std::size_t>(gy) * w + x) * 4;
                    float* dst = out.rgba.data() + 4 * o;
                    if (src[3] & 0x8000) {  // nothing drawn: the background
                        for (int c = 0; c < 3; ++c) dst[c] = transparent ? 0.0f : static_cast<float>(settings.background[c]);
                        dst[3] = transparent ? 0.0f : 1.0f;
                    } else {
                        const float a = static_cast<float>(halfToFloat(src[3]));
                        for (int c = 0; c < 3; ++c)  // the resolve un-premultiplied a transparent frame
                            dst[c] = static_cast<float>(halfToFloat(src[c])) * (transparent ? a : 1.0f);
                        dst[3] = a;
                    }
                    float nearest = 1, matte = 0;
                    int covered = 0;  // samples on a mesh
                    for (int j = 0; j < factor; ++j)
                        for (int i = 0; i < factor; ++i) {
                            const std::size_t k = static_cast<std::size_t>(gy * factor + j) * sw + x * factor + i;
                            nearest = std::min(nearest, depth[k]);
                            covered += depth[k] < 1 ? 1 : 0;
                            matte += contact[k];
                        }
                    const float samples = static_cast<float>(factor * factor);
                    // A ground drawn at output size lies under every mesh sample: its marks show
                    // through the rest, as its colour does in the resolve.
                    const float under = groundMatte.empty()
                                            ? 0.0f
                                            : (1 - covered / samples) * groundMatte[static_cast<std::size_t>(gy) * w + x];
                    out.contact[o] = std::clamp(matte / samples + under, 0.0f, 1.0f);
                    if (nearest < 1) {
                        out.depth[o] = static_cast<float>(B / (2 * Real(nearest) - 1 + A));
                    } else if (!ground.empty() && halfToFloat(ground[(static_cast<std::size_t>(gy) * w + x) * 4 + 3]) > 0) {
                        // a lens sample's view is shifted off axis (Camera::lensShift)
                        const Vec3 dir = worldFromView * Vec3((2 * (x + 0.5) / w - 1) * tx - camera.lensShift.x(),
                                                              (2 * (gy + 0.5) / h - 1) * ty - camera.lensShift.y(), -1);
                        const Real t = dir.y() != 0 ? (*groundAtOutput - camera.eye.y()) / dir.y() : -1;
                        if (t > 0) out.depth[o] = static_cast<float>(t);  // dir has view depth 1
                    }
                }
            },
            16);
        return out;
    }

    static bool seeThrough(const DrawMesh& m) { return std::clamp(m.opacity, 0.0, 1.0) < 1; }

    /// What a frame's passes share: the scene's bounds, the floor, the depth range and the lights.
    struct FrameSetup {
        Box3 bounds;
        bool haveGeometry = false;
        Vec3 centre = Vec3::Zero();
        Real radius = 1;
        Real groundY = 0, fadeInner = 0, fadeOuter = 0;
        bool drawGround = false;
        /// The floor shaded once per output pixel into its own target (it can hide no mesh).
        bool groundAtOutput = false;
        bool haveDecal = false;
        std::array<Real, 4> decalRect{0, 0, 1, 1};
        Real nearZ = 0, farZ = 0;
        Mat4 clipFromWorld = Mat4::Identity();
        Lights lights;
    };

    /// The near and far planes from the scene (the ground and the overlays included), where the
    /// camera leaves them to the renderer.
    void depthRange(const FrameScene& scene, const Camera& camera, FrameSetup& f) const {
        const int w = settings.width, h = settings.height;
        const Mat4 viewFromWorld = camera.viewFromWorld();
        f.nearZ = camera.nearClip;
        f.farZ = camera.farClip;
        if (f.nearZ <= 0 || f.farZ <= 0) {
            Real minDepth = std::numeric_limits<Real>::infinity(), maxDepth = 0;
            auto depthOf = [&](const Vec3& p) { return -(viewFromWorld * p.homogeneous()).z(); };
            if (f.haveGeometry) {
                for (int c = 0; c < 8; ++c) {
                    const Vec3 corner((c & 1) ? f.bounds.max.x() : f.bounds.min.x(),
                                      (c & 2) ? f.bounds.max.y() : f.bounds.min.y(),
                                      (c & 4) ? f.bounds.max.z() : f.bounds.min.z());
                    const Real d = depthOf(corner);
                    minDepth = std::min(minDepth, d);
                    maxDepth = std::max(maxDepth, d);
                }
            }
            // Overlays widen the depth range (they may reach beyond the meshes).
            auto overlayDepth = [&](const Vec3& p) {
                const Real d = depthOf(p);
                if (d > 0) minDepth = std::min(minDepth, d);
                maxDepth = std::max(maxDepth, d);
            };
            for (const Polyline& l : scene.lines)
                for (const Vec3& p : l.points) overlayDepth(p);
            for (const PointSet& ps : scene.points)
                for (const Vec3& p : ps.points) overlayDepth(p);
            if (f.drawGround) {
                for (int c = 0; c < 4; ++c) {
                    const Vec3 corner(f.centre.x() + ((c & 1) ? f.fadeOuter : -f.fadeOuter), f.groundY,
                                      f.centre.z() + ((c & 2) ? f.fadeOuter : -f.fadeOuter));
                    maxDepth = std::max(maxDepth, depthOf(corner));
                }
            }
            // The ground's nearest visible point: a plane meets the view frustum's visible part
            // nearest the eye where its side edges (the corner rays) cross it. Without this a
            // low camera clipped the floor in front of it, a band of background at the bottom.
            Real groundNear = std::numeric_limits<Real>::infinity();
            if (f.drawGround) {
                const Mat4 worldFromView = viewFromWorld.inverse();
                const Real ty = std::tan(0.5 * camera.fovYDegrees * 3.14159265358979323846 / 180);
                const Real tx = ty * static_cast<Real>(w) / h;
                for (int c = 0; c < 4; ++c) {
                    const Vec3 viewDir((c & 1) ? tx : -tx, (c & 2) ? ty : -ty, -1);  // view depth 1
                    const Vec3 dir = worldFromView.block<3, 3>(0, 0) * viewDir;
                    if (dir.y() == 0) continue;
                    const Real t = (f.groundY - camera.eye.y()) / dir.y();  // = the hit's view depth
                    if (t > 0) groundNear = std::min(groundNear, t);
                }
            }
            if (f.farZ <= 0) f.farZ = std::max(maxDepth * 1.05, 1e-3);
            if (f.nearZ <= 0) f.nearZ = std::max(std::min(0.5 * minDepth, 0.9 * groundNear), 1e-3 * f.farZ);
            if (!(f.nearZ < f.farZ)) f.nearZ = 1e-3 * f.farZ;
        }
    }

    /// Pass 1: the shadow map from the key light, orthographic over the bounding sphere.
    void shadowPass(const FrameScene& scene, FrameSetup& f) {
        if (f.haveGeometry && f.lights.shadowLight >= 0) {
            Camera light;
            light.eye = f.centre + 2.0 * f.radius * f.lights.keyDir;
            light.target = f.centre;
            light.up = std::abs(f.lights.keyDir.y()) > 0.99 ? Vec3::UnitZ() : Vec3::UnitY();
            const Mat4 lightClipFromWorld =
                orthographic(-f.radius, f.radius, -f.radius, f.radius, 0.0, 4.0 * f.radius) * light.viewFromWorld();
            Mat4 bias = Mat4::Identity() * 0.5;
            bias(3, 3) = 1;
            bias.block<3, 1>(0, 3) = Vec3::Constant(0.5);
            f.lights.shadowFromWorld = bias * lightClipFromWorld;
            f.lights.shadows = true;
            const Real texelWorld = 2.0 * f.radius / kShadowMapSize;
            f.lights.shadowRadius = 1.0 / kShadowMapSize;  // 4 taps at +-1 texel: ~4-texel penumbra
            f.lights.normalOffset = 1.5 * texelWorld;
            // A light disc of angular f.radius theta widens a penumbra by tan(theta) per unit of
            // distance behind its blocker on either side: the map spans 2 f.radius across and
            // 4 f.radius in depth, so the filter f.radius is 2 tan(theta) per unit of map depth.
            // The bounding sphere starts at depth 1/4 (the light sits 2 f.radius from its f.centre).
            f.lights.penumbraPerDepth = 2.0 * std::tan(settings.shadowSoftness * 3.14159265358979323846 / 180);
            f.lights.searchRadius = 64.0 / kShadowMapSize;
            f.lights.blockerNear = 0.25;

            glBindFramebuffer(GL_FRAMEBUFFER, shadowFbo);
            glViewport(0, 0, kShadowMapSize, kShadowMapSize);
            glEnable(GL_DEPTH_TEST);
            glDepthFunc(GL_LESS);
            glDepthMask(GL_TRUE);
            glClearDepth(1.0);
            glClear(GL_DEPTH_BUFFER_BIT);
            glEnable(GL_POLYGON_OFFSET_FILL);
            glPolygonOffset(2.0f, 4.0f);
            glUseProgram(shadowProgram.id());
            setMat4(shadowProgram, "uLightClipFromWorld", lightClipFromWorld);
            // Closed meshes put only their back faces (seen from the light) in the map: half
            // the triangles to set up, and lit surfaces never compare against themselves.
            for (std::size_t i = 0; i < scene.meshes.size(); ++i)
                if (meshes[i].indexCount > 0) drawTriangles(i, true);
            glBindVertexArray(0);
            glDisable(GL_CULL_FACE);
            glCullFace(GL_BACK);
            glDisable(GL_POLYGON_OFFSET_FILL);
        }

    }

    /// The meshes of the scene pass: the opaque ones, or (seeThroughPass) those with opacity < 1.
    /// Closed, consistently oriented meshes cull their back faces (never visible; half the
    /// fragments); open ones are two-sided.
    void drawMeshes(const FrameScene& scene, const Camera& camera, const FrameSetup& f, bool seeThroughPass) {
        const ShaderProgram* bound = nullptr;
        for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
            if (meshes[i].indexCount == 0) continue;
            const DrawMesh& m = scene.meshes[i];
            if (seeThrough(m) != seeThroughPass) continue;
            const ShaderProgram& p = m.scalar.empty() ? meshPlainProgram : meshProgram;
            if (bound != &p) {
                glUseProgram(p.id());
                setMat4(p, "uClipFromWorld", f.clipFromWorld);
                setLighting(p, f.lights);
                setInt(p, "uFootprint", 0);
                setInt(p, "uBaseColourMap", kBaseColourUnit);
                setVec3(p, "uEye", camera.eye);
                bound = &p;
            }
            setFloat(p, "uOpacity", std::clamp(m.opacity, 0.0, 1.0));
            if (!m.scalar.empty()) {
                setVec3(p, "uRampLow", m.ramp.low.cwiseMax(0.0).cwiseMin(1.0));
                setVec3(p, "uRampHigh", m.ramp.high.cwiseMax(0.0).cwiseMin(1.0));
                setFloat(p, "uRampMin", m.ramp.min);
                setFloat(p, "uRampGlow", std::clamp(m.ramp.glow, 0.0, 1.0));
                if (settings.linearPlanes)
                    setInt(p, "uMatteAlongRamp", (m.ramp.low - m.colour).cwiseAbs().maxCoeff() < 1e-6 ? 1 : 0);
                const Real span = m.ramp.max - m.ramp.min;
                setFloat(p, "uRampInvSpan", span > 0 ? 1.0 / span : 0.0);
            }
            bindTriangles(i, false);
            for (const MeshSlot::Range& r : meshes[i].ranges) {
                setSurface(p, m, r.material >= 0 ? &m.materials[static_cast<std::size_t>(r.material)] : nullptr);
                glDrawElements(GL_TRIANGLES, r.count, GL_UNSIGNED_INT,
                               reinterpret_cast<const void*>(static_cast<std::size_t>(r.first) * sizeof(GLuint)));
            }
        }
        glBindVertexArray(0);
        glDisable(GL_CULL_FACE);
        glCullFace(GL_BACK);
    }

    /// The floor's cells: a 4x4 grid whose centre cell bounds where shadows can fall.
    void drawGroundCells(const FrameScene& scene, const FrameSetup& f) {
        // Where shadows can fall: the bounding sphere projected along the key light onto
        // the ground, an ellipse whose bounding box is the f.centre cell (plus the PCF reach).
        const Vec3& k = f.lights.keyDir;
        const Vec3 shadowCentre = f.centre - k * ((f.centre.y() - f.groundY) / k.y());
        const Real reach = 1.05 * f.radius + 4.0 * f.lights.shadowRadius * f.radius +
                           (softShadows ? 2.0 * f.lights.searchRadius * f.radius : 0.0);
        const Real halfX = reach * std::sqrt(1 + (k.x() / k.y()) * (k.x() / k.y()));
        const Real halfZ = reach * std::sqrt(1 + (k.z() / k.y()) * (k.z() / k.y()));
        const Real outer[4] = {f.centre.x() - f.fadeOuter, f.centre.x() + f.fadeOuter, f.centre.z() - f.fadeOuter,
                               f.centre.z() + f.fadeOuter};
        auto clampX = [&](Real v) { return std::clamp(v, outer[0], outer[1]); };
        auto clampZ = [&](Real v) { return std::clamp(v, outer[2], outer[3]); };
        const Real xs[4] = {outer[0], clampX(shadowCentre.x() - halfX), clampX(shadowCentre.x() + halfX), outer[1]};
        const Real zs[4] = {outer[2], clampZ(shadowCentre.z() - halfZ), clampZ(shadowCentre.z() + halfZ), outer[3]};
        float grid[16 * 3];
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                float* v = grid + (j * 4 + i) * 3;
                v[0] = static_cast<float>(xs[i]);
                v[1] = static_cast<float>(f.groundY);
                v[2] = static_cast<float>(zs[j]);
            }
        glBindBuffer(GL_ARRAY_BUFFER, groundVbo);
        glBufferSubData(GL_ARRAY_BUFFER, 0, sizeof grid, grid);
        glBindVertexArray(groundVao);
        for (const ShaderProgram* program : {&groundPlainProgram, &groundProgram}) {
            const ShaderProgram& p = *program;
            glUseProgram(p.id());
            setMat4(p, "uClipFromWorld", f.clipFromWorld);
            setLighting(p, f.lights);
            setVec3(p, "uGroundCentre", f.centre);
            setFloat(p, "uFadeInner", f.fadeInner);
            setFloat(p, "uFadeOuter", f.fadeOuter);
            setVec3(p, "uGroundAlbedo", Vec3::Constant(0.40));
            setInt(p, "uCatcher", settings.transparentBackground ? 1 : 0);
            setInt(p, "uFootprint", f.groundAtOutput ? 1 : 0);
            setInt(p, "uDecal", 2);
            setInt(p, "uHasDecal", f.haveDecal ? 1 : 0);
            setFloat(p, "uDecalGlow", scene.groundMarkGlow);
            glUniform4f(p.uniform("uDecalRect"), static_cast<float>(f.decalRect[0]), static_cast<float>(f.decalRect[1]),
                        static_cast<float>(f.decalRect[2]), static_cast<float>(f.decalRect[3]));
            if (program == &groundPlainProgram) {
                glDrawElements(GL_TRIANGLES, kGroundOuterIndices, GL_UNSIGNED_INT, nullptr);
            } else {
                glDrawElements(GL_TRIANGLES, 6, GL_UNSIGNED_INT,
                               reinterpret_cast<const void*>(kGroundOuterIndices * sizeof(unsigned)));
            }
        }
        glBindVertexArray(0);
    }

    /// Overlays last: depth-tested ones pulled slightly towards the eye (lines on a surface stay
    /// visible), on-top ones without the depth test. Flat colour, opaque.
    void drawOverlays(const FrameScene& scene, const FrameSetup& f) {
        const int w = settings.width, h = settings.height;
        const GLenum bothTargets[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
        buildOverlays(scene, f.clipFromWorld, w, h);
        if (!overlayDraws.empty()) {
            glDrawBuffers(1, bothTargets);  // overlays leave the contact matte as it is
            glUseProgram(overlayProgram.id());
            glBindVertexArray(overlayVao);
            glEnable(GL_POLYGON_OFFSET_FILL);
            glPolygonOffset(-1.0f, -4.0f);
            for (const OverlayDraw& d : overlayDraws) {
                if (d.onTop)
                    glDisable(GL_DEPTH_TEST);
                else
                    glEnable(GL_DEPTH_TEST);
                setVec3(overlayProgram, "uColour", d.colour.cwiseMax(0.0).cwiseMin(1.0));
                setInt(overlayProgram, "uRound", d.round ? 1 : 0);
                glDrawArrays(GL_TRIANGLES, d.first, d.count);
            }
            glDisable(GL_POLYGON_OFFSET_FILL);
            glEnable(GL_DEPTH_TEST);
            glBindVertexArray(0);
        }
    }

    /// Pass 2: the scene at n x n resolution: premultiplied linear colour, alpha = coverage (and
    /// the contact matte, cleared to 0 with it).
    void scenePass(const FrameScene& scene, const Camera& camera, FrameSetup& f) {
        const int w = settings.width, h = settings.height, factor = settings.supersample;
        glBindFramebuffer(GL_FRAMEBUFFER, sceneFbo);
        const GLenum bothTargets[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
        glDrawBuffers(settings.linearPlanes ? 2 : 1, bothTargets);
        glViewport(0, 0, w * factor, h * factor);
        glClearColor(0, 0, 0, 0);
        glClearDepth(1.0);
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_LESS);
        glDepthMask(GL_TRUE);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        if (softShadows) {
            glActiveTexture(GL_TEXTURE3);
            glBindTexture(GL_TEXTURE_2D, shadowDepth);
            glBindSampler(3, depthSampler);
        }
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, shadowDepth);

        // Meshes first, so that early depth testing rejects the ground behind them; see-through
        // meshes (opacity < 1) after the ground.
        const bool anySeeThrough = std::any_of(scene.meshes.begin(), scene.meshes.end(), seeThrough);
        drawMeshes(scene, camera, f, false);
        // With the eye above the ground plane and every mesh point above it, the ground can never
        // hide a mesh, so it is shaded once per output pixel into its own target and composited
        // under the supersampled meshes in the resolve: a quarter of the fragments at 2x2.
        // Otherwise (eye below the plane, or a mesh reaching below a given ground height) it is
        // drawn here, depth-tested, at n x n.
        f.groundAtOutput = f.drawGround && camera.eye.y() > f.groundY && f.bounds.min.y() >= f.groundY - 1e-3 * f.radius;
        f.haveDecal = f.drawGround && !scene.groundMarks.empty() && !settings.transparentBackground;
        if (f.haveDecal) {
            glActiveTexture(GL_TEXTURE2);
            f.decalRect = uploadGroundMarks(scene.groundMarks);
            glActiveTexture(GL_TEXTURE0);
        }
        if (f.drawGround && !f.groundAtOutput) drawGroundCells(scene, f);
        if (anySeeThrough) {
            // Premultiplied "over" in scene order; depth-tested against the opaque surfaces and
            // the ground, without writing depth (a closed mesh culls its back faces: one layer).
            glEnable(GL_BLEND);
            glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
            glDepthMask(GL_FALSE);
            drawMeshes(scene, camera, f, true);
            glDepthMask(GL_TRUE);
            glDisable(GL_BLEND);
        }

        drawOverlays(scene, f);
        if (f.groundAtOutput) {
            glBindFramebuffer(GL_FRAMEBUFFER, groundFbo);
            glDrawBuffers(settings.linearPlanes ? 2 : 1, bothTargets);
            glViewport(0, 0, w, h);
            glClearColor(0, 0, 0, 0);
            glClear(GL_COLOR_BUFFER_BIT);
            glDisable(GL_DEPTH_TEST);
            drawGroundCells(scene, f);  // the shadow map is still bound to unit 0
        }
    }

    /// Pass 3: box downsample, composite or un-premultiply -> linear RGBA16F (sRGB on the CPU).
    void resolvePass(const FrameSetup& f) {
        const int w = settings.width, h = settings.height;
        glBindFramebuffer(GL_FRAMEBUFFER, outFbo);
        glViewport(0, 0, w, h);
        glDisable(GL_DEPTH_TEST);
        glUseProgram(resolveProgram.id());
        glBindTexture(GL_TEXTURE_2D, sceneColour);
        setInt(resolveProgram, "uColour", 0);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_2D, groundColour);
        glActiveTexture(GL_TEXTURE0);
        setInt(resolveProgram, "uGround", 1);
        setInt(resolveProgram, "uHasGround", f.groundAtOutput ? 1 : 0);
        setInt(resolveProgram, "uTransparent", settings.transparentBackground ? 1 : 0);
        setVec3(resolveProgram, "uBackground", settings.background);
        glBindVertexArray(emptyVao);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glBindVertexArray(0);

    }

    /// Reads back the half floats (bottom row first) and flips them into the top-down Image while
    /// encoding: colour through the exact sRGB table, alpha linear. Pixels the resolve marked as
    /// uncovered (alpha < 0) get the background exactly, round(65535 * srgb(bg)), or (0,0,0,0)
    /// when transparent.
    Image readBack() {
        const int w = settings.width, h = settings.height;
        readback.resize(static_cast<std::size_t>(w) * h * 4);
        glPixelStorei(GL_PACK_ALIGNMENT, 2);
        glReadPixels(0, 0, w, h, GL_RGBA, GL_HALF_FLOAT, readback.data());
        checkGlError("rendering a frame");
        glBindFramebuffer(GL_FRAMEBUFFER, 0);

        std::uint16_t background[4] = {0, 0, 0, 0};
        if (!settings.transparentBackground) {
            for (int c = 0; c < 3; ++c)
                background[c] = static_cast<std::uint16_t>(std::lround(65535.0 * encodeSrgb(settings.background[c])));
            background[3] = 65535;
        }
        Image image(w, h);
        const std::size_t rowSamples = static_cast<std::size_t>(w) * 4;
        parallelFor(
            static_cast<Index>(h),
            [&](Index yi) {
                const std::size_t y = static_cast<std::size_t>(yi);
                const std::uint16_t* src = readback.data() + rowSamples * (static_cast<std::size_t>(h) - 1 - y);
                std::uint16_t* dst = image.rgba.data() + rowSamples * y;
                for (std::size_t i = 0; i < rowSamples; i += 4) {
                    if (src[i + 3] & 0x8000) {  // negative alpha: nothing drawn here
                        std::memcpy(dst + i, background, sizeof background);
                        continue;
                    }
                    dst[i] = srgbOfHalf[src[i]];
                    dst[i + 1] = srgbOfHalf[src[i + 1]];
                    dst[i + 2] = srgbOfHalf[src[i + 2]];
                    dst[i + 3] = unormOfHalf[src[i + 3]];
                }
            },
            16);
        return image;
    }

    Image render(const FrameScene& scene, const Camera& camera, LinearImage* linear) {
        if (linear && !settings.linearPlanes)
            throw std::logic_error("Renderer::render: linear planes need RenderSettings::linearPlanes");
        auto t0 = std::chrono::steady_clock::now();
        context.makeCurrent();
        const int w = settings.width, h = settings.height, factor = settings.supersample;
        ensureTargets(w, h, factor);

        FrameSetup f;
        // Scene f.bounds (meshes only) and the upload of positions and normals.
        while (meshes.size() < scene.meshes.size()) meshes.emplace_back();
        for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
            for (const Vec3& p : scene.meshes[i].positions) f.bounds.extend(p);
            uploadMesh(meshes[i], scene.meshes[i]);
        }
        for (std::size_t i = scene.meshes.size(); i < meshes.size(); ++i) meshes[i].indexCount = 0;
        timings.prepareMs = msSince(t0);
        t0 = std::chrono::steady_clock::now();
        f.haveGeometry = !f.bounds.empty();
        f.centre = f.haveGeometry ? f.bounds.centre() : Vec3::Zero();
        f.radius = f.haveGeometry ? 0.5 * f.bounds.size().norm() : 1.0;
        if (!(f.radius > 0)) f.radius = 1e-3;

        f.lights = worldLights(camera);

        // Ground: a quad at the given height, else under the lowest point, fading out radially.
        f.groundY = scene.groundHeight ? *scene.groundHeight : f.haveGeometry ? f.bounds.min.y() : 0.0;
        f.fadeInner = 1.2 * f.radius;
        f.fadeOuter = 4.0 * f.radius;
        f.drawGround = scene.groundPlane && f.haveGeometry;

        depthRange(scene, camera, f);
        const Real aspect = static_cast<Real>(w) / h;
        f.clipFromWorld = camera.clipFromView(aspect, f.nearZ, f.farZ) * camera.viewFromWorld();

        glDisable(GL_BLEND);
        glDisable(GL_CULL_FACE);
        glDisable(GL_SCISSOR_TEST);
        shadowPass(scene, f);
        if (settings.profilePasses) {
            glFinish();
            timings.shadowMs = msSince(t0);
        }
        const auto tScene = std::chrono::steady_clock::now();
        scenePass(scene, camera, f);
        if (settings.profilePasses) {
            glFinish();
            timings.sceneMs = msSince(tScene);
        }
        const auto tResolve = std::chrono::steady_clock::now();
        resolvePass(f);
        glFinish();
        if (settings.profilePasses) timings.resolveMs = msSince(tResolve);
        timings.drawMs = msSince(t0);
        t0 = std::chrono::steady_clock::now();
        Image image = readBack();
        if (linear)
            *linear = linearPlanes(camera, f.nearZ, f.farZ,
                                   f.drawGround && f.groundAtOutput ? std::optional<Real>(f.groundY) : std::nullopt);
        timings.readbackMs = msSince(t0);
        return image;
    }
};

Renderer::Renderer(const RenderSettings& settings) {
    const std::vector<std::string> problems = settings.validate();
    if (!problems.empty()) {
        std::string all;
        for (const std::string& p : problems) all += (all.empty() ? "" : "; ") + p;
        throw InputError("render settings", "", all);
    }
    mImpl = std::make_unique<Impl>(settings);
}

Renderer::~Renderer() = default;

Image Renderer::render(const FrameScene& scene, const Camera& camera, LinearImage* linear) {
    return mImpl->render(scene, camera, linear);
}

std::string Renderer::glRenderer() const { return mImpl->context.description(); }

GlBackend Renderer::backend() const { return mImpl->context.backend(); }

Renderer::Timings Renderer::lastTimings() const { return mImpl->timings; }

}  // namespace dgv
