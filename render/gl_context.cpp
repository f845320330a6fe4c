#include "render/gl_context.hpp"

#include "base/errors.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/osmesa.h>
#include <GL/glcorearb.h>

#include <cstring>

namespace dgv::render {

namespace {
constexpr int kScratchSize = 16;

std::string glString(GLenum name) {
    const GLubyte* s = glGetString(name);
    return s ? reinterpret_cast<const char*>(s) : std::string();
}

bool hasExtension(const char* list, const char* name) {
    if (!list) return false;
    const std::size_t n = std::strlen(name);
    for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}
}  // namespace

GlContext::GlContext(GlBackend backend) {
    if (backend == GlBackend::OsMesa) {
        createOsMesa();
    } else if (backend == GlBackend::Egl) {
        createEgl();
    } else {
        // Auto: OSMesa first. It is always llvmpipe (EGL may pick a GPU driver on a
        // workstation, whose pixels differ from the golden images), and it is silent (Mesa's
        // EGL loader prints driver-probing warnings where there is no DRM device). EGL is
        // the fallback, for Mesa builds without OSMesa (25.1 and later).
        try {
            createOsMesa();
        } catch (const RuntimeError& osmesaError) {
            try {
                createEgl();
            } catch (const RuntimeError& eglError) {
                throw RuntimeError(std::string("no OpenGL context: ") + osmesaError.what() + "; " + eglError.what());
            }
        }
    }
    const std::string renderer = glString(GL_RENDERER);
    if (renderer.empty()) {
        destroy();
        throw RuntimeError("OpenGL (" + glBackendName(mBackend) +
                           "): glGetString(GL_RENDERER) returned null: GL calls are not reaching the "
                           "context (is libGL linked as well as libOSMesa?)");
    }
    mDescription = renderer + "; " + glString(GL_VERSION);
}

void GlContext::createOsMesa() {
    mBackend = GlBackend::OsMesa;
    mScratch.assign(kScratchSize * kScratchSize * 4, 0);
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
        throw RuntimeError(
            "OSMesa: cannot create an OpenGL 3.3 core-profile context "
            "(is libOSMesa from Mesa >= 20 with llvmpipe installed?)");
    }
    mContext = ctx;
    makeCurrent();
}

void GlContext::createEgl() {
    mBackend = GlBackend::Egl;
    auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto queryDeviceString =
        reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    auto getPlatformDisplay =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!getPlatformDisplay)
        throw RuntimeError("EGL: eglGetPlatformDisplayEXT is missing (is libegl-mesa0 installed?)");
    EGLDisplay dpy = EGL_NO_DISPLAY;
    // Mesa's software device (llvmpipe) by name, so a GPU is never picked: the same pixels as
    // OSMesa. Else the surfaceless platform.
    if (queryDevices && queryDeviceString) {
        EGLDeviceEXT devices[16];
        EGLint count = 0;
        if (queryDevices(16, devices, &count)) {
            for (EGLint i = 0; i < count && dpy == EGL_NO_DISPLAY; ++i) {
                if (hasExtension(queryDeviceString(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software"))
                    dpy = getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
            }
        }
    }
    if (dpy == EGL_NO_DISPLAY) dpy = getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (dpy == EGL_NO_DISPLAY) throw RuntimeError("EGL: no software device and no surfaceless platform display");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy, &major, &minor)) throw RuntimeError("EGL: eglInitialize failed");
    mDisplay = dpy;
    if (!eglBindAPI(EGL_OPENGL_API)) {
        destroy();
        throw RuntimeError("EGL: eglBindAPI(EGL_OPENGL_API) failed");
    }
    const EGLint attribs[] = {
        EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    // No config (EGL_KHR_no_config_context): nothing is drawn to an EGL surface.
    EGLContext ctx = eglCreateContext(dpy, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
    if (ctx == EGL_NO_CONTEXT) {
        destroy();
        throw RuntimeError("EGL: cannot create an OpenGL 3.3 core-profile context");
    }
    mContext = ctx;
    makeCurrent();
}

void GlContext::destroy() noexcept {
    if (mBackend == GlBackend::OsMesa) {
        if (mContext) OSMesaDestroyContext(static_cast<OSMesaContext>(mContext));
    } else if (mDisplay) {
        auto dpy = static_cast<EGLDisplay>(mDisplay);
        eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (mContext) eglDestroyContext(dpy, static_cast<EGLContext>(mContext));
        eglTerminate(dpy);
    }
    mContext = nullptr;
    mDisplay = nullptr;
}

GlContext::~GlContext() { destroy(); }

void GlContext::makeCurrent() {
    if (mBackend == GlBackend::OsMesa) {
        if (!OSMesaMakeCurrent(static_cast<OSMesaContext>(mContext), mScratch.data(), GL_UNSIGNED_BYTE, kScratchSize,
                               kScratchSize)) {
            throw RuntimeError("OSMesa: OSMesaMakeCurrent failed");
        }
    } else if (!eglMakeCurrent(static_cast<EGLDisplay>(mDisplay), EGL_NO_SURFACE, EGL_NO_SURFACE,
                               static_cast<EGLContext>(mContext))) {
        throw RuntimeError("EGL: eglMakeCurrent failed");
    }
}

}  // namespace dgv::render

namespace dgv {

std::string glBackendName(GlBackend b) {
    switch (b) {
        case GlBackend::Auto:
            return "auto";
        case GlBackend::Egl:
            return "egl";
        case GlBackend::OsMesa:
            return "osmesa";
    }
    return "?";
}

}  // namespace dgv
