#include <dfb/gbuffer/Baker.h>

#include "EnvTracer.h"
#include "HorizonTracer.h"

#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <openssl/evp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string_view>
#include <unordered_map>

namespace dfb::shaders {
std::string_view gbufferShader(std::string_view name);
}

namespace dfb {
namespace {

// Side limit for one bake: GL_MAX_TEXTURE_SIZE is at least 16384 on every 4.5 implementation.
constexpr int MAX_BAKE_SIDE = 16384;
// Texture slots of bake_gbuffer.frag.
constexpr int SLOT_COUNT = 11;
// Render targets of bake_gbuffer.frag (8 = the minimum GL_MAX_DRAW_BUFFERS of GL 4.5).
constexpr int TARGETS = 8;
// Object and material ids travel through float render targets: exact below 2^24.
constexpr uint32_t MAX_ID = 1u << 24;

struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;
    glm::vec4 tangent;
    glm::vec2 uv0;
    glm::vec2 uv1;
    glm::vec4 color;
};
static_assert(sizeof(Vertex) == 72, "Vertex must be tightly packed for the VAO layout");

// Channels accumulated per merged sample, in the order of the render targets' floats:
// target t, component c -> float t * 4 + c. Ids (2.w, 4.w) are kept apart.
constexpr int FLOATS = TARGETS * 4;

struct Group {
    uint32_t object = 0, material = 0;
    uint32_t count = 0;
    float sum[FLOATS];
    float env[ENV_TRANSFER_COEFFICIENTS]; // summed environment transfer of the points (when baked)
    double lobe[EnvTracer::LOBE_SUMS];    // summed specular-lobe sums of the points (when baked)
    float horizon[HORIZON_AZIMUTHS];      // summed near-field horizons of the points (when baked)
};

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

} // namespace

std::vector<glm::vec2> sampleOffsets(int samples) {
    std::vector<glm::vec2> out;
    const int n = int(std::lround(std::sqrt(double(samples))));
    if (n * n == samples) {
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) out.push_back({(i + 0.5f) / float(n) - 0.5f, (j + 0.5f) / float(n) - 0.5f});
        return out;
    }
    // R2 quasi-random sequence (Roberts 2018): well spread for any count.
    const double g = 1.32471795724474602596;
    const double a1 = 1.0 / g, a2 = 1.0 / (g * g);
    for (int i = 0; i < samples; ++i) {
        const double x = std::fmod(0.5 + a1 * (i + 1), 1.0), y = std::fmod(0.5 + a2 * (i + 1), 1.0);
        out.push_back({float(x) - 0.5f, float(y) - 0.5f});
    }
    return out;
}

Result<std::string> sha256File(const std::string& path) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return makeError(ErrorCode::IoError, path + ": cannot open for hashing");
    EVP_MD_CTX* ctx = EVP_MD_CTX_new();
    EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
    std::vector<unsigned char> buf(1 << 16);
    size_t n;
    while ((n = std::fread(buf.data(), 1, buf.size(), f)) > 0) EVP_DigestUpdate(ctx, buf.data(), n);
    const bool failed = std::ferror(f) != 0;
    std::fclose(f);
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned len = 0;
    EVP_DigestFinal_ex(ctx, digest, &len);
    EVP_MD_CTX_free(ctx);
    if (failed) return makeError(ErrorCode::IoError, path + ": read error while hashing");
    std::string hex;
    char two[3];
    for (unsigned i = 0; i < len; ++i) {
        std::snprintf(two, sizeof two, "%02x", digest[i]);
        hex += two;
    }
    return hex;
}

