#pragma once
/// @file renderer.hpp
/// @brief Offscreen rendering of a frame to an Image (OSMesa core profile on llvmpipe; GL stays
/// inside render/*.cpp). Shading in linear light, sRGB at output, 2x2 supersampling by default.

#include "base/image.hpp"
#include "base/types.hpp"
#include "render/camera.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace dgv {

/// One surface to draw, in world space. Normals are recomputed from the positions every frame.
struct DrawMesh {
    std::vector<Vec3> positions;
    std::vector<std::array<int, 3>> triangles;  ///< CCW from outside
    Vec3 colour = Vec3(0.8, 0.8, 0.8);          ///< linear RGB albedo in [0,1]
};

struct FrameScene {
    std::vector<DrawMesh> meshes;
    bool groundPlane = true;  ///< a ground under the lowest point, with a soft contact shadow
};

struct RenderSettings {
    int width = 640;
    int height = 360;
    int supersample = 2;                  ///< n x n samples per pixel (1..4)
    Vec3 background = Vec3(0.18, 0.19, 0.21);  ///< linear RGB
    bool transparentBackground = false;   ///< alpha 0 where nothing is drawn
    std::string shaderDir;                ///< empty: found automatically (see findShaderDir)

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

    /// Draws one frame. Deterministic: the same input gives the same pixels.
    Image render(const FrameScene& scene, const Camera& camera);

    /// GL_RENDERER and GL_VERSION, for logs and PNG provenance.
    std::string glRenderer() const;

    /// Wall-clock split of the last render() call, in milliseconds (for benchmarks and logs):
    /// prepare = normals and uploads on the CPU, draw = GL passes until glFinish, readback =
    /// glReadPixels and the row flip.
    struct Timings {
        double prepareMs = 0, drawMs = 0, readbackMs = 0;
    };
    Timings lastTimings() const;

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

}  // namespace dgv
