#pragma once
// The rig a session starts with (DESIGN section 5): the scene's KHR_lights_punctual lights when it
// has any, else a three-point rig with a dome fitted to its bounds and the shot's camera and
// calibrated on the shot (issue 19 point 6; docs/lighting.md, "Default rig").

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/Engine.h>

#include <string>
#include <vector>

namespace dfb {

/// Spot, point and directional lights of the scene become lights of the rig (names made valid and
/// unique, cone angles clamped to the rig's ranges); `imported` tells which case applied.
/// A light whose node carries extras.dfb_light (dfb's export; docs/gbuffer-format.md, "Lights in
/// glTF") is that rig light exactly (renamed only if its name is taken), and the scene's
/// extras.dfb_rig sets the exposure, view transform and time. A dfb_light or dfb_rig that the
/// rig's codec refuses is reported in `warnings` (one line each, naming the node and the field)
/// and the light is read from its stand-in (KHR light or dfb_area_light), or left out when it has
/// none.
/// Without lights in the scene: defaultRig (a key and fill framed on the bounds alone; what the
/// engine tests and benchmarks relight). A session's shot uses sessionRig instead.
Rig initialRig(const Scene& scene, bool* imported = nullptr, std::vector<std::string>* warnings = nullptr);

/// The classic three-point layout around the shot's camera (docs/lighting.md, "Default rig"): a
/// "key" spot 40 degrees up and 40 degrees to the camera's left, a "fill" spot low on its right
/// (a quarter of the key's irradiance, no shadow), a "rim" spot high behind the subject, and a
/// "dome": a neutral constant environment light. Aimed at the bounds; intensities relative to
/// each other only (calibrateRig sets the level).
Rig threePointRig(const Bounds& bounds, const CameraInfo& camera);

/// What calibrateRig measured.
struct Calibration {
    float factor = 1.f;        ///< what every light's intensity was multiplied by
    float medianBefore = 0.f;  ///< median covered-pixel luminance before, at the rig's exposure
    size_t coveredPixels = 0;  ///< pixels with coverage >= 1/2 (the median's population)
};

/// Multiplies every light's intensity by one factor so that the median Rec. 709 luminance of the
/// shot's covered pixels (coverage >= 1/2, divided by it), rendered by `engine` at the rig's
/// exposure, is `target` (0.18: mid-grey). The image is linear in the intensities, so one render
/// gives the exact factor. Fails with InvalidValue when no pixel is covered or the median is 0
/// (nothing the rig lights is seen), leaving the rig as it was.
Result<Calibration> calibrateRig(Engine& engine, const DeepBuffer& shot, Rig& rig, float target = 0.18f);

/// The rig a session on `shot` starts with: initialRig's lights when the scene brings any, else
/// threePointRig calibrated by calibrateRig on an engine of its own (made and released here, its
/// GL context current on the calling thread meanwhile). `calibration`, when given, receives what
/// was measured (factor 1 for imported lights).
Result<Rig> sessionRig(const Scene& scene, const DeepBuffer& shot, const ShadowGeometry& casters, bool* imported = nullptr,
                       std::vector<std::string>* warnings = nullptr, Calibration* calibration = nullptr);

} // namespace dfb