Result<CameraInfo> chooseCamera(const Scene& scene, const BakeOptions& o) {
    const float aspect = float(o.width) / float(o.height);
    const float fov = glm::radians(o.fovDegrees > 0.f ? o.fovDegrees : 40.f);
    SceneCamera cam;
    if (o.lookFrom && o.lookAt) {
        if (glm::length(*o.lookAt - *o.lookFrom) <= 0.f) {
            return makeError(ErrorCode::InvalidValue, "--look-from and --look-at must differ");
        }
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
        cam = scene.cameras.empty() ? autoFrameCamera(scene, fov, aspect) : scene.cameras.front();
        if (o.fovDegrees > 0.f && !cam.orthographic) cam.yfovRadians = fov;
    }
    CameraInfo info;
    info.name = cam.name;
    info.orthographic = cam.orthographic;
    info.worldToCamera = cam.worldToCamera;
    info.aspect = aspect; // the image decides; the vertical extent is kept
    // Far plane: the file's, or just past the farthest corner of the scene's bounds.
    const glm::vec3 eye = glm::vec3(glm::inverse(cam.worldToCamera)[3]);
    float farthest = 0.f;
    for (int i = 0; i < 8; ++i) {
        glm::vec3 c((i & 1) ? scene.bounds.max.x : scene.bounds.min.x, (i & 2) ? scene.bounds.max.y : scene.bounds.min.y,
                    (i & 4) ? scene.bounds.max.z : scene.bounds.min.z);
        farthest = std::max(farthest, glm::length(c - eye));
    }
    info.zfar = cam.zfar > 0.f ? cam.zfar : farthest * 1.01f + 1e-3f;
    if (cam.orthographic) {
        if (!(cam.ymag > 0.f) || !std::isfinite(cam.ymag)) {
            return makeError(ErrorCode::InvalidValue, "camera '" + cam.name + "' has an invalid orthographic ymag");
        }
        info.yfovRadians = 0.f;
        info.ymag = cam.ymag;
        info.znear = std::max(cam.znear, 0.f);
        info.worldToNDC = glm::ortho(-cam.ymag * aspect, cam.ymag * aspect, -cam.ymag, cam.ymag, info.znear, info.zfar) *
                          info.worldToCamera;
        return info;
    }
    if (!(cam.yfovRadians > 1e-4f && cam.yfovRadians < 3.1f)) {
        return makeError(ErrorCode::InvalidValue, "camera '" + cam.name + "' has an invalid field of view");
    }
    info.yfovRadians = cam.yfovRadians;
    // A near plane far below the scene's size wastes depth precision; glTF files often say 0.01.
    info.znear = std::max(cam.znear > 0.f ? cam.znear : 1e-3f, info.zfar * 1e-5f);
    info.worldToNDC = glm::perspective(info.yfovRadians, info.aspect, info.znear, info.zfar) * info.worldToCamera;
    return info;
}

namespace {

// GL textures for a scene: one per (image, colour space), made on first use, mipmapped.
class TextureCache {
public:
    explicit TextureCache(const Scene& s) : mScene(s) {}
    GLuint texture(int textureIndex, bool srgb) {
        const SceneTexture& t = mScene.textures[size_t(textureIndex)];
        const auto key = std::make_pair(t.image, srgb);
        auto it = mTextures.find(key);
        if (it != mTextures.end()) return it->second.id();
        const SceneImage& img = mScene.images[size_t(t.image)];
        GLuint id = 0;
        glCreateTextures(GL_TEXTURE_2D, 1, &id);
        const int levels = 1 + int(std::floor(std::log2(std::max(img.width, img.height))));
        glTextureStorage2D(id, levels, srgb ? GL_SRGB8_ALPHA8 : GL_RGBA8, img.width, img.height);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        // glTF images have row 0 at the top and UV (0,0) at the top-left, so uploading row 0 to
        // GL's row 0 makes texture(uv) sample the glTF convention directly.
        glTextureSubImage2D(id, 0, 0, 0, img.width, img.height, GL_RGBA, GL_UNSIGNED_BYTE, img.rgba.data());
        glGenerateTextureMipmap(id);
        mTextures.emplace(key, gl::Texture(id));
        return id;
    }
    GLuint sampler(int textureIndex) {
        const SceneTexture& t = mScene.textures[size_t(textureIndex)];
        const std::array<int, 4> key{t.wrapS, t.wrapT, t.minFilter, t.magFilter};
        auto it = mSamplers.find(key);
        if (it != mSamplers.end()) return it->second;
        GLuint id = 0;
        glCreateSamplers(1, &id);
        auto wrap = [](int w) -> GLint {
            return w == GL_CLAMP_TO_EDGE ? GL_CLAMP_TO_EDGE : w == GL_MIRRORED_REPEAT ? GL_MIRRORED_REPEAT : GL_REPEAT;
        };
        glSamplerParameteri(id, GL_TEXTURE_WRAP_S, wrap(t.wrapS));
        glSamplerParameteri(id, GL_TEXTURE_WRAP_T, wrap(t.wrapT));
        glSamplerParameteri(id, GL_TEXTURE_MAG_FILTER, t.magFilter == GL_NEAREST ? GL_NEAREST : GL_LINEAR);
        const bool validMin = t.minFilter == GL_NEAREST || t.minFilter == GL_LINEAR ||
                              (t.minFilter >= GL_NEAREST_MIPMAP_NEAREST && t.minFilter <= GL_LINEAR_MIPMAP_LINEAR);
        glSamplerParameteri(id, GL_TEXTURE_MIN_FILTER, validMin ? t.minFilter : GL_LINEAR_MIPMAP_LINEAR);
        // No anisotropic filtering: Mesa 22.3 llvmpipe's implementation blurs magnified textures
        // (measured: 0.11 error against an exact bilinear lookup, 0.001 without it).
        glSamplerParameterf(id, GL_TEXTURE_MAX_ANISOTROPY, 1.f);
        mSamplers.emplace(key, id);
        return id;
    }
    ~TextureCache() {
        for (auto& [k, id] : mSamplers) glDeleteSamplers(1, &id);
    }

private:
    const Scene& mScene;
    std::map<std::pair<int, bool>, gl::Texture> mTextures;
    std::map<std::array<int, 4>, GLuint> mSamplers;
};

} // namespace

