#include <dfb/server/InitialRig.h>

#include <algorithm>
#include <cctype>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Json.h>
#include <dfb/protocol/Schema.h>

#include <cmath>
#include <glm/glm.hpp>

namespace dfb {

namespace {

// Node extras are a file's text: bounded like any JSON the server reads (a light is a few KB;
// a long BendyLight chain with keys stays far below).
constexpr size_t MAX_LIGHT_JSON_BYTES = 1 << 20;

// The rig light of a node's extras.dfb_light, through the rig's own codec (every check a client's
// rig gets).
Result<Light> rigLightOf(const SceneLight& sl) {
    const std::string where = "node '" + sl.name + "': extras.dfb_light";
    auto j = protocol::parseJson(sl.rigJson, MAX_LIGHT_JSON_BYTES, where);
    if (!j) return j.error();
    auto rig = protocol::rigFromJson(nlohmann::json{{"lights", nlohmann::json::array({j.value()})}});
    if (!rig) return makeError(rig.error().code, where + ": " + rig.error().message);
    return rig->lights[0];
}

} // namespace

Rig initialRig(const Scene& scene, bool* imported, std::vector<std::string>* warnings) {
    Rig rig;
    rig.version = 1;
    auto warn = [&](const std::string& w) {
        if (warnings) warnings->push_back(w);
    };
    for (const SceneLight& sl : scene.lights) {
        if (!sl.rigJson.empty()) {
            auto exact = rigLightOf(sl);
            if (exact) {
                Light l = std::move(exact.value());
                const std::string base = l.name.substr(0, 56); // room for "_N" within the 64 characters a name may have
                for (int k = 2; rig.find(l.name); ++k) l.name = base + "_" + std::to_string(k);
                rig.lights.push_back(std::move(l));
                continue;
            }
            warn(exact.error().message + (sl.type.empty() ? " (the light is left out)" : " (read from its stand-in instead)"));
            if (sl.type.empty()) continue;
        }
        Light l;
        std::string name;
        for (char ch : sl.name) name += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-') ? ch : '_';
        l.name = name.empty() ? sl.type : name.substr(0, 56); // room for "_N" within the 64 characters a name may have
        const std::string base = l.name;
        for (int k = 2; rig.find(l.name); ++k) l.name = base + "_" + std::to_string(k);
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
    if (!rig.lights.empty() && !scene.rigSettingsJson.empty()) {
        // {"exposure", "viewTransform", "time"}: rig-level properties, checked by the codec.
        auto j = protocol::parseJson(scene.rigSettingsJson, MAX_LIGHT_JSON_BYTES, "scene extras.dfb_rig");
        Result<Rig> settings = makeError(ErrorCode::InvalidValue, "expected an object");
        if (!j) settings = j.error();
        else if (j->is_object() && !j->contains("version") && !j->contains("lights")) settings = protocol::rigFromJson(j.value());
        if (settings) {
            rig.exposureStops = settings->exposureStops;
            rig.viewTransform = settings->viewTransform;
            rig.time = settings->time;
        } else {
            warn("scene extras.dfb_rig is not {\"exposure\", \"viewTransform\", \"time\"}: " + settings.error().message + " (ignored)");
        }
    }
    if (!rig.lights.empty()) return rig;
    const Bounds& b = scene.bounds;
    return defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
}

} // namespace dfb
