#pragma once
/// @file gl_context.hpp
/// @brief (internal to render/) An OpenGL 3.3+ core-profile context on Mesa's llvmpipe, from
/// one of two backends: OSMesa, or EGL on a software device / the surfaceless platform (OSMesa
/// is gone from Mesa 25.1). No GL headers here: the context is opaque. Rendering goes to the
/// caller's FBOs; neither backend has a default framebuffer that dgv reads.
///
/// GL entry points come from libOSMesa (GL_GLEXT_PROTOTYPES). Mesa's libOSMesa and its EGL
/// driver share libglapi's current-context dispatch, so the same entry points reach whichever
/// backend's context is current; GlContext checks that (GL_RENDERER must be non-null).

#include "render/renderer.hpp"

#include <memory>
#include <string>
#include <vector>

namespace dgv::render {

class GlContext {
public:
    /// Creates a context with `backend` (Auto: OSMesa, then EGL) and makes it current.
    /// RuntimeError naming the backend(s) and why when none works, or when GL calls do not
    /// reach the context (GL_RENDERER null: e.g. libGL linked by mistake).
    explicit GlContext(GlBackend backend = GlBackend::Auto);
    ~GlContext();
    GlContext(const GlContext&) = delete;
    GlContext& operator=(const GlContext&) = delete;

    /// Makes this context current in the calling thread. RuntimeError on failure.
    void makeCurrent();

    /// "llvmpipe (LLVM 15.0.6, 256 bits); 4.5 (Core Profile) Mesa 22.3.6".
    const std::string& description() const { return mDescription; }
    /// The backend in use (never Auto).
    GlBackend backend() const { return mBackend; }

private:
    void createOsMesa();
    void createEgl();
    void destroy() noexcept;

    GlBackend mBackend = GlBackend::OsMesa;
    void* mContext = nullptr;  // OSMesaContext or EGLContext
    void* mDisplay = nullptr;  // EGLDisplay
    std::vector<unsigned char> mScratch;
    std::string mDescription;
};

}  // namespace dgv::render
