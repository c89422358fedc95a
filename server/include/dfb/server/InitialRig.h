#pragma once
// The rig a session starts with (DESIGN section 5): the scene's KHR_lights_punctual lights when it
// has any, else a default key and fill framed on its bounds.

#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Rig.h>

namespace dfb {

/// Spot, point and directional lights of the scene become lights of the rig (names made valid and
/// unique, cone angles clamped to the rig's ranges); `imported` tells which case applied.
Rig initialRig(const Scene& scene, bool* imported = nullptr);

} // namespace dfb
