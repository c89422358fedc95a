#pragma once
// The rig a session starts with (DESIGN section 5): the scene's KHR_lights_punctual lights when it
// has any, else a default key and fill framed on its bounds.

#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Rig.h>

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
Rig initialRig(const Scene& scene, bool* imported = nullptr, std::vector<std::string>* warnings = nullptr);

} // namespace dfb
