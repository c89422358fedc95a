#include "GBufferTextures.h"

#include "GpuInterface.h"

#include <dfb/gbuffer/Baker.h>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <vector>

namespace dfb::engine {
namespace {

// Uploads one per-sample layer into a sample texture, padded to RGBA (three-component float
// textures are slow paths on some drivers).
gl::Texture uploadLayer(GLenum internalFormat, int row, int rows, const std::vector<float>& data, int comps,
                        const std::vector<float>* alpha) {
    const size_t n = data.size() / size_t(comps);
    std::vector<float> rgba(size_t(row) * size_t(rows) * 4, 0.f);
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < comps; ++c) rgba[i * 4 + size_t(c)] = data[i * size_t(comps) + size_t(c)];
        if (alpha) rgba[i * 4 + 3] = (*alpha)[i];
    }
    gl::Texture t = gl::makeTexture2D(internalFormat, row, rows);
    glTextureSubImage2D(t.id(), 0, 0, 0, row, rows, GL_RGBA, GL_FLOAT, rgba.data());
    return t;
}

} // namespace

Status GBufferTextures::upload(const DeepBuffer& g) {
    width = g.width;
    height = g.height;
    flat = g.isFlat();
    // Sample textures: as wide as the image (so a flat buffer's sample texture is the image); a
    // deep buffer's are a power of two wide (sampleTexel: a mask and a shift), wider still when
    // its rows would exceed GL's minimum maximum texture size.
    constexpr int MAX_SIDE = 16384;
    const size_t samples = std::max<size_t>(g.sampleCount(), 1);
    sampleRow = flat ? width : std::min(int(std::bit_ceil(unsigned(std::max(width, 1)))), MAX_SIDE);
    if ((samples + size_t(sampleRow) - 1) / size_t(sampleRow) > size_t(MAX_SIDE)) sampleRow = MAX_SIDE;
    const int rows = int((samples + size_t(sampleRow) - 1) / size_t(sampleRow));
    sampleRows = rows;
    if (rows > MAX_SIDE) return makeError(ErrorCode::InvalidValue, "engine: too many samples for the GPU's textures");
    flat = flat && sampleRow == width; // the flat shaders read sample (x, y) at pixel (x, y)
    // Edge taps: the bake's own sample pattern (sampleOffsets), so that a merged sample's mask is
    // looked up where its bake samples were; rates above FOOTPRINT_MAX_TAPS use that many (a 4x4
    // grid: 16 taps of 4 comparison gathers each already cost more than the rest of the shading).
    // DFB_FOOTPRINT_TAPS=n caps the count, a diagnostic for comparisons (1: one lookup per sample).
    footprintTaps = std::clamp(g.samplesPerPixel, 1, int(FOOTPRINT_MAX_TAPS));
    if (const char* cap = std::getenv("DFB_FOOTPRINT_TAPS"); cap && *cap) {
        footprintTaps = std::clamp(std::atoi(cap), 1, footprintTaps);
    }
    footprintOffsets = sampleOffsets(footprintTaps);
    P = uploadLayer(GL_RGBA32F, sampleRow, rows, g.P, 3, &g.A);
    N = uploadLayer(GL_RGBA16F, sampleRow, rows, g.N, 3, nullptr);
    // Ng's w: the sample's highest horizon sine, when the shot holds a horizon (common_horizon.glsl:
    // a light above it skips the azimuth lookup).
    std::vector<float> highest;
    if (g.hasHorizon()) {
        highest.assign(g.sampleCount(), 0.f);
        for (size_t i = 0; i < g.sampleCount(); ++i)
            for (int k = 0; k < HORIZON_AZIMUTHS; ++k) highest[i] = std::max(highest[i], g.horizon[i * HORIZON_AZIMUTHS + size_t(k)]);
    }
    Ng = uploadLayer(GL_RGBA16F, sampleRow, rows, g.Ng, 3, highest.empty() ? nullptr : &highest);
    albedo = uploadLayer(GL_RGBA16F, sampleRow, rows, g.albedo, 3, nullptr);
    brdf = uploadLayer(GL_RGBA16F, sampleRow, rows, g.brdf, 4, nullptr);
    emission = uploadLayer(GL_RGBA16F, sampleRow, rows, g.emission, 3, nullptr);
    sheen = uploadLayer(GL_RGBA16F, sampleRow, rows, g.sheen, 4, nullptr);
    coat = uploadLayer(GL_RGBA16F, sampleRow, rows, g.coat, 2, nullptr);
    for (size_t i = 0; i < g.sampleCount() && !hasSheen; ++i) {
        hasSheen = g.sheen[i * 4] > 0.f || g.sheen[i * 4 + 1] > 0.f || g.sheen[i * 4 + 2] > 0.f;
    }
    for (size_t i = 0; i < g.sampleCount() && !hasCoat; ++i) hasCoat = g.coat[i * 2] > 0.f;
    hasEnvTransfer = g.hasEnvTransfer();
    hasEnvLobe = hasEnvTransfer && g.hasEnvLobe();
    hasEnvRings = hasEnvLobe && g.hasEnvRings();
    if (hasEnvTransfer) {
        // The environment transfer T_0..T_{n-1} (n = envBands^2) and after it the specular lobe's
        // octahedral direction and visible share (ENV_LOBE), value j at layer j / 4, component
        // j % 4 of one array sample texture: 3 layers for three bands, 7 for five
        // (relight_env.frag's ENV_LAYERS); then the lobe's rings, ring r at layer ENV_LAYERS + r
        // (u, v, share, roughness: ENV_RINGS).
        const size_t n = g.sampleCount(), texels = size_t(sampleRow) * size_t(rows);
        envBands = g.envBands;
        const int coefficients = envBands * envBands;
        envLayers = envTransferLayers(envBands);
        const int layers = envLayers + (hasEnvRings ? int(ENV_LOBE_RINGS) : 0);
        std::vector<float> data(texels * 4 * size_t(layers), 0.f);
        auto put = [&](size_t s, int j, float v) { data[(size_t(j / 4) * texels + s) * 4 + size_t(j % 4)] = v; };
        for (size_t i = 0; i < n; ++i) {
            for (int c = 0; c < coefficients; ++c) put(i, c, g.envTransfer[i * ENV_TRANSFER_COEFFICIENTS + size_t(c)]);
            for (int c = 0; c < ENV_LOBE_COMPONENTS && hasEnvLobe; ++c)
                put(i, coefficients + c, g.envLobe[i * ENV_LOBE_COMPONENTS + size_t(c)]);
            for (int c = 0; c < ENV_RING_COMPONENTS && hasEnvRings; ++c)
                put(i, 4 * envLayers + c, g.envRings[i * ENV_RING_COMPONENTS + size_t(c)]);
        }
        static_assert(ENV_RING_COMPONENTS == 4 * ENV_LOBE_RINGS, "a layer per ring");
        envTransfer = gl::makeTexture2DArray(GL_RGBA16F, sampleRow, rows, layers);
        glTextureSubImage3D(envTransfer.id(), 0, 0, 0, 0, sampleRow, rows, layers, GL_RGBA, GL_FLOAT, data.data());
    }
    hasHorizon = g.hasHorizon();
    horizonRadius = hasHorizon ? g.horizonRadius : 0.f;
    if (hasHorizon) {
        // Azimuth k of sample s at layer k / 4, component k % 4 (common_horizon.glsl).
        static_assert(HORIZON_AZIMUTHS % 4 == 0 && HORIZON_AZIMUTHS == int(HORIZON_AZIMUTH_COUNT));
        constexpr int layers = HORIZON_AZIMUTHS / 4;
        const size_t n = g.sampleCount(), texels = size_t(sampleRow) * size_t(rows);
        std::vector<float> data(texels * 4 * size_t(layers), 0.f);
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < HORIZON_AZIMUTHS; ++k)
                data[(size_t(k / 4) * texels + i) * 4 + size_t(k % 4)] = g.horizon[i * HORIZON_AZIMUTHS + size_t(k)];
        horizon = gl::makeTexture2DArray(GL_RGBA16F, sampleRow, rows, layers);
        glTextureSubImage3D(horizon.id(), 0, 0, 0, 0, sampleRow, rows, layers, GL_RGBA, GL_FLOAT, data.data());
    }
    {
        std::vector<uint32_t> objectIds(size_t(sampleRow) * size_t(rows), 0);
        for (size_t i = 0; i < g.sampleCount(); ++i) {
            objectIds[i] = g.objectId[i];
            maxObjectId = std::max(maxObjectId, g.objectId[i]);
        }
        ids = gl::makeTexture2D(GL_R32UI, sampleRow, rows);
        glTextureSubImage2D(ids.id(), 0, 0, 0, sampleRow, rows, GL_RED_INTEGER, GL_UNSIGNED_INT, objectIds.data());
    }
    // Per pixel: first sample and count. Row 0 of the deep buffer (top) goes to GL row 0: every
    // pass is per pixel, so the image is rendered top-down and read back without a flip.
    std::vector<uint32_t> ranges(g.pixelCount() * 2);
    for (size_t p = 0; p < g.pixelCount(); ++p) {
        ranges[p * 2] = g.sampleOffset[p];
        ranges[p * 2 + 1] = g.sampleOffset[p + 1] - g.sampleOffset[p];
    }
    pixelSamples = gl::makeTexture2D(GL_RG32UI, width, height);
    glTextureSubImage2D(pixelSamples.id(), 0, 0, 0, width, height, GL_RG_INTEGER, GL_UNSIGNED_INT, ranges.data());
    return okStatus();
}

void GBufferTextures::bindForShading() const {
    glBindTextureUnit(TEX_GBUFFER_ID, ids.id());
    glBindTextureUnit(TEX_GBUFFER_P, P.id());
    glBindTextureUnit(TEX_GBUFFER_N, N.id());
    glBindTextureUnit(TEX_GBUFFER_NG, Ng.id());
    glBindTextureUnit(TEX_GBUFFER_ALBEDO, albedo.id());
    glBindTextureUnit(TEX_GBUFFER_BRDF, brdf.id());
    glBindTextureUnit(TEX_GBUFFER_SHEEN, sheen.id());
    glBindTextureUnit(TEX_GBUFFER_COAT, coat.id());
    glBindTextureUnit(TEX_PIXEL_SAMPLES, pixelSamples.id());
    if (hasEnvTransfer) glBindTextureUnit(TEX_GBUFFER_ENV, envTransfer.id());
    if (hasHorizon) glBindTextureUnit(TEX_GBUFFER_HORIZON, horizon.id());
}

} // namespace dfb::engine
