#pragma once
// The offline bake: rasterises a glTF scene from a fixed camera through headless EGL into a deep
// framebuffer (DESIGN section 2). May be slow; runs once per shot.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>

#include <optional>
#include <string>

namespace dfb {

struct BakeOptions {
    int width = 960;          ///< pixels, 1..16384
    int height = 540;         ///< pixels, 1..16384
    std::string cameraName;   ///< glTF camera (node or camera name); empty = first camera, else auto
    std::optional<glm::vec3> lookFrom; ///< with lookAt: overrides the scene's cameras
    std::optional<glm::vec3> lookAt;
    float fovDegrees = 0.f;   ///< vertical field of view for lookFrom/auto framing; 0 = 40 degrees
};

/// Picks the camera the options ask for. Fails with MissingData naming the camera when
/// `cameraName` matches none (the message lists the cameras the scene has).
Result<CameraInfo> chooseCamera(const Scene& scene, const BakeOptions& options);

/// Bakes the scene. Creates its own EGL context on the calling thread. Fails with GpuError when no
/// context can be made, InvalidValue for bad sizes.
Result<DeepBuffer> bake(const Scene& scene, const BakeOptions& options);

} // namespace dfb
