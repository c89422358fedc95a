#pragma once
// A headless OpenGL 4.5 core context through EGL, without any display server.
//
// Platforms, tried in order unless DFB_EGL_PLATFORM names one:
//   "surfaceless" - EGL_MESA_platform_surfaceless (Mesa llvmpipe or a Mesa GPU driver);
//   "device"      - EGL_EXT_platform_device (NVIDIA's EGL needs this one).
// A context is current on the thread that created it; use it from that thread only.

#include <dfb/core/Result.h>

#include <memory>
#include <string>

namespace dfb::gl {

class Context {
public:
    /// Creates the context and makes it current on the calling thread. Fails with GpuError and a
    /// message naming the step (no EGL, no platform, no 4.5 core context) instead of crashing.
    static Result<std::unique_ptr<Context>> create();
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    /// "renderer | version | platform", for logs and benchmark tables.
    const std::string& description() const { return mDescription; }

    /// Makes this context current on the calling thread (several contexts may live in one
    /// process, e.g. a test with two engines). Returns GpuError if EGL refuses.
    Status makeCurrent() const;

    /// Checks glGetError and the robustness reset status; returns a GpuError naming `where`.
    Status check(const char* where) const;

private:
    Context() = default;
    void* mDisplay = nullptr;
    void* mContext = nullptr;
    std::string mDescription;
};

} // namespace dfb::gl
