#include <dfb/server/InitialRig.h>

#include <algorithm>
#include <cctype>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Schema.h>

#include <cmath>
#include <glm/glm.hpp>

namespace dfb {

Rig initialRig(const Scene& scene, bool* imported) {
    Rig rig;
    rig.version = 1;
    for (const SceneLight& sl : scene.lights) {
        Light l;
        std::string name;
        for (char ch : sl.name) name += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-') ? ch : '_';
        l.name = name.empty() ? sl.type : name.substr(0, 60);
        while (rig.find(l.name)) l.name += "_";
        l.type = sl.type == "directional" ? LightType::Directional
                 : sl.type == "point"     ? LightType::Point
                 : sl.type == "area"      ? LightType::Area
                                          : LightType::Spot;
        l.position = {sl.position.x, sl.position.y, sl.position.z};
        l.direction = {sl.direction.x, sl.direction.y, sl.direction.z};
        l.color = {std::max(sl.color.r, 0.f), std::max(sl.color.g, 0.f), std::max(sl.color.b, 0.f)};
        l.intensityCd = std::max(sl.intensity, 0.f);
        l.coneAngleDeg = std::clamp(glm::degrees(sl.outerConeRadians), 0.1f, 85.f);
        l.penumbraDeg = std::clamp(glm::degrees(sl.outerConeRadians - sl.innerConeRadians), 0.f, l.coneAngleDeg);
        if (l.type == LightType::Area) {
            l.areaShape = sl.disk ? AreaShape::Disk : AreaShape::Rect;
            l.areaSize = {sl.size.x, sl.size.y};
            l.pattern = sl.pattern;
            l.shadowGrid = {sl.shadowGrid.x, sl.shadowGrid.y};
            l.shadowMapSize = protocol::AREA_DEFAULT_MAP_SIZE;
            l.shadowFilter = 0; // as switching a light to an area light does (Schema.cpp setType)
            // The roll that turns the product's frame (spotFrame) onto the node's +X.
            const lightmath::SpotFrame<float> f = lightmath::spotFrame(sl.direction);
            l.rollDeg = glm::degrees(std::atan2(glm::dot(sl.right, f.up), glm::dot(sl.right, f.right)));
        }
        rig.lights.push_back(l);
    }
    if (imported) *imported = !rig.lights.empty();
    if (!rig.lights.empty()) return rig;
    const Bounds& b = scene.bounds;
    return defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
}

} // namespace dfb
