#include <dfb/gl/Objects.h>

#include <string>

namespace dfb::gl {

void deleteTexture(GLuint id) { glDeleteTextures(1, &id); }
void deleteBuffer(GLuint id) { glDeleteBuffers(1, &id); }
void deleteFramebuffer(GLuint id) { glDeleteFramebuffers(1, &id); }
void deleteVertexArray(GLuint id) { glDeleteVertexArrays(1, &id); }
void deleteProgram(GLuint id) { glDeleteProgram(id); }
void deleteQuery(GLuint id) { glDeleteQueries(1, &id); }

Texture makeTexture2D(GLenum internalFormat, int width, int height) {
    GLuint id = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &id);
    glTextureStorage2D(id, 1, internalFormat, width, height);
    glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return Texture(id);
}

Texture makeTexture2DArray(GLenum internalFormat, int width, int height, int layers) {
    GLuint id = 0;
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &id);
    glTextureStorage3D(id, 1, internalFormat, width, height, layers);
    glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return Texture(id);
}

Texture makeBufferTexture(GLenum internalFormat, const Buffer& buffer) {
    GLuint id = 0;
    glCreateTextures(GL_TEXTURE_BUFFER, 1, &id);
    glTextureBuffer(id, internalFormat, buffer.id());
    return Texture(id);
}

Buffer makeBuffer(const void* data, size_t bytes, GLbitfield flags) {
    GLuint id = 0;
    glCreateBuffers(1, &id);
    glNamedBufferStorage(id, static_cast<GLsizeiptr>(bytes), data, flags);
    return Buffer(id);
}

Result<Program> buildProgram(const std::vector<ShaderSource>& stages) {
    Program program(glCreateProgram());
    std::vector<GLuint> shaders;
    std::string names;
    for (const ShaderSource& s : stages) {
        names += std::string(names.empty() ? "" : ", ") + std::string(s.name);
        if (s.source.empty()) {
            for (GLuint sh : shaders) glDeleteShader(sh);
            return makeError(ErrorCode::MissingData, "shader source " + std::string(s.name) + " is empty");
        }
        GLuint sh = glCreateShader(s.stage);
        const GLchar* src = s.source.data();
        const GLint len = static_cast<GLint>(s.source.size());
        glShaderSource(sh, 1, &src, &len);
        glCompileShader(sh);
        GLint ok = 0;
        glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
        if (!ok) {
            GLint logLen = 0;
            glGetShaderiv(sh, GL_INFO_LOG_LENGTH, &logLen);
            std::string log(static_cast<size_t>(logLen > 0 ? logLen : 1), '\0');
            glGetShaderInfoLog(sh, logLen, nullptr, log.data());
            glDeleteShader(sh);
            for (GLuint o : shaders) glDeleteShader(o);
            return makeError(ErrorCode::GpuError, "compiling " + std::string(s.name) + ": " + log);
        }
        glAttachShader(program.id(), sh);
        shaders.push_back(sh);
    }
    glLinkProgram(program.id());
    for (GLuint sh : shaders) {
        glDetachShader(program.id(), sh);
        glDeleteShader(sh);
    }
    GLint ok = 0;
    glGetProgramiv(program.id(), GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint logLen = 0;
        glGetProgramiv(program.id(), GL_INFO_LOG_LENGTH, &logLen);
        std::string log(static_cast<size_t>(logLen > 0 ? logLen : 1), '\0');
        glGetProgramInfoLog(program.id(), logLen, nullptr, log.data());
        return makeError(ErrorCode::GpuError, "linking " + names + ": " + log);
    }
    return program;
}

Result<Framebuffer> makeFramebuffer(GLuint color, GLuint depth, const std::string& what) {
    GLuint id = 0;
    glCreateFramebuffers(1, &id);
    Framebuffer fb(id);
    if (color) glNamedFramebufferTexture(id, GL_COLOR_ATTACHMENT0, color, 0);
    else glNamedFramebufferDrawBuffer(id, GL_NONE);
    if (depth) glNamedFramebufferTexture(id, GL_DEPTH_ATTACHMENT, depth, 0);
    if (auto s = checkFramebuffer(id, what.c_str()); !s) return s.error();
    return fb;
}

Status checkFramebuffer(GLuint fb, const char* what) {
    GLenum status = glCheckNamedFramebufferStatus(fb, GL_DRAW_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        return makeError(ErrorCode::GpuError, std::string("framebuffer for ") + what +
                                                  " incomplete (status " + std::to_string(status) + ")");
    }
    return okStatus();
}

} // namespace dfb::gl
