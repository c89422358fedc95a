#pragma once
// Indirect editing's drag modes (docs/protocol.md "Drags"; issue 17; paper 000 "BendyLights"
// section 5 and Kasai et al. section 4.2): the one table behind
//   - the `drag` message's `mode` field and POST /v1/sessions/ID/drag (parseDragMode),
//   - the light types each mode applies to and whether it needs an occluder under the grab,
//   - the browser's mode selector and its keyboard shortcuts (GET /v1/schema, "dragModes"),
//   - `dfb-client drag MODE` (its help lists the names),
//   - the drag-mode table of docs/protocol.md (dragModesMarkdown(), checked by a test).
// The solvers are the server's (dfb/server/Drag.h); adding a mode = a row here and a case there.

#include <dfb/core/Result.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace dfb::protocol {

enum class DragMode {
    Shadow,             ///< paper 000 eq. 11: the light moves so that the grabbed shadow point falls under the pointer
    Hotspot,            ///< paper 000 eq. 12: the beam turns so that the grabbed point of it is under the pointer
    Highlight,          ///< paper 000 eq. 13: the light turns about the surface so that its highlight is under the pointer
    LocalShadowMove,    ///< Kasai et al. eq. 11 (E1): control points bend the light so the shadow point moves, shading at the occluder kept
    LocalShadowScale,   ///< Kasai et al. eq. 13 (E2): the tube's radii change so the shadow point moves, shading at the occluder kept
    PhysicalShadowMove, ///< Kasai et al. eq. 15: the whole light rotates about the occluder point
    DiffuseMove,        ///< Kasai et al. eq. 16: the light carries its distance and angle to the normal from the grab to the pointer
};

/// Light types as bits, for DragModeInfo::lights.
constexpr unsigned lightBit(LightType t) { return 1u << unsigned(t); }

struct DragModeInfo {
    DragMode mode;
    const char* name;      ///< the protocol's name ("shadow")
    const char* label;     ///< for menus ("Shadow drag")
    const char* shortcut;  ///< the browser's key (one lower-case letter)
    unsigned lights;       ///< the light types it applies to (lightBit)
    bool needsOccluder;    ///< the grabbed pixel must lie in a shadow of the light (its occluder is picked)
    bool selectable;       ///< `points` (BendyLight control points 1..2K) may restrict it
    const char* source;    ///< the paper and equation it implements
    const char* doc;       ///< one line for docs and help
};

/// Every mode, in the order menus list them.
const std::vector<DragModeInfo>& dragModes();
/// The row of `mode` (always found).
const DragModeInfo& dragModeInfo(DragMode mode);
/// Parses a mode's protocol name; InvalidValue names the known ones.
Result<DragMode> parseDragMode(std::string_view name);
/// The list for GET /v1/schema ("dragModes"): name, label, shortcut, lights, needsOccluder, selectable, doc.
nlohmann::json dragModesJson();
/// The table of docs/protocol.md "Drags" (checked by a test).
std::string dragModesMarkdown();
/// "spot, bendy": the light types a mode applies to, for errors and docs.
std::string dragModeLightNames(const DragModeInfo& mode);
/// "shadow, hotspot, ..." for help texts and errors.
std::string dragModeNames();

} // namespace dfb::protocol
