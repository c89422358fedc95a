#include <dfb/gbuffer/Baker.h>

#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <string_view>

namespace dfb::shaders {
std::string_view gbufferShader(std::string_view name);
}

namespace dfb {
namespace {

// Side limit for one bake: GL_MAX_TEXTURE_SIZE is at least 16384 on every 4.5 implementation.
constexpr int MAX_BAKE_SIDE = 16384;

struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;
};
static_assert(sizeof(Vertex) == 24, "Vertex must be tightly packed for the VAO layout");

} // namespace

Result<CameraInfo> chooseCamera(const Scene& scene, const BakeOptions& o) {
    const float aspect = float(o.width) / float(o.height);
    const float fov = glm::radians(o.fovDegrees > 0.f ? o.fovDegrees : 40.f);
    SceneCamera cam;
    if (o.lookFrom && o.lookAt) {
        cam = lookAtCamera(*o.lookFrom, *o.lookAt, fov);
    } else if (!o.cameraName.empty()) {
        auto it = std::find_if(scene.cameras.begin(), scene.cameras.end(),
                               [&](const SceneCamera& c) { return c.name == o.cameraName; });
        if (it == scene.cameras.end()) {
            std::string names;
            for (const SceneCamera& c : scene.cameras) names += (names.empty() ? "" : ", ") + c.name;
            return makeError(ErrorCode::MissingData, scene.path + ": no camera named '" + o.cameraName +
                                                         "' (cameras: " + (names.empty() ? "none" : names) + ")");
        }
        cam = *it;
    } else {
        auto it = std::find_if(scene.cameras.begin(), scene.cameras.end(),
                               [](const SceneCamera& c) { return !c.orthographic; });
        cam = it != scene.cameras.end() ? *it : autoFrameCamera(scene.bounds, fov, aspect);
        if (o.fovDegrees > 0.f) cam.yfovRadians = fov;
    }
    if (cam.orthographic) {
        return makeError(ErrorCode::InvalidValue, "camera '" + cam.name + "' is orthographic; only perspective cameras are supported");
    }
    if (!(cam.yfovRadians > 1e-4f && cam.yfovRadians < 3.1f)) {
        return makeError(ErrorCode::InvalidValue, "camera '" + cam.name + "' has an invalid field of view");
    }
    CameraInfo info;
    info.name = cam.name;
    info.worldToCamera = cam.worldToCamera;
    info.yfovRadians = cam.yfovRadians;
    info.aspect = aspect; // the image decides; the vertical field of view is kept
    // Far plane: the file's, or just past the farthest corner of the scene's bounds.
    const glm::vec3 eye = glm::vec3(glm::inverse(cam.worldToCamera)[3]);
    float farthest = 0.f;
    for (int i = 0; i < 8; ++i) {
        glm::vec3 c((i & 1) ? scene.bounds.max.x : scene.bounds.min.x, (i & 2) ? scene.bounds.max.y : scene.bounds.min.y,
                    (i & 4) ? scene.bounds.max.z : scene.bounds.min.z);
        farthest = std::max(farthest, glm::length(c - eye));
    }
    info.zfar = cam.zfar > 0.f ? cam.zfar : farthest * 1.01f + 1e-3f;
    // A near plane far below the scene's size wastes depth precision; glTF files often say 0.01.
    info.znear = std::max(cam.znear > 0.f ? cam.znear : 1e-3f, info.zfar * 1e-5f);
    info.worldToNDC = glm::perspective(info.yfovRadians, info.aspect, info.znear, info.zfar) * info.worldToCamera;
    return info;
}