Result<DeepBuffer> bake(const Scene& scene, const BakeOptions& o) {
    if (o.width < 1 || o.height < 1 || o.width > MAX_BAKE_SIDE || o.height > MAX_BAKE_SIDE) {
        return makeError(ErrorCode::InvalidValue, "bake size " + std::to_string(o.width) + "x" + std::to_string(o.height) +
                                                      " is out of range (1.." + std::to_string(MAX_BAKE_SIDE) + ")");
    }
    if (o.samples < 1 || o.samples > MAX_SAMPLES_PER_PIXEL) {
        return makeError(ErrorCode::InvalidValue, "samples per pixel " + std::to_string(o.samples) + " is out of range (1.." +
                                                      std::to_string(MAX_SAMPLES_PER_PIXEL) + ")");
    }
    if (o.envRays < 0 || o.envRays > MAX_ENV_RAYS) {
        return makeError(ErrorCode::InvalidValue, "environment rays per sample " + std::to_string(o.envRays) +
                                                      " is out of range (0.." + std::to_string(MAX_ENV_RAYS) + ")");
    }
    if (!validEnvBands(o.envBands)) {
        return makeError(ErrorCode::InvalidValue, "environment transfer bands " + std::to_string(o.envBands) + " is not 3 or " +
                                                      std::to_string(ENV_TRANSFER_BANDS));
    }
    if (o.horizonRadius != 0.f && !(o.horizonRadius > 0.f && o.horizonRadius <= MAX_HORIZON_RADIUS_FRACTION)) {
        return makeError(ErrorCode::InvalidValue, "near-field horizon radius " + std::to_string(o.horizonRadius) +
                                                      " of the scene's radius is out of range (0 = none, or up to " +
                                                      std::to_string(MAX_HORIZON_RADIUS_FRACTION) + ")");
    }
    if (scene.objectNames.size() >= MAX_ID || scene.materials.size() >= MAX_ID) {
        return makeError(ErrorCode::InvalidValue, scene.path + ": more than 2^24 objects or materials");
    }
    auto camera = chooseCamera(scene, o);
    if (!camera) return camera.error();
    std::string sha;
    if (auto h = sha256File(scene.path); h) sha = h.value(); // scenes loaded from memory have none

    auto ctx = gl::Context::create();
    if (!ctx) return ctx.error();

    auto program = gl::buildProgram({{GL_VERTEX_SHADER, "bake_gbuffer.vert", shaders::gbufferShader("bake_gbuffer.vert")},
                                     {GL_FRAGMENT_SHADER, "bake_gbuffer.frag", shaders::gbufferShader("bake_gbuffer.frag")}});
    if (!program) return program.error();

    // The environment transfer's rays, traced at each pass's exact surface points (Baker.h).
    std::optional<EnvTracer> env;
    EnvTransferStats envStats;
    std::atomic<size_t> envTraced{0};
    if (o.envRays > 0) {
        const auto t0 = Clock::now();
        env.emplace(scene, o.envRays);
        envStats.bvhMs = env->bvhMs();
        envStats.totalMs += msSince(t0);
    }

    // The near-field horizon, traced at each pass's exact surface points too (a merged sample's
    // averaged position may lie inside a curved mesh or a corner; the horizon of the merge is the
    // mean of its points', as for the transfer: on the 16-spp edge test the sun's shadow edges
    // 5.2 % of the mean radiance from the averaged positions' horizons, 4.3 % from the mean).
    std::optional<HorizonTracer> horizon;
    HorizonStats horizonStats;
    std::atomic<size_t> horizonTraced{0};
    if (o.horizonRadius > 0.f) {
        const auto t0 = Clock::now();
        horizon.emplace(scene, o.horizonRadius, env ? env->bvh() : nullptr); // one hierarchy for both
        horizonStats.totalMs += msSince(t0);
    }

    // Work units for the progress report: upload, each sample pass (raster, environment rays,
    // horizon), merging.
    const size_t totalWork = 2 + size_t(o.samples) * (2 + (env ? 1 : 0) + (horizon ? 1 : 0));
    size_t done = 0;
    auto progress = [&]() {
        if (o.progress) o.progress(++done, totalWork);
    };

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
        for (size_t i = 0; i < p.positions.size(); ++i) {
            Vertex v;
            v.position = p.positions[i];
            v.normal = p.normals[i];
            v.tangent = i < p.tangents.size() ? p.tangents[i] : glm::vec4(1, 0, 0, 1);
            v.uv0 = i < p.uv0.size() ? p.uv0[i] : glm::vec2(0.f);
            v.uv1 = i < p.uv1.size() ? p.uv1[i] : glm::vec2(0.f);
            v.color = i < p.colors.size() ? p.colors[i] : glm::vec4(1.f);
            vertices.push_back(v);
        }
        indices.insert(indices.end(), p.indices.begin(), p.indices.end());
    }
    gl::Buffer vbo = gl::makeBuffer(vertices.data(), vertices.size() * sizeof(Vertex));
    gl::Buffer ibo = gl::makeBuffer(indices.data(), indices.size() * sizeof(uint32_t));
    vertices = {};
    indices = {};
    GLuint vaoId = 0;
    glCreateVertexArrays(1, &vaoId);
    gl::VertexArray vao(vaoId);
    glVertexArrayVertexBuffer(vaoId, 0, vbo.id(), 0, sizeof(Vertex));
    glVertexArrayElementBuffer(vaoId, ibo.id());
    struct Attr {
        GLuint loc;
        GLint size;
        size_t offset;
    };
    for (const Attr& a : {Attr{0, 3, offsetof(Vertex, position)}, Attr{1, 3, offsetof(Vertex, normal)},
                          Attr{2, 4, offsetof(Vertex, tangent)}, Attr{3, 2, offsetof(Vertex, uv0)},
                          Attr{4, 2, offsetof(Vertex, uv1)}, Attr{5, 4, offsetof(Vertex, color)}}) {
        glEnableVertexArrayAttrib(vaoId, a.loc);
        glVertexArrayAttribFormat(vaoId, a.loc, a.size, GL_FLOAT, GL_FALSE, GLuint(a.offset));
        glVertexArrayAttribBinding(vaoId, a.loc, 0);
    }
    TextureCache textures(scene);
    for (const Material& m : scene.materials) {
        // Create every texture up front so that the sample passes only bind.
        for (const TextureRef* r : {&m.baseColorTexture, &m.emissiveTexture, &m.specularColorTexture, &m.sheenColorTexture}) {
            if (r->valid()) textures.texture(r->texture, true);
        }
    }
    progress();

    // Render targets: see the outputs of bake_gbuffer.frag. All RGBA32F.
    const int W = o.width, H = o.height;
    std::vector<gl::Texture> targets;
    GLuint fbId = 0;
    glCreateFramebuffers(1, &fbId);
    gl::Framebuffer fb(fbId);
    GLenum drawBuffers[TARGETS];
    for (int i = 0; i < TARGETS; ++i) {
        targets.push_back(gl::makeTexture2D(GL_RGBA32F, W, H));
        glNamedFramebufferTexture(fbId, GL_COLOR_ATTACHMENT0 + GLenum(i), targets.back().id(), 0);
        drawBuffers[i] = GL_COLOR_ATTACHMENT0 + GLenum(i);
    }
    gl::Texture depth = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, W, H);
    glNamedFramebufferTexture(fbId, GL_DEPTH_ATTACHMENT, depth.id(), 0);
    glNamedFramebufferDrawBuffers(fbId, TARGETS, drawBuffers);
    if (auto s = gl::checkFramebuffer(fbId, "the G-buffer bake"); !s) return s.error();

    glBindFramebuffer(GL_FRAMEBUFFER, fbId);
    glViewport(0, 0, W, H);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glUseProgram(program->id());
    glBindVertexArray(vaoId);
    const CameraInfo& cam = camera.value();
    const glm::vec3 eye = cam.position(), fwd = cam.forward();
    glUniform3f(1, eye.x, eye.y, eye.z);
    glUniform3f(2, fwd.x, fwd.y, fwd.z);
    glUniform1i(3, cam.orthographic ? 1 : 0);

    // Per pixel: the first merged group densely, further groups in a map (edges only).
    const size_t np = size_t(W) * size_t(H);
    std::vector<Group> first(np);
    std::unordered_map<size_t, std::vector<Group>> extra;
    std::vector<float> readback(np * 4);
    std::vector<std::vector<float>> pass(TARGETS);
    std::vector<float> passEnv(env ? np * ENV_TRANSFER_COEFFICIENTS : 0);
    std::vector<double> passLobe(env ? np * EnvTracer::LOBE_SUMS : 0);
    std::vector<float> passHorizon(horizon ? np * HORIZON_AZIMUTHS : 0);

    const std::vector<glm::vec2> offsets = sampleOffsets(o.samples);
    for (int s = 0; s < o.samples; ++s) {
        // Jitter: shift the image by the sample's sub-pixel offset (NDC units are 2/W per pixel;
        // GL's y axis points up while our rows go down).
        const glm::vec2 off = offsets[size_t(s)];
        const glm::mat4 jitter = glm::translate(glm::mat4(1.f), glm::vec3(-2.f * off.x / float(W), 2.f * off.y / float(H), 0.f));
        const glm::mat4 worldToClip = jitter * cam.worldToNDC;
        glUniformMatrix4fv(0, 1, GL_FALSE, glm::value_ptr(worldToClip));
        const float zero[4] = {0, 0, 0, 0};
        for (int i = 0; i < TARGETS; ++i) glClearNamedFramebufferfv(fbId, GL_COLOR, i, zero);
        const float one = 1.f;
        glClearNamedFramebufferfv(fbId, GL_DEPTH, 0, &one);
        for (const Draw& d : draws) {
            const Material& m = scene.materials[d.part->materialId - 1];
            if (m.doubleSided) glDisable(GL_CULL_FACE);
            else glEnable(GL_CULL_FACE);
            glUniform4f(4, m.baseColor.r, m.baseColor.g, m.baseColor.b, m.baseColor.a);
            // Specular level: 0.5 * specularFactor (F0 = 0.08 * level, 0.04 by default).
            glUniform4f(5, m.metallic, m.roughness, 0.5f * m.specularFactor, m.occlusionTexture.scale);
            glUniform3f(6, m.emissive.r, m.emissive.g, m.emissive.b);
            glUniform4f(7, m.sheenColor.r, m.sheenColor.g, m.sheenColor.b, m.sheenRoughness);
            glUniform2f(8, m.clearcoat, m.clearcoatRoughness);
            glUniform3f(9, m.specularColor.r, m.specularColor.g, m.specularColor.b);
            glUniform2f(10, float(d.part->objectId), float(d.part->materialId));
            glUniform1i(11, m.alphaMode == AlphaMode::Mask ? 1 : m.alphaMode == AlphaMode::Blend ? 2 : 0);
            glUniform1f(12, m.alphaCutoff);
            glUniform1f(13, m.normalTexture.scale);
            const TextureRef* slots[SLOT_COUNT] = {&m.baseColorTexture,   &m.metallicRoughnessTexture,
                                                   &m.normalTexture,      &m.occlusionTexture,
                                                   &m.emissiveTexture,    &m.specularTexture,
                                                   &m.specularColorTexture, &m.sheenColorTexture,
                                                   &m.sheenRoughnessTexture, &m.clearcoatTexture,
                                                   &m.clearcoatRoughnessTexture};
            const bool srgbSlot[SLOT_COUNT] = {true, false, false, false, true, false, true, true, false, false, false};
            int mask = 0;
            for (int k = 0; k < SLOT_COUNT; ++k) {
                const TextureRef& r = *slots[k];
                glUniform1i(15 + k, r.texCoord);
                glUniformMatrix3fv(26 + k, 1, GL_FALSE, glm::value_ptr(r.transform));
                if (!r.valid()) {
                    glBindTextureUnit(GLuint(k), 0);
                    continue;
                }
                mask |= 1 << k;
                glBindTextureUnit(GLuint(k), textures.texture(r.texture, srgbSlot[k]));
                glBindSampler(GLuint(k), textures.sampler(r.texture));
            }
            glUniform1i(14, mask);
            glDrawElementsBaseVertex(GL_TRIANGLES, GLsizei(d.count), GL_UNSIGNED_INT,
                                     reinterpret_cast<const void*>(d.firstIndex * sizeof(uint32_t)), d.baseVertex);
        }
        glFinish();
        if (auto st = ctx.value()->check("G-buffer bake draw"); !st) return st.error();
        progress();

        for (int t = 0; t < TARGETS; ++t) {
            pass[size_t(t)].resize(np * 4);
            glGetTextureImage(targets[size_t(t)].id(), 0, GL_RGBA, GL_FLOAT, GLsizei(np * 4 * sizeof(float)),
                              pass[size_t(t)].data());
        }
        if (auto st = ctx.value()->check("G-buffer read-back"); !st) return st.error();
        if (env) {
            // This pass's point in each covered pixel gets every stride-th direction of the
            // pixel's pattern (one shift per pixel, seeded by the pixel: a flat bake's seeds are
            // bakeEnvTransfer's sample indices): a surface all the passes hit is integrated with
            // the whole stratified pattern, as at one sample per pixel, and a partly covered
            // sample's fewer directions are still an unbiased estimate.
            const size_t stride = size_t(std::min(o.samples, o.envRays)), firstRay = size_t(s) % stride;
            const auto t0 = Clock::now();
            envStats.threads = parallelChunks(np, 0, [&](size_t lo, size_t hi) {
                size_t mine = 0;
                for (size_t dst = lo; dst < hi; ++dst) {
                    const size_t src = (size_t(H) - 1 - dst / size_t(W)) * size_t(W) + dst % size_t(W);
                    if (uint32_t(pass[2][src * 4 + 3]) == 0) continue;
                    auto at = [&](int t) { // target t's xyz: P, N, Ng (bake_gbuffer.frag)
                        const float* v = &pass[size_t(t)][src * 4];
                        return glm::vec3(v[0], v[1], v[2]);
                    };
                    mine += env->estimate(at(0), at(1), at(2), uint64_t(dst), firstRay, stride,
                                          &passEnv[dst * ENV_TRANSFER_COEFFICIENTS]);
                    // The specular lobe as the camera sees this point (roughness: target 5's y).
                    mine += env->lobe(at(0), at(1), at(2), cam.towardsEye(at(0)), pass[5][src * 4 + 1], uint64_t(dst), firstRay,
                                      stride, &passLobe[dst * EnvTracer::LOBE_SUMS]);
                }
                envTraced.fetch_add(mine);
            });
            envStats.totalMs += msSince(t0);
            progress();
        }
        if (horizon) {
            const auto t0 = Clock::now();
            horizonStats.threads = parallelChunks(np, 0, [&](size_t lo, size_t hi) {
                size_t mine = 0;
                for (size_t dst = lo; dst < hi; ++dst) {
                    const size_t src = (size_t(H) - 1 - dst / size_t(W)) * size_t(W) + dst % size_t(W);
                    if (uint32_t(pass[2][src * 4 + 3]) == 0) continue;
                    const float* p = &pass[0][src * 4];
                    const float* n = &pass[2][src * 4]; // target 2's xyz: Ng (bake_gbuffer.frag)
                    mine += horizon->trace(glm::vec3(p[0], p[1], p[2]), glm::vec3(n[0], n[1], n[2]),
                                           &passHorizon[dst * HORIZON_AZIMUTHS]);
                }
                horizonTraced.fetch_add(mine);
            });
            horizonStats.totalMs += msSince(t0);
            progress();
        }
        // Merge this pass's samples into the pixels' groups. GL's row 0 is the bottom; the deep
        // buffer's row 0 is the top (EXR convention).
        for (size_t dst = 0; dst < np; ++dst) {
            const size_t y = dst / size_t(W), x = dst % size_t(W);
            const size_t src = (size_t(H) - 1 - y) * size_t(W) + x;
            const uint32_t object = uint32_t(pass[2][src * 4 + 3]);
            if (object == 0) continue;
            const uint32_t material = uint32_t(pass[4][src * 4 + 3]);
            Group* g = nullptr;
            if (first[dst].count == 0 || (first[dst].object == object && first[dst].material == material)) {
                g = &first[dst];
            } else {
                auto& more = extra[dst];
                for (Group& e : more)
                    if (e.object == object && e.material == material) g = &e;
                if (!g) g = &more.emplace_back();
            }
            if (g->count == 0) {
                g->object = object;
                g->material = material;
                std::fill(std::begin(g->sum), std::end(g->sum), 0.f);
                std::fill(std::begin(g->env), std::end(g->env), 0.f);
                std::fill(std::begin(g->lobe), std::end(g->lobe), 0.0);
                std::fill(std::begin(g->horizon), std::end(g->horizon), 0.f);
            }
            ++g->count;
            for (int t = 0; t < TARGETS; ++t)
                for (int c = 0; c < 4; ++c) g->sum[t * 4 + c] += pass[size_t(t)][src * 4 + size_t(c)];
            if (env) {
                const float* t = &passEnv[dst * ENV_TRANSFER_COEFFICIENTS];
                for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i) g->env[i] += t[i];
                const double* l = &passLobe[dst * EnvTracer::LOBE_SUMS];
                for (int i = 0; i < EnvTracer::LOBE_SUMS; ++i) g->lobe[i] += l[i];
            }
            if (horizon)
                for (int k = 0; k < HORIZON_AZIMUTHS; ++k) g->horizon[k] += passHorizon[dst * HORIZON_AZIMUTHS + size_t(k)];
        }
        progress();
    }
    pass = {};

    // Lay the groups out as samples.
    std::vector<uint32_t> counts(np, 0);
    const bool flat = o.samples == 1;
    for (size_t p = 0; p < np; ++p) {
        if (flat) counts[p] = 1; // a flat image keeps a (possibly empty) sample per pixel
        else counts[p] = (first[p].count ? 1u : 0u) + (extra.count(p) ? uint32_t(extra[p].size()) : 0u);
    }
    DeepBuffer b;
    b.allocateSamples(W, H, counts);
    if (env) {
        b.envTransfer.assign(b.sampleCount() * ENV_TRANSFER_COEFFICIENTS, 0.f);
        b.envLobe.assign(b.sampleCount() * ENV_LOBE_COMPONENTS, 0.f);
        b.envRings.assign(b.sampleCount() * ENV_RING_COMPONENTS, 0.f);
        b.envRays = o.envRays;
        b.envBands = o.envBands;
    }
    if (horizon) {
        b.horizon.assign(b.sampleCount() * HORIZON_AZIMUTHS, 0.f);
        b.horizonRadius = horizon->reach();
    }
    b.samplesPerPixel = o.samples;
    b.camera = cam;
    b.sourcePath = scene.path;
    b.sourceSha256 = sha;
    b.objectNames = scene.objectNames;
    for (const Material& m : scene.materials) b.materialNames.push_back(m.name);
    const float invSamples = 1.f / float(o.samples);
    auto store = [&](size_t s, const Group& g) {
        const float inv = 1.f / float(g.count);
        auto avg = [&](int t, int c) { return g.sum[t * 4 + c] * inv; };
        const glm::vec3 P(avg(0, 0), avg(0, 1), avg(0, 2));
        auto unit = [](glm::vec3 v) { return glm::length(v) > 0.f ? glm::normalize(v) : glm::vec3(0, 0, 1); };
        const glm::vec3 N = unit({avg(1, 0), avg(1, 1), avg(1, 2)});
        const glm::vec3 Ng = unit({avg(2, 0), avg(2, 1), avg(2, 2)});
        glm::vec3 T = glm::vec3(avg(3, 0), avg(3, 1), avg(3, 2));
        T = unit(T - N * glm::dot(N, T));
        for (int c = 0; c < 3; ++c) {
            b.P[s * 3 + size_t(c)] = P[c];
            b.N[s * 3 + size_t(c)] = N[c];
            b.Ng[s * 3 + size_t(c)] = Ng[c];
            b.T[s * 4 + size_t(c)] = T[c];
            b.albedo[s * 3 + size_t(c)] = avg(4, c);
            b.emission[s * 3 + size_t(c)] = avg(6, c);
            b.sheen[s * 4 + size_t(c)] = avg(7, c);
        }
        b.T[s * 4 + 3] = avg(3, 3) < 0.f ? -1.f : 1.f;
        for (int c = 0; c < 4; ++c) b.brdf[s * 4 + size_t(c)] = avg(5, c);
        b.sheen[s * 4 + 3] = avg(7, 3);
        b.coat[s * 2] = avg(6, 3);
        b.coat[s * 2 + 1] = avg(0, 3);
        // Camera depth from the averaged position: exactly the view-space distance.
        b.Z[s] = -(cam.worldToCamera * glm::vec4(P, 1.f)).z;
        b.A[s] = float(g.count) * invSamples * avg(1, 3); // fraction of samples x BLEND alpha
        b.objectId[s] = g.object;
        b.materialId[s] = g.material;
        if (env) {
            // The mean of the points' transfers: each estimates the transfer at its own surface
            // point, and the sample stands for their average, as for every attribute above.
            for (int i = 0; i < o.envBands * o.envBands; ++i)
                b.envTransfer[s * ENV_TRANSFER_COEFFICIENTS + size_t(i)] = g.env[i] * inv;
            // The lobe's and its rings' sums add over the points (ratios and directions: no mean needed).
            EnvTracer::encodeLobe(g.lobe, N, cam.towardsEye(P), &b.envLobe[s * ENV_LOBE_COMPONENTS]);
            EnvTracer::encodeRings(g.lobe, N, cam.towardsEye(P), &b.envRings[s * ENV_RING_COMPONENTS]);
            envStats.samples += b.A[s] > 0.f;
        }
        if (horizon) {
            for (int k = 0; k < HORIZON_AZIMUTHS; ++k) b.horizon[s * HORIZON_AZIMUTHS + size_t(k)] = g.horizon[k] * inv;
            horizonStats.samples += b.A[s] > 0.f;
        }
    };
    std::vector<const Group*> groups;
    for (size_t p = 0; p < np; ++p) {
        groups.clear();
        if (first[p].count) groups.push_back(&first[p]);
        if (auto it = extra.find(p); it != extra.end())
            for (const Group& g : it->second) groups.push_back(&g);
        // Nearest first, as deep images are conventionally sorted.
        auto groupDepth = [&](const Group* g) {
            const glm::vec3 P = glm::vec3(g->sum[0], g->sum[1], g->sum[2]) / float(g->count);
            return -(cam.worldToCamera * glm::vec4(P, 1.f)).z;
        };
        if (groups.size() > 1) {
            std::sort(groups.begin(), groups.end(), [&](const Group* a, const Group* c) { return groupDepth(a) < groupDepth(c); });
        }
        size_t s = b.sampleOffset[p];
        for (const Group* g : groups) store(s++, *g);
    }
    progress();
    if (horizon && o.horizonStats) {
        horizonStats.rays = horizonTraced.load();
        *o.horizonStats = horizonStats;
    }
    if (env && o.envStats) {
        envStats.rays = envTraced.load();
        *o.envStats = envStats;
    }
    return b;
}

} // namespace dfb
