#pragma once
// The rig's way back out (issue 19 point 7): the session's scene written as one GLB whose lights
// are the rig's. Spot, point and directional lights become KHR_lights_punctual lights on nodes
// placed and turned by the light's position and frame (the node's -Z is where the light points);
// every light also carries its exact rig JSON in the node's extras.dfb_light, so that loading the
// file back into dfb (loadScene + initialRig) reproduces the rig. The convention is in
// docs/gbuffer-format.md, "Lights in glTF".

#include <dfb/core/Result.h>
#include <dfb/protocol/Rig.h>

#include <cstddef>
#include <string>

namespace dfb {

/// Most bytes of an exported file, and of the scene read to make it: the file is built in memory
/// and sent as one HTTP body (dfb-client reads bodies up to 512 MiB). A GLB cannot exceed 4 GiB.
constexpr size_t MAX_EXPORT_BYTES = size_t(256) << 20;

/// The scene at `scenePath` (.glb, or .gltf with its external buffers and images, which are
/// packed into the GLB) with its own lights removed (KHR_lights_punctual, extras.dfb_area_light,
/// extras.dfb_light; nodes that were only lights are dropped) and one new root node per light of
/// `rig`, in rig order; meshes, materials, cameras and animations are kept. The rig's exposure,
/// view transform and time go to the default scene's extras.dfb_rig. Returns the GLB bytes.
/// Fails with MissingData when the rig has no lights (nothing is read); FileNotFound or
/// InvalidFile naming the file when the scene cannot be read or has no scene; LimitExceeded when
/// the scene or the result is over MAX_EXPORT_BYTES. Thread-safe (no shared state); it reads the
/// file and allocates about twice its size.
Result<std::string> exportGltf(const std::string& scenePath, const Rig& rig);

/// The KHR_lights_punctual values of one light (evaluated at its rig's time by the caller), as
/// exportGltf writes them: type "spot", "point" or "directional" ("" for the lights the extension
/// cannot express: bendy gets its unbent spot as a stand-in, area and bentArea lights none, a
/// disabled light none). Colour in [0, 1] with the excess moved into the intensity (candela for
/// spot and point lights, lux for directional ones), cone angles in radians with
/// innerConeAngle = cone - penumbra (kept just below outerConeAngle: the extension wants it less).
struct PunctualLight {
    std::string type;
    double color[3] = {1, 1, 1};
    double intensity = 1;
    double innerConeAngle = 0, outerConeAngle = 0.785398163397448;
};
PunctualLight punctualLight(const Light& light);

} // namespace dfb
