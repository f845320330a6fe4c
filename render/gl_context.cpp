#include "render/gl_context.hpp"

#include "base/errors.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/glcorearb.h>

namespace dgv::render {

namespace {
constexpr int kScratchSize = 16;

std::string glString(GLenum name) {
    const GLubyte* s = glGetString(name);
    return s ? reinterpret_cast<const char*>(s) : std::string();
}
}  // namespace

GlContext::GlContext() : mScratch(kScratchSize * kScratchSize * 4, 0) {
    // Only the FBOs are drawn to, so the OSMesa buffer needs no depth or stencil.
    const int attribs[] = {OSMESA_FORMAT,
                           OSMESA_RGBA,
                           OSMESA_DEPTH_BITS,
                           0,
                           OSMESA_STENCIL_BITS,
                           0,
                           OSMESA_ACCUM_BITS,
                           0,
                           OSMESA_PROFILE,
                           OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION,
                           3,
                           OSMESA_CONTEXT_MINOR_VERSION,
                           3,  // OSMesa returns >= the request (4.5); 4.6 would fail
                           0};
    OSMesaContext ctx = OSMesaCreateContextAttribs(attribs, nullptr);
    if (!ctx) {
        throw RuntimeError("OSMesa: cannot create an OpenGL 3.3 core-profile context "
                           "(is libOSMesa from Mesa >= 20 with llvmpipe installed?)");
    }
    mContext = ctx;
    makeCurrent();
    const std::string renderer = glString(GL_RENDERER);
    if (renderer.empty()) {
        OSMesaDestroyContext(ctx);
        mContext = nullptr;
        throw RuntimeError("OpenGL: glGetString(GL_RENDERER) returned null: GL calls are not "
                           "reaching OSMesa (is libGL linked as well as libOSMesa?)");
    }
    mDescription = renderer + "; " + glString(GL_VERSION);
}

GlContext::~GlContext() {
    if (mContext) OSMesaDestroyContext(static_cast<OSMesaContext>(mContext));
}

void GlContext::makeCurrent() {
    if (!OSMesaMakeCurrent(static_cast<OSMesaContext>(mContext), mScratch.data(), GL_UNSIGNED_BYTE,
                           kScratchSize, kScratchSize)) {
        throw RuntimeError("OSMesa: OSMesaMakeCurrent failed");
    }
}

}  // namespace dgv::render
