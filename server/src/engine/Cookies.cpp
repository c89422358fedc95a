#include "Cookies.h"

#include "EnvironmentMap.h"
#include "GpuInterface.h"

#include <dfb/lightmath/Environment.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

namespace dfb::engine {

Result<GLuint> Cookies::texture(const Light& l) {
    auto it = mTextures.find(l.cookie);
    if (it != mTextures.end()) return it->second.id();
    const std::string path = (std::filesystem::path(mDirectory) / l.cookie).string();
    auto img = readLinearImage(path);
    if (!img) {
        return makeError(img.error().code, "light '" + l.name + "': cookie '" + l.cookie + "': " + img.error().message);
    }
    const int levels = 1 + int(std::floor(std::log2(double(std::max(img->width, img->height)))));
    GLuint id = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &id);
    gl::Texture t(id);
    glTextureStorage2D(id, levels, GL_RGBA16F, img->width, img->height);
    // Row 0 of the image (its top) goes to t = 1, the light's up (relight_spot.frag).
    std::vector<float> flipped(img->rgba.size());
    const size_t row = size_t(img->width) * 4;
    for (int y = 0; y < img->height; ++y)
        std::copy_n(img->rgba.begin() + ptrdiff_t(size_t(y) * row), row, flipped.begin() + ptrdiff_t(size_t(img->height - 1 - y) * row));
    glTextureSubImage2D(id, 0, 0, 0, img->width, img->height, GL_RGBA, GL_FLOAT, flipped.data());
    glGenerateTextureMipmap(id);
    glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return mTextures.emplace(l.cookie, std::move(t)).first->second.id();
}

