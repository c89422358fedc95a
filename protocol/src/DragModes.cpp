#include <dfb/protocol/DragModes.h>
#include <dfb/protocol/Schema.h>

namespace dfb::protocol {

namespace {
constexpr unsigned SPOT = lightBit(LightType::Spot), POINT = lightBit(LightType::Point), SUN = lightBit(LightType::Directional),
                   BENDY = lightBit(LightType::Bendy);
constexpr unsigned ALL = SPOT | POINT | SUN | BENDY;
} // namespace

const std::vector<DragModeInfo>& dragModes() {
    static const std::vector<DragModeInfo> modes = {
        {DragMode::Shadow, "shadow", "Shadow drag", "s", ALL, true, true, "paper 000 eq. 11",
         "grab a shadow point: the light moves (a sun turns) so that the occluder's shadow falls under the pointer"},
        {DragMode::Hotspot, "hotspot", "Hotspot drag", "o", SPOT | BENDY, false, true, "paper 000 eq. 12",
         "grab a point of the beam: the light turns about its source so that point is under the pointer"},
        {DragMode::Highlight, "highlight", "Highlight drag", "g", ALL, false, true, "paper 000 eq. 13",
         "the light turns about the surface under the pointer so that its specular highlight is there"},
        {DragMode::LocalShadowMove, "localShadowMove", "Local shadow move", "m", BENDY, true, true,
         "Kasai et al. eqs. 11-12 (E1)",
         "grab a shadow point: the BendyLight's control points bend the light so the shadow point follows the pointer while "
         "the occluder keeps its shading"},
        {DragMode::LocalShadowScale, "localShadowScale", "Local shadow scale", "x", BENDY, true, true,
         "Kasai et al. eqs. 13-14 (E2)",
         "grab a shadow point: the BendyLight's radii change so the shadow grows or shrinks towards the pointer while the "
         "occluder keeps its shading"},
        {DragMode::PhysicalShadowMove, "physicalShadowMove", "Physical shadow move", "p", ALL, true, true, "Kasai et al. eq. 15",
         "grab a shadow point: the whole light rotates about the occluder point so that its shadow falls under the pointer"},
        {DragMode::DiffuseMove, "diffuseMove", "Diffuse move", "i", ALL, false, true, "Kasai et al. eq. 16",
         "grab a lit point: the light moves with the pointer keeping its distance and angle to the surface normal, so the "
         "brightness there follows"},
    };
    return modes;
}

const DragModeInfo& dragModeInfo(DragMode mode) {
    for (const DragModeInfo& m : dragModes()) {
        if (m.mode == mode) return m;
    }
    return dragModes().front(); // unreachable: every enumerator has a row (protocol_drag_modes test)
}

std::string dragModeNames() {
    std::string out;
    for (const DragModeInfo& m : dragModes()) out += (out.empty() ? "" : ", ") + std::string(m.name);
    return out;
}

Result<DragMode> parseDragMode(std::string_view name) {
    for (const DragModeInfo& m : dragModes()) {
        if (name == m.name) return m.mode;
    }
    return makeError(ErrorCode::InvalidValue, "drag mode '" + std::string(name.substr(0, 64)) + "' is not one of: " + dragModeNames());
}

namespace {
std::vector<std::string> typeNames(unsigned lights) {
    std::vector<std::string> out;
    for (LightType t : {LightType::Spot, LightType::Point, LightType::Directional, LightType::Bendy}) {
        if (lights & lightBit(t)) out.push_back(lightTypeName(t));
    }
    return out;
}
} // namespace

nlohmann::json dragModesJson() {
    nlohmann::json arr = nlohmann::json::array();
    for (const DragModeInfo& m : dragModes()) {
        arr.push_back({{"name", m.name},
                       {"label", m.label},
                       {"shortcut", m.shortcut},
                       {"lights", typeNames(m.lights)},
                       {"needsOccluder", m.needsOccluder},
                       {"selectable", m.selectable},
                       {"source", m.source},
                       {"doc", m.doc}});
    }
    return arr;
}

std::string dragModeLightNames(const DragModeInfo& mode) {
    std::string out;
    for (const std::string& t : typeNames(mode.lights)) out += (out.empty() ? "" : ", ") + t;
    return out;
}

std::string dragModesMarkdown() {
    std::string out = "| mode | key | lights | grab | from | what it does |\n|---|---|---|---|---|---|\n";
    for (const DragModeInfo& m : dragModes()) {
        out += "| `" + std::string(m.name) + "` | " + m.shortcut + " | " + dragModeLightNames(m) + " | " +
               (m.needsOccluder ? "a shadowed pixel" : "a lit pixel") + " | " + m.source + " | " + m.doc + " |\n";
    }
    return out;
}

} // namespace dfb::protocol
