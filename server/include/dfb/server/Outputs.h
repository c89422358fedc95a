#pragma once
// What a client can ask to see of a shot (DESIGN section 6, docs/protocol.md "outputs"): the
// beauty, one light alone, a light's shadow mask or a G-buffer layer, encoded as JPEG, PNG or
// OpenEXR (float; the beauty's EXR carries one layer per light for compositing).

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Rig.h>
#include <dfb/bvh/TriangleBvh.h>
#include <dfb/server/Engine.h>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// Cells per side of the `reference:NAME` output (Engine::renderAreaReference): 32 x 32 = 1024
/// BRDF evaluations per sample, a few seconds at 960 x 540 on llvmpipe.
constexpr int AREA_REFERENCE_OUTPUT_CELLS = 32;

struct OutputRequest {
    /// "beauty", "light:NAME", "reference:NAME" (an area light by the stratified reference: the
    /// difference to light:NAME is one-shot's error), "shadow:NAME" or "layer:NAME" (a viewable
    /// G-buffer layer).
    std::string output = "beauty";
    /// "jpeg" (or "jpg"), "png" or "exr".
    std::string format = "png";
    int jpegQuality = 92;
    /// 8-bit beauty only: the rig's enabled environment lights seen along each pixel's camera ray
    /// fill the share of the pixel the G-buffer does not cover (environmentBackground).
    bool background = false;
};

struct EncodedImage {
    std::vector<uint8_t> bytes;
    std::string contentType; ///< image/jpeg, image/png or image/x-exr
    int width = 0;
    int height = 0;
};


/// Renders and encodes one output of `rig` (already evaluated at the session's time).
/// 8-bit encodings get the rig's exposure and the sRGB view transform (shadow masks: visibility as
/// grey, black where the light does not reach; layers: the mappings of layerImage()). EXR holds
/// linear floats times the rig's exposure: the beauty as R, G, B, A plus a layer NAME.R/G/B per
/// enabled light; one light alone as R, G, B; a shadow mask as R = G = B = visibility and A = the
/// coverage the light reaches. G-buffer layers have no EXR output (the shot file holds them).
/// `reference:NAME` of an area light is the engine's stratified reference; of an environment
/// light, renderEnvironmentReference with ENV_REFERENCE_OUTPUT_RAYS rays per sample against
/// `scene` (the casters' hierarchy; its bounding radius `sceneRadius`), maps from `assetDir`: CPU
/// seconds on the render thread, like the area reference's GPU seconds. Without `scene` an
/// environment light has no reference output.
struct ReferenceScene {
    const TriangleBvh* scene = nullptr;
    float sceneRadius = 1.f;
    std::string assetDir = ".";
};
constexpr int ENV_REFERENCE_OUTPUT_RAYS = 64;
Result<EncodedImage> renderOutput(Engine& engine, const DeepBuffer& shot, const Rig& rig, const OutputRequest& request,
                                  const ReferenceScene& reference = {});

/// The radiance of the rig's enabled environment lights (colour x intensity x the map, turned by
/// rotation: lightmath::envRotation) along the camera ray through each pixel's centre, times the
/// share of the pixel the shot does not cover (1 - coverage), RGBA with A = 0; black without
/// environment lights. Maps are read from `assetDir` (bilinear, wrapping in u) and kept for the
/// next call while their file is unchanged. The backdrop of OutputRequest::background.
Result<ImageF> environmentBackground(const DeepBuffer& shot, const Rig& rig, const std::string& assetDir);

/// The 8-bit display image of a linear one (exposure already applied): `viewTransform` (sRGB, or
/// the filmic curve of composite_tonemap.frag, then sRGB), alpha 255. The encodings of
/// renderOutput and of final renders (GET .../final.png).
Image8 displayImage(const ImageF& image, ViewTransform viewTransform);

} // namespace dfb