Result<Cookies::Pattern> Cookies::pattern(const Light& l) {
    const auto key = std::make_pair(l.pattern, l.areaShape == AreaShape::Disk);
    auto it = mPatterns.find(key);
    if (it == mPatterns.end()) {
        auto table = areaPatternTable(l, mDirectory);
        if (!table) return table.error();
        const lightmath::PatternTable& t = table.value()->table;
        // The mean's share is taken out (and added back by the shader): the corners then stay
        // near 0 instead of growing to the mean, and float keeps small boxes' differences.
        std::vector<float> corners(size_t(t.w + 1) * size_t(t.h + 1) * 4);
        for (int j = 0; j <= t.h; ++j)
            for (int i = 0; i <= t.w; ++i) {
                const size_t k = size_t(j) * size_t(t.w + 1) + size_t(i);
                const glm::dvec3 v = t.sat[k] - t.mean * (double(i) / t.w) * (double(j) / t.h);
                corners[k * 4] = float(v.x);
                corners[k * 4 + 1] = float(v.y);
                corners[k * 4 + 2] = float(v.z);
                corners[k * 4 + 3] = 0.f;
            }
        gl::Texture tex = gl::makeTexture2D(GL_RGBA32F, t.w + 1, t.h + 1);
        glTextureSubImage2D(tex.id(), 0, 0, 0, t.w + 1, t.h + 1, GL_RGBA, GL_FLOAT, corners.data());
        glTextureParameteri(tex.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(tex.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        it = mPatterns.emplace(key, std::make_pair(std::move(tex), glm::vec3(t.mean))).first;
    }
    return Pattern{it->second.first.id(), it->second.second};
}

namespace {
// What the order-3 expansion misses of the map's exact irradiance, E(N) / pi less the expansion's,
// at the normals of an ENV_IRRADIANCE_WIDTH x /2 grid in the map's own frame (a few milliseconds:
// 512 normals x the map's small copy). The shader reads it at R^T N and adds the turned
// expansion: rotating the map is rotating where both are read, exactly, since the expansion's
// coefficients turn with their directions (envProjectSh) and E_turned(N) = E(R^T N).
gl::Texture irradianceResidual(const std::vector<float>& sh, int w, int h,
                               const std::array<glm::dvec3, lightmath::SH_TRANSFER_COEFFICIENTS>& L) {
    constexpr int IW = int(ENV_IRRADIANCE_WIDTH), IH = IW / 2;
    const glm::dmat3 identity(1.0);
    std::vector<float> E = lightmath::envIrradianceMap(sh.data(), w, h, 4, identity, IW, IH);
    for (int j = 0; j < IH; ++j)
        for (int i = 0; i < IW; ++i) {
            const auto T = lightmath::shUnshadowedTransfer(lightmath::envIrradianceNormal(i, j, IW, IH));
            glm::dvec3 e(0.0);
            for (int k = 0; k < lightmath::SH_COEFFICIENTS; ++k) e += L[size_t(k)] * T[size_t(k)];
            float* o = &E[(size_t(j) * size_t(IW) + size_t(i)) * 4];
            for (int ch = 0; ch < 3; ++ch) o[ch] -= float(e[ch]);
        }
    gl::Texture t = gl::makeTexture2D(GL_RGBA32F, IW, IH);
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(t.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTextureSubImage2D(t.id(), 0, 0, 0, IW, IH, GL_RGBA, GL_FLOAT, E.data());
    return t;
}
} // namespace

Result<Cookies::Environment> Cookies::environment(const Light& l) {
    auto it = mEnvironments.find(l.envMap);
    if (it == mEnvironments.end()) {
        ImageF src;
        if (l.envMap.empty()) {
            src.width = 2;
            src.height = 1;
            src.rgba.assign(8, 1.f);
        } else {
            auto img = readHdrImage((std::filesystem::path(mDirectory) / l.envMap).string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
            if (!img) return makeError(img.error().code, "light '" + l.name + "': map '" + l.envMap + "': " + img.error().message);
            src = std::move(img.value());
        }
        std::vector<EnvSun> suns = extractSuns(src);
        // A cube map, faces a quarter of the lat-long base across (the same angle per texel
        // at the equator), read with a direction (relight_env.frag prefiltered).
        const EnvLevels levels = prefilterEnvironment(src, int(ENV_LEVELS), ENV_PREFILTER_WIDTH, ENV_PREFILTER_WIDTH / 4);
        // A few maps are kept (swapping back and forth costs no reload); the others go.
        constexpr size_t KEPT = 4;
        if (mEnvironments.size() >= KEPT) mEnvironments.clear();
        EnvEntry e;
        GLuint id = 0;
        glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &id);
        e.texture = gl::Texture(id);
        glTextureStorage2D(id, GLsizei(ENV_LEVELS), GL_RGBA32F, levels.widths[0], levels.widths[0]);
        for (int k = 0; k < int(ENV_LEVELS); ++k) {
            // The six faces as layers 0..5 (+X, -X, +Y, -Y, +Z, -Z), as EnvLevels holds them.
            const int size = levels.widths[size_t(k)];
            glTextureSubImage3D(id, k, 0, 0, 0, size, size, 6, GL_RGBA, GL_FLOAT, levels.rgba[size_t(k)].data());
        }
        glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
        glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(id, GL_TEXTURE_MAX_LEVEL, GLint(ENV_LEVELS) - 1);
        e.sh = levels.sh;
        e.shWidth = levels.shWidth;
        e.shHeight = levels.shHeight;
        e.suns = std::move(suns);
        e.coefficients = lightmath::envProjectSh(e.sh.data(), e.shWidth, e.shHeight, 4, glm::dmat3(1.0));
        e.irradianceResidual = irradianceResidual(e.sh, e.shWidth, e.shHeight, e.coefficients);
        it = mEnvironments.emplace(l.envMap, std::move(e)).first;
    }
    return Environment{it->second.texture.id(), it->second.irradianceResidual.id(), &it->second.sh, it->second.shWidth,
                       it->second.shHeight, it->second.suns, it->second.coefficients};
}

} // namespace dfb::engine
