#pragma once
/// @file renderer.hpp
/// @brief Offscreen rendering of a frame to an Image (OSMesa or EGL core profile on llvmpipe;
/// GL stays inside render/*.cpp). Shading in linear light, sRGB at output, 2x2 supersampling
/// by default.

#include "base/image.hpp"
#include "base/light.hpp"
#include "base/material.hpp"
#include "base/types.hpp"
#include "render/camera.hpp"
#include "render/environment.hpp"

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace dgv {

/// A colour ramp for a per-vertex scalar (e.g. the contact set R: penetration depth, or
/// frames since contact). Where the interpolated scalar s > 0 the albedo becomes
/// mix(low, high, clamp((s - min) / (max - min), 0, 1)); where s <= 0 it stays the mesh colour,
/// so 0 means "not highlighted".
struct ScalarRamp {
    Vec3 low = Vec3(1.0, 0.85, 0.1);    ///< linear RGB at s = min
    Vec3 high = Vec3(0.9, 0.05, 0.02);  ///< linear RGB at s >= max
    Real min = 0, max = 1;
    /// Where s > 0, `high` times this (0..1) times the ramp's position t = clamp((s − min)/(max −
    /// min)) is also emitted: unlit and unshadowed, so a highlight on a surface turned from the
    /// lights or in a contact shadow still reads, and it fades in with the ramp.
    Real glow = 0;
};

/// One surface to draw, in world space. Normals are recomputed from the positions every frame
/// (area-weighted, split along creases: RenderSettings::creaseDegrees).
struct DrawMesh {
    std::vector<Vec3> positions;
    std::vector<std::array<int, 3>> triangles;  ///< CCW from outside
    Vec3 colour = Vec3(0.8, 0.8, 0.8);          ///< linear RGB albedo in [0,1]
    std::vector<Real> scalar;                   ///< per vertex (same size as positions) or empty
    ScalarRamp ramp;                            ///< how `scalar` colours the surface
    /// Optional (same size as positions): where the crease split is decided when the triangle
    /// list is first seen, instead of this frame's positions. A deforming mesh passes its rest
    /// shape, so a render of frames A-B splits like a render of the whole range.
    std::vector<Vec3> creasePositions;
    /// The file's look (base/material.hpp; both per-triangle lists empty: every triangle in
    /// `colour`). Per triangle its material (an index into `materials`; −1: `colour`) and its
    /// corners' texture coordinates. A material's albedo is its base colour times its texture;
    /// its roughness sets the highlights' width, its metalness tints them and darkens the diffuse.
    /// Where the highlight scalar is > 0 the ramp's colour replaces the albedo.
    std::vector<int> triangleMaterials;
    std::vector<std::array<Eigen::Vector2f, 3>> cornerUvs;
    std::vector<SurfaceMaterial> materials;
    /// 1: opaque. Below 1 (down to 0) the surface is drawn see-through, after the opaque meshes
    /// and the ground, blended over them in scene order without writing depth (an x-ray view of
    /// what lies behind, e.g. a body's contact behind a collider); it still casts its full shadow.
    Real opacity = 1;
};

/// A polyline overlay (curves, GLN network loops, ...): flat, unlit, `width` output pixels
/// wide (screen-space quads per segment, so any width works on any GL). Casts no shadow.
struct Polyline {
    std::vector<Vec3> points;           ///< world space
    bool closed = true;                 ///< also joins the last point to the first
    Vec3 colour = Vec3(1.0, 0.9, 0.1);  ///< linear RGB
    Real width = 2;                     ///< output pixels (> 0)
    bool onTop = false;                 ///< drawn over everything (no depth test); else depth-tested
};

/// Dots (e.g. the lattice points): round, flat, `size` output pixels across. Casts no shadow.
struct PointSet {
    std::vector<Vec3> points;             ///< world space
    Vec3 colour = Vec3(0.05, 0.35, 1.0);  ///< linear RGB
    Real size = 3;                        ///< diameter, output pixels (> 0)
    bool onTop = true;                    ///< drawn over everything (points inside a volume show through)
};

/// A mark on the ground plane (a contact footprint, render.contact.footprint): a disc at
/// (x, z) whose colour covers the ground's albedo by `strength` (0..1) at its centre and by
/// nothing at `radius`, smoothly (a smoothstep in the distance). Where marks overlap, the
/// coverage is 1 − Π(1 − a_i) and the colour the coverage-weighted mean. Lit and shadowed as
/// the ground is; not drawn in the transparent background's shadow-catcher mode.
struct GroundMark {
    Real x = 0, z = 0;
    Real radius = 0;                      ///< world units (> 0)
    Vec3 colour = Vec3(0.9, 0.05, 0.02);  ///< linear RGB
    Real strength = 1;                    ///< 0..1
};

struct FrameScene {
    std::vector<DrawMesh> meshes;
    bool groundPlane = true;  ///< a ground plane with a soft contact shadow
    /// The ground plane's height (y), e.g. a ground collider's; unset: just under the meshes'
    /// lowest point (a studio floor for turntables). A body falling towards a fixed ground
    /// needs it set, or the floor would follow the body down until it lands.
    std::optional<Real> groundHeight;
    /// Overlays, drawn after the surfaces and the ground (they do not move the ground, the
    /// shadow or the lights, which follow the meshes' bounds).
    std::vector<Polyline> lines;
    std::vector<PointSet> points;
    /// Marks drawn into the ground plane (only where it is drawn: groundPlane, at groundHeight).
    std::vector<GroundMark> groundMarks;
    Real groundMarkGlow = 0;  ///< the marks' colour also emitted, times this (as ScalarRamp::glow)
};

/// Today's studio rig, attached to the camera: a key above front-left (the shadows, highlights at
/// exponent 48), a cool fill low front-right, a rim behind (highlights at 24; the floor excluded).
std::vector<Light> defaultLightRig();

/// Where the OpenGL context comes from (both give llvmpipe and bit-identical images on Mesa 22).
enum class GlBackend {
    Auto,    ///< OSMesa, else EGL
    Egl,     ///< EGL: Mesa's software device, else the surfaceless platform
    OsMesa,  ///< OSMesa (removed from Mesa 25.1)
};

/// "auto", "egl", "osmesa".
std::string glBackendName(GlBackend backend);

struct RenderSettings {
    int width = 640;
    int height = 360;
    int supersample = 2;                       ///< n x n samples per pixel (1..4)
    Vec3 background = Vec3(0.18, 0.19, 0.21);  ///< linear RGB
    bool transparentBackground = false;        ///< alpha 0 where nothing is drawn
    std::string shaderDir;                     ///< empty: found automatically (see findShaderDir)
    GlBackend backend = GlBackend::Auto;       ///< the OpenGL context's source
    /// Normals are smoothed across an edge only when its two faces' normals differ by at most
    /// this angle; sharper edges split the vertices (a crisp box). 180: smooth everywhere.
    /// The split is decided when a mesh's triangle list is first seen (0..180 degrees).
    double creaseDegrees = 40;
    /// Supersampled (n >= 2): the fragments of each 2x2 quad share their key-light PCF taps,
    /// two taps each instead of four (shaders/lighting.glsl): the scene pass's texture work
    /// halves, and pixels stay within 4/255 of the four-tap result but for a few on hard shadow
    /// edges. false: four taps per subsample (the reference the tests compare with).
    bool sharedShadowTaps = true;
    /// The key light's angular radius, degrees: a shadow's penumbra widens with the distance
    /// from its blocker (percentage-closer soft shadows, shaders/lighting.glsl), hard at a
    /// contact and soft further off. 0: a point light (the 4-tap kernel alone), 0..15.
    double shadowSoftness = 3;
    /// Finish the GL work after each pass to time it (Timings::shadowMs...). Off in production
    /// renders: the waits stop llvmpipe overlapping passes.
    bool profilePasses = false;
    /// Also keep what compositing needs (render(scene, camera, &linear)): the linear colour, each
    /// pixel's depth and the contact highlight's matte. Off: the scene pass writes one target.
    bool linearPlanes = false;
    /// The lights (up to kMaxLights; at most one casts shadows); empty: defaultLightRig(). A sky
    /// and ground hemisphere adds its soft ambient light under any rig.
    std::vector<Light> lights;
    /// The ambient light from every direction (render.environment); unset: the studio's sky and
    /// bounce hemisphere.
    std::optional<Environment> environment;

    std::vector<std::string> validate() const;  ///< problems by field name; empty when valid
};

/// The folder holding dgv's GLSL files: $DGV_SHADER_DIR, else <exe dir>/shaders,
/// <exe dir>/../share/dgv/shaders, else the source tree's shaders/. RuntimeError if none has them.
std::string findShaderDir();

class Renderer {
public:
    /// Creates the GL context and compiles the shaders. RuntimeError (with the compiler log, or
    /// what OSMesa said) on failure.
    explicit Renderer(const RenderSettings& settings);
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    /// Draws one frame. Deterministic: the same input gives the same pixels. With `linear` (needs
    /// RenderSettings::linearPlanes) it also receives the frame for compositing: the resolve's
    /// linear colour with premultiplied alpha (alpha 1 everywhere unless the background is
    /// transparent), the depth of the nearest of each pixel's samples (the ground plane's too) and
    /// the share of the pixel's samples on a highlighted surface (base/image.hpp, LinearImage).
    Image render(const FrameScene& scene, const Camera& camera, LinearImage* linear = nullptr);

    /// GL_RENDERER and GL_VERSION, for logs and PNG provenance.
    std::string glRenderer() const;
    /// The context backend in use (OsMesa or Egl, never Auto). Use one backend per process:
    /// OSMesa and EGL contexts share Mesa's dispatch, so do not interleave their renders.
    GlBackend backend() const;

    /// Wall-clock split of the last render() call, in milliseconds (for benchmarks and logs):
    /// prepare = normals and uploads on the CPU, draw = GL passes until glFinish, readback =
    /// glReadPixels and the row flip.
    /// With RenderSettings::profilePasses, draw is split into shadow (depth from the key
    /// light), scene (meshes and ground at n x n) and resolve (downsample, sRGB encode).
    struct Timings {
        double prepareMs = 0, drawMs = 0, readbackMs = 0;
        double shadowMs = 0, sceneMs = 0, resolveMs = 0;
    };
    Timings lastTimings() const;

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

}  // namespace dgv
