#pragma once
// Random valid edits of any row of the rig schema (protocol/Schema.h), for tests that must cover
// every property without listing them: the schema is the list. A new row gets edited by every
// such test as soon as it exists; a row of a new type fails here until its edit is written.

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Schema.h>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace dfb::test {

struct SchemaEditOptions {
    uint32_t objectCount = 1;                 ///< object ids 1..objectCount for linking rows
    std::vector<std::string> cookies = {""};  ///< file names cookie edits choose from
    std::vector<std::string> envMaps = {""};  ///< file names an environment light's map edits choose from
    std::vector<int> shadowMapSizes = {256, 512};
    float positionStep = 0.2f;                ///< largest move of a point per edit, scene units
};

/// A valid new value for row `p` of light `l` (a property path relative to the light, an element
/// row's path with its index), or nothing when the row is not edited this way (read-only rows,
/// keyframe operations and names: the tests edit them separately).
inline std::optional<std::pair<std::string, nlohmann::json>> randomEdit(const protocol::Property& p, const Light& l,
                                                                         std::mt19937& rng, const SchemaEditOptions& o) {
    using nlohmann::json;
    using protocol::PropType;
    std::uniform_real_distribution<float> u(-1.f, 1.f), u01(0.f, 1.f);
    const std::string path = p.path;
    if (p.readOnly || p.type == PropType::Keys || path == "name") return std::nullopt;
    auto jsonOf = [&](const char* prop) { return protocol::toJson(l)[prop]; };
    auto perturb = [&](float x, float lo, float hi, float step) { return std::clamp(x + step * u(rng), lo, hi); };
    auto vec = [&](const Vec3& v, float step) { return json{v[0] + step * u(rng), v[1] + step * u(rng), v[2] + step * u(rng)}; };
    auto colour = [&]() { return json{0.2f + 0.8f * u01(rng), 0.2f + 0.8f * u01(rng), 0.2f + 0.8f * u01(rng)}; };
    const int K = l.segments();
    switch (p.type) {
    case PropType::Boolean: return std::pair{path, json(!jsonOf(p.path).get<bool>())};
    case PropType::Enum: {
        // Any of the row's choices (type, an area light's shape and shading, ...).
        std::vector<std::string> choices;
        for (std::string rest = p.values; !rest.empty();) {
            const size_t comma = rest.find(',');
            choices.push_back(rest.substr(0, comma));
            rest = comma == std::string::npos ? "" : rest.substr(comma + 1);
        }
        return std::pair{path, json(choices[rng() % choices.size()])};
    }
    case PropType::String: // cookie, pattern: images; an environment's map: HDR images
        if (path == "map") return std::pair{path, json(o.envMaps[rng() % o.envMaps.size()])};
        return std::pair{path, json(o.cookies[rng() % o.cookies.size()])};
    case PropType::Integer:
        if (path == "shadowMapSize") return std::pair{path, json(o.shadowMapSizes[rng() % o.shadowMapSizes.size()])};
        return std::pair{path, json(int(p.min) + int(rng() % uint32_t(p.max - p.min + 1)))};
    case PropType::Number:
        if (path == "intensity") return std::pair{path, json(l.intensityCd * (0.5f + u01(rng)) + 0.01f)};
        if (path == "coneAngle") return std::pair{path, json(perturb(l.coneAngleDeg, 10.f, 70.f, 4.f))};
        if (path == "penumbra") return std::pair{path, json(std::min(l.coneAngleDeg, perturb(l.penumbraDeg, 0.f, 20.f, 3.f)))};
        if (path == "shadowBias") return std::pair{path, json(perturb(l.shadowBias, 0.5f, 4.f, 0.6f))};
        if (path == "roll") return std::pair{path, json(perturb(l.rollDeg, -90.f, 90.f, 30.f))};
        if (path == "cr[]") { // a bent area light's corner radius, not a source's
            const int per = 2 * l.cornerSegments() + 1, i = int(rng() % 4u) * per + 1 + int(rng() % uint32_t(per - 1));
            return std::pair{"cr[" + std::to_string(i) + "]", json(perturb(l.cornerRadii[size_t(i)], 0.f, 4.f, 0.2f))};
        }
        if (path == "r[]") {
            const int i = 1 + int(rng() % uint32_t(2 * K));
            return std::pair{"r[" + std::to_string(i) + "]", json(perturb(l.radii[size_t(i)], 0.f, 4.f, 0.2f))};
        }
        break;
    case PropType::Vec3:
        if (path == "position") return std::pair{path, vec(l.position, o.positionStep)};
        if (path == "ccp[]") {
            const int i = int(rng() % uint32_t(l.cornerPoints.size()));
            return std::pair{"ccp[" + std::to_string(i) + "]", vec(l.cornerPoints[size_t(i)], 0.5f * o.positionStep)};
        }
        if (path == "cp[]") {
            const int i = 1 + int(rng() % uint32_t(2 * K));
            return std::pair{"cp[" + std::to_string(i) + "]", vec(l.controlPoints[size_t(i - 1)], o.positionStep)};
        }
        break;
    case PropType::Direction: {
        const json d = vec(l.direction, 0.15f);
        return std::pair{path, d};
    }
    case PropType::Color:
        if (path == "cpColor[]") return std::pair{"cpColor[" + std::to_string(rng() % uint32_t(2 * K + 1)) + "]", colour()};
        return std::pair{path, colour()};
    case PropType::Numbers: {
        json v = json::array();
        if (path == "size") { // an area light's
            for (int i = 0; i < 2; ++i) v.push_back(perturb(l.areaSize[size_t(i)], 0.2f, 2.f, 0.3f));
        } else if (path == "shadowGrid") {
            for (int i = 0; i < 2; ++i) v.push_back(1 + int(rng() % 4u));
        } else if (path == "cornerRadii") {
            const size_t per = size_t(2 * l.cornerSegments() + 1);
            for (size_t i = 0; i < l.cornerRadii.size(); ++i)
                v.push_back(i % per == 0 ? l.cornerRadii[i] : std::max(0.f, l.cornerRadii[i] + 0.15f * u(rng)));
        } else if (p.size > 0) { // barn doors
            for (int i = 0; i < p.size; ++i) v.push_back(u01(rng) < 0.5f ? 90.f : 10.f + 80.f * u01(rng));
        } else { // radii
            for (float r : l.radii) v.push_back(std::max(0.f, r + 0.15f * u(rng)));
            v[0] = l.radii[0];
        }
        return std::pair{path, v};
    }
    case PropType::IdList: {
        json v = json::array();
        for (uint32_t id = 1; id <= o.objectCount; ++id)
            if (u01(rng) < 0.3f) v.push_back(id);
        return std::pair{path, v};
    }
    case PropType::Points: {
        json v = json::array();
        for (const Vec3& q : path == "cornerPoints" ? l.cornerPoints : l.controlPoints) v.push_back(vec(q, 0.5f * o.positionStep));
        return std::pair{path, v};
    }
    case PropType::Colors: {
        json v = json::array();
        for (size_t i = 0; i < l.colors.size(); ++i) v.push_back(colour());
        return std::pair{path, v};
    }
    case PropType::Keys:
    case PropType::Groups: break; // a rig-level row: no light property to perturb
    }
    ADD_FAILURE() << "no random edit for schema row '" << path << "' (type " << protocol::toString(p.type)
                  << "): add one in tests/support/SchemaEdits.h";
    return std::nullopt;
}

} // namespace dfb::test
