#pragma once
// Test support for the glTF export (dfb/server/GltfExport.h): a rig with a light of every type and
// most properties off their defaults (keys, linking, barn doors, shadows off, a bent chain, a
// disk, straight and bent corner chains, a disabled light), placed over the default scene
// (scenes/tabletop.glb, about 2 x 2 units around the origin); and the JSON chunk of a GLB.

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <optional>
#include <string>

namespace dfb::test {

/// `patterns`: give the area light a pattern image name (only for tests that do not render).
inline Rig everyLightRig(bool patterns = false) {
    Rig rig;
    rig.version = 7;
    rig.exposureStops = 0.75f;
    rig.viewTransform = ViewTransform::Filmic;
    rig.time = 1.5;

    Light spot;
    spot.name = "key";
    spot.position = {1.5f, 3.f, 2.f};
    spot.direction = {-0.4f, -0.8f, -0.45f};
    spot.color = {2.f, 1.f, 0.5f}; // over 1: the punctual light's colour is scaled into [0, 1]
    spot.intensityCd = 40.f;
    spot.coneAngleDeg = 30.f;
    spot.penumbraDeg = 10.f;
    spot.barnDoorsDeg = {90.f, 25.f, 90.f, 40.f};
    spot.shadowMapSize = 1024;
    spot.shadowBias = 0.3f;
    spot.shadowFilter = 2;
    spot.exclude = {2};
    spot.keys["intensity"] = {Key{0.0, 20.0, Interp::Linear}, Key{2.0, 60.0, Interp::Smooth}};
    rig.lights.push_back(spot);

    Light hard = spot; // a hard-edged cone: penumbra 0
    hard.name = "hard";
    hard.keys.clear();
    hard.exclude.clear();
    hard.color = {0.3f, 0.6f, 0.9f};
    hard.position = {-1.5f, 2.5f, 1.f};
    hard.direction = {0.5f, -0.8f, -0.3f};
    hard.penumbraDeg = 0.f;
    hard.coneAngleDeg = 20.f;
    hard.shadow = false;
    rig.lights.push_back(hard);

    Light point;
    point.name = "bulb";
    point.type = LightType::Point;
    point.position = {0.5f, 1.5f, -1.f};
    point.color = {1.f, 0.8f, 0.6f};
    point.intensityCd = 3.f;
    point.shadowMapSize = 512;
    point.include = {1, 3};
    rig.lights.push_back(point);

    Light sun;
    sun.name = "sun";
    sun.type = LightType::Directional;
    sun.position = {0.f, 5.f, 0.f};
    sun.direction = {0.3f, -1.f, 0.2f};
    sun.intensityCd = 2.5f;
    sun.color = {1.f, 0.95f, 0.9f};
    rig.lights.push_back(sun);

    Light vertical = sun; // straight down: the frame's up hint switches to +X
    vertical.name = "zenith";
    vertical.direction = {0.f, -1.f, 0.f};
    vertical.intensityCd = 0.5f;
    vertical.shadow = false;
    rig.lights.push_back(vertical);

    Light bendy;
    bendy.name = "bendy";
    bendy.position = {-1.f, 3.f, 1.5f};
    bendy.direction = {0.2f, -0.9f, -0.3f};
    bendy.intensityCd = 25.f;
    bendy.coneAngleDeg = 25.f;
    bendy.penumbraDeg = 6.f;
    makeStraightChain(bendy, 3.f, 2);
    bendy.type = LightType::Bendy;
    bendy.controlPoints[2] = {2.2f, 0.4f, 0.1f};
    bendy.colors[4] = {1.f, 0.5f, 0.25f};
    bendy.exactDirection = true;
    bendy.keys["cp[3]"] = {Key{0.0, nlohmann::json::array({2.8, 0.3, 0.0}), Interp::Linear},
                           Key{3.0, nlohmann::json::array({2.8, 0.6, 0.2}), Interp::Linear}};
    rig.lights.push_back(bendy);

    Light area;
    area.name = "softbox";
    area.type = LightType::Area;
    area.position = {0.f, 2.5f, 0.5f};
    area.direction = {0.1f, -1.f, -0.2f};
    area.areaSize = {1.2f, 0.6f};
    area.rollDeg = 30.f;
    area.intensityCd = 6.f;
    area.color = {1.f, 0.9f, 0.8f};
    area.shadowGrid = {2, 3};
    area.shadowMapSize = 256;
    area.shadowFilter = 0;
    if (patterns) area.pattern = "stripes.png";
    rig.lights.push_back(area);

    Light disk = area;
    disk.name = "disk";
    disk.areaShape = AreaShape::Disk;
    disk.areaSize = {0.5f, 0.5f};
    disk.rollDeg = -45.f;
    disk.position = {1.f, 2.f, -0.5f};
    disk.direction = {-0.3f, -1.f, 0.1f};
    disk.pattern.clear();
    disk.shadow = false;
    disk.shadowGrid = {1, 1};
    rig.lights.push_back(disk);

    Light bent;
    bent.name = "bentpanel";
    bent.type = LightType::BentArea;
    bent.position = {-0.5f, 2.8f, -0.5f};
    bent.direction = {0.f, -1.f, 0.1f};
    bent.areaSize = {0.8f, 0.5f};
    bent.rollDeg = 10.f;
    bent.intensityCd = 4.f;
    bent.coneAngleDeg = 60.f;
    bent.penumbraDeg = 5.f;
    bent.shadowGrid = {2, 2};
    bent.shadowMapSize = 256;
    bent.shadowFilter = 0;
    makeStraightCorners(bent, 2.f, 2);
    bent.cornerPoints[1] = {1.2f, 0.2f, 0.1f};
    rig.lights.push_back(bent);

    Light off = spot; // disabled: no punctual light for other renderers, exact in extras
    off.name = "off";
    off.enabled = false;
    off.keys.clear();
    rig.lights.push_back(off);
    // Through the codec, as a client's rig arrives (directions normalised on set).
    auto parsed = protocol::rigFromJson(protocol::toJson(rig));
    return parsed ? parsed.value() : rig;
}

/// The JSON chunk of a GLB (glTF 2.0 section 4.4: 12-byte header "glTF", version 2, length; then
/// chunk 0 = length, type "JSON", text), or nothing when the bytes are not a well-formed GLB.
inline std::optional<nlohmann::json> glbJson(const std::string& glb) {
    auto u32 = [&](size_t at) {
        uint32_t v = 0;
        std::memcpy(&v, glb.data() + at, 4);
        return v;
    };
    if (glb.size() < 20 || glb.compare(0, 4, "glTF") != 0 || u32(4) != 2 || u32(8) != glb.size()) return std::nullopt;
    const uint32_t length = u32(12);
    if (u32(16) != 0x4E4F534Au || 20 + size_t(length) > glb.size() || length % 4 != 0) return std::nullopt;
    auto j = nlohmann::json::parse(glb.substr(20, length), nullptr, false);
    if (j.is_discarded()) return std::nullopt;
    return j;
}

} // namespace dfb::test
