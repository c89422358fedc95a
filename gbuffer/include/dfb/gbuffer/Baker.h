#pragma once
// The offline bake: rasterises a glTF scene from a fixed camera through headless EGL into a deep
// framebuffer (DESIGN section 2). May be slow; runs once per shot.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/EnvTransfer.h>
#include <dfb/gbuffer/NearField.h>
#include <dfb/gbuffer/Scene.h>

#include <functional>
#include <optional>
#include <string>

namespace dfb {

struct BakeOptions {
    int width = 960;          ///< pixels, 1..16384
    int height = 540;         ///< pixels, 1..16384
    int samples = 1;          ///< samples per pixel, 1..MAX_SAMPLES_PER_PIXEL (see sampleOffsets)
    std::string cameraName;   ///< glTF camera (node or camera name); empty = first camera, else auto
    std::optional<glm::vec3> lookFrom; ///< with lookAt: overrides the scene's cameras
    std::optional<glm::vec3> lookAt;
    float fovDegrees = 0.f;   ///< vertical field of view for lookFrom/auto framing; 0 = 40 degrees
    /// Rays per pixel for the environment transfer (DeepBuffer::envTransfer), 0..MAX_ENV_RAYS;
    /// 0 = not baked (envTransfer left empty). dfb-bake asks for 64 by default.
    int envRays = 0;
    /// Spherical-harmonic bands of the environment transfer: 3 (9 coefficients) or 5 (25; the
    /// default, ENV_TRANSFER_BANDS). The rays are the same; bands 3-4 are left 0 with 3.
    int envBands = ENV_TRANSFER_BANDS;
    /// When set and envRays > 0: filled with what the transfer cost (its share of the bake).
    EnvTransferStats* envStats = nullptr;
    /// The near-field horizon's reach (DeepBuffer::horizon, bakeHorizon) as a fraction of the
    /// scene's bounding radius, in (0, MAX_HORIZON_RADIUS_FRACTION]; 0 = not baked.
    float horizonRadius = HORIZON_RADIUS_FRACTION;
    /// When set and horizonRadius > 0: filled with what the horizon cost.
    HorizonStats* horizonStats = nullptr;
    /// Called with (done, total) work units while baking; may be empty.
    std::function<void(size_t, size_t)> progress;
};

/// Sample positions of one pixel, in pixels relative to its centre, each in (-0.5, 0.5)^2:
/// a stratified n x n grid when `samples` is a perfect square (then they coincide with the pixel
/// centres of an n-times larger bake), else the first `samples` points of the R2 sequence.
std::vector<glm::vec2> sampleOffsets(int samples);

/// Picks the camera the options ask for. Fails with MissingData naming the camera when
/// `cameraName` matches none (the message lists the cameras the scene has).
Result<CameraInfo> chooseCamera(const Scene& scene, const BakeOptions& options);

/// Bakes the scene. Creates its own EGL context on the calling thread. Fails with GpuError when no
/// context can be made, InvalidValue for bad sizes, sample counts, environment ray or band counts,
/// or horizon radii. With horizonRadius > 0 each pass's surface points also get their near-field
/// horizon (bakeHorizon's estimator, over every core), and a merged sample the mean of its
/// points' horizons.
/// With envRays > 0, each pass's surface points also get the environment transfer, on the CPU over
/// every core (the estimator of bakeEnvTransfer): a pixel's envRays directions, shifted once per
/// pixel (seeded by the pixel index: reproducible), are dealt out to its passes, every
/// samples-th to each; a merged sample's transfer is the mean of its points', as its other
/// attributes are, so that no ray starts from an averaged position (which may lie inside a curved
/// mesh). With one sample per pixel the result is bakeEnvTransfer's on the stored samples.
///
/// With several samples per pixel, each sample is a full raster pass with the projection jittered
/// to the sample position; a pixel's samples that hit the same object and material are merged
/// into one stored sample (attributes averaged, normals renormalised) whose coverage A is the
/// fraction of samples it got (times the alpha of BLEND materials).
Result<DeepBuffer> bake(const Scene& scene, const BakeOptions& options);

/// Lowercase hex SHA-256 of a file's bytes (OpenSSL), or an IoError.
Result<std::string> sha256File(const std::string& path);

} // namespace dfb
