#pragma once
// The shot's G-buffer on the GPU, uploaded once: every per-sample layer as a "sample texture"
// (sample s at texel (s % sampleRow, s / sampleRow), common_uniforms.glsl's sampleTexel) and per
// pixel its first sample and sample count.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gl/Objects.h>

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace dfb::engine {

struct GBufferTextures {
    /// Uploads `g` (GL thread, context current). InvalidValue when its samples do not fit the
    /// GPU's textures.
    Status upload(const DeepBuffer& g);

    /// Binds the layers the relight passes read at their texture units (GpuInterface.h).
    void bindForShading() const;

    int width = 0, height = 0;
    int sampleRow = 0;  // width of the sample textures: the image's (flat) or a power of two (deep)
    int sampleRows = 0; // their height
    bool flat = false;  // one sample per pixel, stored at the pixel: specialised shaders
    bool hasSheen = false, hasCoat = false; // any sample with a sheen / clear-coat lobe
    bool hasEnvTransfer = false;            // the shot holds the environment transfer (DeepBuffer::envTransfer)
    bool hasEnvLobe = false;                // and the specular lobe (DeepBuffer::envLobe)
    bool hasEnvRings = false;               // and the lobe's rings (DeepBuffer::envRings)
    int envBands = 0;                       // the transfer's bands (DeepBuffer::envBands) when held
    int envLayers = 0;                      // the transfer's and the lobe's layers (envTransferLayers)
    bool hasHorizon = false;                // the shot holds the near-field horizon (DeepBuffer::horizon)
    float horizonRadius = 0.f;              // and its reach, scene units (DeepBuffer::horizonRadius)
    uint32_t maxObjectId = 0;
    // Edge taps per sample over its pixel footprint (common_pixel_footprint.glsl): the shot's
    // samples per pixel, at most FOOTPRINT_MAX_TAPS; 1 = one lookup at the sample (flat shots).
    int footprintTaps = 1;
    std::vector<glm::vec2> footprintOffsets; // their offsets from the pixel centre, pixels (y down)
    gl::Texture P, N, Ng, albedo, brdf, emission, sheen, coat, pixelSamples, ids;
    // 2D array: T_0..T_{n-1}, then the lobe's u, v, share, four per layer (envLayers layers),
    // then with hasEnvRings one layer per ring: its u, v, share, roughness.
    gl::Texture envTransfer;
    gl::Texture horizon;     // 2D array: the horizon's sines, four per layer (TEX_GBUFFER_HORIZON)
};

/// Layers of the transfer's array texture: envBands^2 coefficients and the lobe's three values,
/// four per layer (3 for three bands, 7 for five).
constexpr int envTransferLayers(int bands) { return (bands * bands + ENV_LOBE_COMPONENTS + 3) / 4; }

} // namespace dfb::engine
