#include <dfb/gl/Context.h>

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace dfb::gl {
namespace {

std::string eglErrorName(EGLint e) {
    switch (e) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    default: return "EGL error " + std::to_string(e);
    }
}

bool hasExtension(const char* list, const char* name) {
    if (!list) return false;
    const size_t n = std::strlen(name);
    for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    }
    return false;
}

EGLDisplay openDisplay(const std::string& want, std::string& platformName, std::string& why) {
    const char* clientExts = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!clientExts) {
        why = "EGL client extensions unavailable (EGL 1.5 / EGL_EXT_client_extensions needed)";
        return EGL_NO_DISPLAY;
    }
    auto trySurfaceless = [&]() -> EGLDisplay {
        if (!hasExtension(clientExts, "EGL_MESA_platform_surfaceless")) return EGL_NO_DISPLAY;
        platformName = "surfaceless";
        return eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    };
    auto tryDevice = [&]() -> EGLDisplay {
        // NVIDIA's EGL advertises EGL_EXT_device_base, which includes device enumeration.
        if (!hasExtension(clientExts, "EGL_EXT_platform_device") ||
            !(hasExtension(clientExts, "EGL_EXT_device_enumeration") || hasExtension(clientExts, "EGL_EXT_device_base"))) {
            return EGL_NO_DISPLAY;
        }
        EGLDeviceEXT devices[16];
        EGLint count = 0;
        if (!eglQueryDevicesEXT(16, devices, &count) || count == 0) return EGL_NO_DISPLAY;
        for (EGLint i = 0; i < count; ++i) {
            EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
            if (d == EGL_NO_DISPLAY) continue;
            EGLint major = 0, minor = 0;
            if (eglInitialize(d, &major, &minor)) {
                platformName = "device " + std::to_string(i);
                return d;
            }
        }
        return EGL_NO_DISPLAY;
    };
    EGLDisplay d = EGL_NO_DISPLAY;
    if (want.empty() || want == "surfaceless") d = trySurfaceless();
    if (d == EGL_NO_DISPLAY && (want.empty() || want == "device")) d = tryDevice();
    if (d == EGL_NO_DISPLAY) {
        why = "no usable EGL platform (tried " + (want.empty() ? std::string("surfaceless, device") : want) +
              "; client extensions: " + clientExts + ")";
    }
    return d;
}

} // namespace

Result<std::unique_ptr<Context>> Context::create() {
    const char* env = std::getenv("DFB_EGL_PLATFORM");
    std::string platform, why;
    EGLDisplay display = openDisplay(env ? env : "", platform, why);
    if (display == EGL_NO_DISPLAY) return makeError(ErrorCode::GpuError, why);

    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) {
        return makeError(ErrorCode::GpuError,
                         "eglInitialize failed on the " + platform + " platform: " + eglErrorName(eglGetError()));
    }
    if (!eglBindAPI(EGL_OPENGL_API)) {
        return makeError(ErrorCode::GpuError, "eglBindAPI(EGL_OPENGL_API) failed: " + eglErrorName(eglGetError()));
    }
    const char* dispExts = eglQueryString(display, EGL_EXTENSIONS);
    EGLConfig config = EGL_NO_CONFIG_KHR;
    if (!hasExtension(dispExts, "EGL_KHR_no_config_context")) {
        const EGLint attrs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                EGL_NONE};
        EGLint n = 0;
        if (!eglChooseConfig(display, attrs, &config, 1, &n) || n == 0) {
            return makeError(ErrorCode::GpuError, "no EGL config with OpenGL support");
        }
    }
    // Robust access lets a lost context surface as an error instead of a hang (when supported).
    const bool robust = hasExtension(dispExts, "EGL_EXT_create_context_robustness");
    std::vector<EGLint> ctxAttrs = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT};
    if (robust) {
        ctxAttrs.insert(ctxAttrs.end(), {EGL_CONTEXT_OPENGL_RESET_NOTIFICATION_STRATEGY,
                                         EGL_LOSE_CONTEXT_ON_RESET});
    }
    ctxAttrs.push_back(EGL_NONE);
    EGLContext ctx = eglCreateContext(display, config, EGL_NO_CONTEXT, ctxAttrs.data());
    if (ctx == EGL_NO_CONTEXT && robust) {
        ctxAttrs.resize(6);
        ctxAttrs.push_back(EGL_NONE);
        ctx = eglCreateContext(display, config, EGL_NO_CONTEXT, ctxAttrs.data());
    }
    if (ctx == EGL_NO_CONTEXT) {
        return makeError(ErrorCode::GpuError, "could not create an OpenGL 4.5 core context on the " +
                                                  platform + " platform: " + eglErrorName(eglGetError()));
    }
    if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
        eglDestroyContext(display, ctx);
        return makeError(ErrorCode::GpuError,
                         "eglMakeCurrent without surface failed: " + eglErrorName(eglGetError()));
    }
    std::unique_ptr<Context> c(new Context());
    c->mDisplay = display;
    c->mContext = ctx;
    c->mDescription = std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))) + " | " +
                      reinterpret_cast<const char*>(glGetString(GL_VERSION)) + " | EGL " + platform;
    return c;
}

Context::~Context() {
    if (mDisplay) {
        eglMakeCurrent(mDisplay, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (mContext) eglDestroyContext(mDisplay, mContext);
        // eglTerminate is skipped on purpose: other contexts in the process may share the display.
    }
}

Status Context::makeCurrent() const {
    if (eglGetCurrentContext() == mContext) return okStatus();
    if (!eglMakeCurrent(mDisplay, EGL_NO_SURFACE, EGL_NO_SURFACE, mContext)) {
        return makeError(ErrorCode::GpuError, "eglMakeCurrent failed: " + eglErrorName(eglGetError()));
    }
    return okStatus();
}

Status Context::check(const char* where) const {
    GLenum reset = glGetGraphicsResetStatus();
    if (reset != GL_NO_ERROR) {
        return makeError(ErrorCode::GpuError, std::string("GL context lost (reset status 0x") +
                                                  std::to_string(reset) + ") at " + where);
    }
    GLenum e = glGetError();
    if (e != GL_NO_ERROR) {
        std::string list;
        for (int i = 0; e != GL_NO_ERROR && i < 8; ++i, e = glGetError()) {
            char buf[16];
            std::snprintf(buf, sizeof buf, "0x%04x ", e);
            list += buf;
        }
        return makeError(ErrorCode::GpuError, std::string("GL error ") + list + "at " + where);
    }
    return okStatus();
}

} // namespace dfb::gl
