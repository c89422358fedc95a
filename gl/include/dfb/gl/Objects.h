#pragma once
// Owners for OpenGL objects: each releases its name when destroyed, so every GL object has exactly
// one owner (issue 5). Move-only. Must be destroyed on the thread whose context created them.

#include <dfb/core/Result.h>

#include <epoxy/gl.h>

#include <string_view>
#include <utility>
#include <vector>

namespace dfb::gl {

template <void (*Deleter)(GLuint)> class Handle {
public:
    Handle() = default;
    explicit Handle(GLuint id) : mId(id) {}
    ~Handle() { reset(); }
    Handle(Handle&& o) noexcept : mId(std::exchange(o.mId, 0)) {}
    Handle& operator=(Handle&& o) noexcept {
        if (this != &o) {
            reset();
            mId = std::exchange(o.mId, 0);
        }
        return *this;
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;

    GLuint id() const { return mId; }
    explicit operator bool() const { return mId != 0; }
    void reset() {
        if (mId) Deleter(mId);
        mId = 0;
    }

private:
    GLuint mId = 0;
};

void deleteTexture(GLuint id);
void deleteBuffer(GLuint id);
void deleteFramebuffer(GLuint id);
void deleteVertexArray(GLuint id);
void deleteProgram(GLuint id);
void deleteQuery(GLuint id);

using Texture = Handle<deleteTexture>;
using Buffer = Handle<deleteBuffer>;
using Framebuffer = Handle<deleteFramebuffer>;
using VertexArray = Handle<deleteVertexArray>;
using Program = Handle<deleteProgram>;
using Query = Handle<deleteQuery>;

/// An immutable 2D texture (glTextureStorage2D) with nearest filtering and clamp-to-edge.
Texture makeTexture2D(GLenum internalFormat, int width, int height);
/// An immutable 2D array texture (glTextureStorage3D) of `layers` layers, filtered and wrapped
/// as makeTexture2D's.
Texture makeTexture2DArray(GLenum internalFormat, int width, int height, int layers);
Buffer makeBuffer(const void* data, size_t bytes, GLbitfield flags = 0);
/// A buffer texture over `buffer` (texelFetch from a samplerBuffer). On llvmpipe a shader's
/// texelFetch is one vector gather where a storage-buffer read at a per-lane index is a loop over
/// the lanes.
Texture makeBufferTexture(GLenum internalFormat, const Buffer& buffer);

/// One shader stage's source. `name` is the file name used in error messages.
struct ShaderSource {
    GLenum stage;
    std::string_view name;
    std::string_view source;
};

/// Compiles and links a program; errors carry the file name and the driver's log.
Result<Program> buildProgram(const std::vector<ShaderSource>& stages);

/// Checks that the bound draw framebuffer `fb` is complete.
Status checkFramebuffer(GLuint fb, const char* what);

/// A framebuffer with the 2D texture `color` (0: none, draw buffer NONE) and the depth texture
/// `depth` (0: none) attached at level 0, checked complete (error names `what`).
Result<Framebuffer> makeFramebuffer(GLuint color, GLuint depth, const std::string& what);

} // namespace dfb::gl
