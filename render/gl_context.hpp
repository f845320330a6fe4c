#pragma once
/// @file gl_context.hpp
/// @brief (internal to render/) An OSMesa core-profile context (gallium llvmpipe). No GL
/// headers here: the context is an opaque pointer. Rendering goes to the caller's FBOs; the
/// OSMesa buffer itself is a 16x16 scratch that is never read.

#include <string>
#include <vector>

namespace dgv::render {

class GlContext {
public:
    /// Creates a 3.3+ core context (OSMesa returns 4.5 on Mesa 22) and makes it current.
    /// RuntimeError when OSMesa refuses, or GL_RENDERER is null (e.g. libGL linked by mistake).
    GlContext();
    ~GlContext();
    GlContext(const GlContext&) = delete;
    GlContext& operator=(const GlContext&) = delete;

    /// Makes this context current in the calling thread. RuntimeError on failure.
    void makeCurrent();

    /// "llvmpipe (LLVM 15.0.6, 256 bits); 4.5 (Core Profile) Mesa 22.3.6".
    const std::string& description() const { return mDescription; }

private:
    void* mContext = nullptr;  // OSMesaContext
    std::vector<unsigned char> mScratch;
    std::string mDescription;
};

}  // namespace dgv::render