Result<DeepBuffer> bake(const Scene& scene, const BakeOptions& o) {
    if (o.width < 1 || o.height < 1 || o.width > MAX_BAKE_SIDE || o.height > MAX_BAKE_SIDE) {
        return makeError(ErrorCode::InvalidValue, "bake size " + std::to_string(o.width) + "x" + std::to_string(o.height) +
                                                      " is out of range (1.." + std::to_string(MAX_BAKE_SIDE) + ")");
    }
    auto camera = chooseCamera(scene, o);
    if (!camera) return camera.error();

    auto ctx = gl::Context::create();
    if (!ctx) return ctx.error();

    auto program = gl::buildProgram({{GL_VERTEX_SHADER, "bake_gbuffer.vert", shaders::gbufferShader("bake_gbuffer.vert")},
                                     {GL_FRAGMENT_SHADER, "bake_gbuffer.frag", shaders::gbufferShader("bake_gbuffer.frag")}});
    if (!program) return program.error();

    // Geometry: one vertex and one index buffer for all parts, drawn with a base vertex each.
    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;
    struct Draw {
        size_t firstIndex, count;
        GLint baseVertex;
        const MeshPart* part;
    };
    std::vector<Draw> draws;
    for (const MeshPart& p : scene.parts) {
        draws.push_back({indices.size(), p.indices.size(), GLint(vertices.size()), &p});
        for (size_t i = 0; i < p.positions.size(); ++i) vertices.push_back({p.positions[i], p.normals[i]});
        indices.insert(indices.end(), p.indices.begin(), p.indices.end());
    }
    gl::Buffer vbo = gl::makeBuffer(vertices.data(), vertices.size() * sizeof(Vertex));
    gl::Buffer ibo = gl::makeBuffer(indices.data(), indices.size() * sizeof(uint32_t));
    GLuint vaoId = 0;
    glCreateVertexArrays(1, &vaoId);
    gl::VertexArray vao(vaoId);
    glVertexArrayVertexBuffer(vaoId, 0, vbo.id(), 0, sizeof(Vertex));
    glVertexArrayElementBuffer(vaoId, ibo.id());
    glEnableVertexArrayAttrib(vaoId, 0);
    glEnableVertexArrayAttrib(vaoId, 1);
    glVertexArrayAttribFormat(vaoId, 0, 3, GL_FLOAT, GL_FALSE, offsetof(Vertex, position));
    glVertexArrayAttribFormat(vaoId, 1, 3, GL_FLOAT, GL_FALSE, offsetof(Vertex, normal));
    glVertexArrayAttribBinding(vaoId, 0, 0);
    glVertexArrayAttribBinding(vaoId, 1, 0);

    // Render targets: see the outputs of bake_gbuffer.frag.
    const int W = o.width, H = o.height;
    const GLenum formats[] = {GL_RGBA32F, GL_RGBA32F, GL_RGBA32F, GL_RGBA32F, GL_RGBA32F, GL_RGBA32F, GL_RG32UI};
    constexpr int TARGETS = 7;
    std::vector<gl::Texture> targets;
    GLuint fbId = 0;
    glCreateFramebuffers(1, &fbId);
    gl::Framebuffer fb(fbId);
    GLenum drawBuffers[TARGETS];
    for (int i = 0; i < TARGETS; ++i) {
        targets.push_back(gl::makeTexture2D(formats[i], W, H));
        glNamedFramebufferTexture(fbId, GL_COLOR_ATTACHMENT0 + GLenum(i), targets.back().id(), 0);
        drawBuffers[i] = GL_COLOR_ATTACHMENT0 + GLenum(i);
    }
    gl::Texture depth = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, W, H);
    glNamedFramebufferTexture(fbId, GL_DEPTH_ATTACHMENT, depth.id(), 0);
    glNamedFramebufferDrawBuffers(fbId, TARGETS, drawBuffers);
    if (auto s = gl::checkFramebuffer(fbId, "the G-buffer bake"); !s) return s.error();

    glBindFramebuffer(GL_FRAMEBUFFER, fbId);
    glViewport(0, 0, W, H);
    const float zero[4] = {0, 0, 0, 0};
    const GLuint zeroU[4] = {0, 0, 0, 0};
    for (int i = 0; i < TARGETS - 1; ++i) glClearNamedFramebufferfv(fbId, GL_COLOR, i, zero);
    glClearNamedFramebufferuiv(fbId, GL_COLOR, TARGETS - 1, zeroU);
    const float one = 1.f;
    glClearNamedFramebufferfv(fbId, GL_DEPTH, 0, &one);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);

    glUseProgram(program->id());
    glBindVertexArray(vaoId);
    const CameraInfo& cam = camera.value();
    glUniformMatrix4fv(0, 1, GL_FALSE, glm::value_ptr(cam.worldToNDC));
    glUniformMatrix4fv(1, 1, GL_FALSE, glm::value_ptr(cam.worldToCamera));
    const glm::vec3 eye = cam.position();
    glUniform3f(6, eye.x, eye.y, eye.z);
    for (const Draw& d : draws) {
        const Material& m = scene.materials[d.part->materialId - 1];
        if (m.doubleSided) glDisable(GL_CULL_FACE);
        else glEnable(GL_CULL_FACE);
        glUniform4f(2, m.baseColor.r, m.baseColor.g, m.baseColor.b, m.baseColor.a);
        // glTF's default dielectric specular is F0 = 0.04, stored as specular = 0.5 (F0 = 0.08 * s).
        glUniform4f(3, m.metallic, m.roughness, 0.5f, 1.f);
        glUniform3f(4, m.emissive.r, m.emissive.g, m.emissive.b);
        glUniform2ui(5, d.part->objectId, d.part->materialId);
        glDrawElementsBaseVertex(GL_TRIANGLES, GLsizei(d.count), GL_UNSIGNED_INT,
                                 reinterpret_cast<const void*>(d.firstIndex * sizeof(uint32_t)), d.baseVertex);
    }
    glFinish();
    if (auto s = ctx.value()->check("G-buffer bake draw"); !s) return s.error();

    DeepBuffer b;
    b.allocate(W, H);
    b.camera = cam;
    b.sourcePath = scene.path;
    b.objectNames = scene.objectNames;
    for (const Material& m : scene.materials) b.materialNames.push_back(m.name);

    const size_t n = b.pixelCount();
    std::vector<float> rgba(n * 4);
    std::vector<uint32_t> ids(n * 2);
    // GL's row 0 is the bottom; the deep buffer's row 0 is the top (EXR convention).
    auto srcIndex = [&](size_t dst) {
        const size_t y = dst / size_t(W), x = dst % size_t(W);
        return (size_t(H) - 1 - y) * size_t(W) + x;
    };
    auto readTarget = [&](int t, auto&& store) {
        glGetTextureImage(targets[size_t(t)].id(), 0, GL_RGBA, GL_FLOAT, GLsizei(rgba.size() * sizeof(float)), rgba.data());
        for (size_t i = 0; i < n; ++i) store(i, &rgba[srcIndex(i) * 4]);
    };
    glGetTextureImage(targets[6].id(), 0, GL_RG_INTEGER, GL_UNSIGNED_INT, GLsizei(ids.size() * sizeof(uint32_t)), ids.data());
    for (size_t i = 0; i < n; ++i) {
        b.objectId[i] = ids[srcIndex(i) * 2];
        b.materialId[i] = ids[srcIndex(i) * 2 + 1];
    }
    readTarget(0, [&](size_t i, const float* v) {
        for (int c = 0; c < 3; ++c) b.P[i * 3 + size_t(c)] = v[c];
        b.Z[i] = v[3];
    });
    readTarget(1, [&](size_t i, const float* v) { for (int c = 0; c < 3; ++c) b.N[i * 3 + size_t(c)] = v[c]; });
    readTarget(2, [&](size_t i, const float* v) { for (int c = 0; c < 3; ++c) b.Ng[i * 3 + size_t(c)] = v[c]; });
    readTarget(3, [&](size_t i, const float* v) {
        for (int c = 0; c < 3; ++c) b.albedo[i * 3 + size_t(c)] = v[c];
        b.A[i] = v[3];
    });
    readTarget(4, [&](size_t i, const float* v) { for (int c = 0; c < 4; ++c) b.brdf[i * 4 + size_t(c)] = v[c]; });
    readTarget(5, [&](size_t i, const float* v) { for (int c = 0; c < 3; ++c) b.emission[i * 3 + size_t(c)] = v[c]; });
    if (auto s = ctx.value()->check("G-buffer read-back"); !s) return s.error();
    return b;
}

} // namespace dfb
