// The rig as JSON (docs/protocol.md "The rig"): written and read through the schema's rows.

#include "Validate.h"

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Json.h>
#include <dfb/protocol/Schema.h>

#include <set>

namespace dfb::protocol {
namespace {

using namespace detail;

Result<Light> lightFromJson(const json& j, const std::string& where) {
    if (!j.is_object()) return invalid(where + ": a light must be an object");
    Light l;
    // Order matters: coneAngle before penumbra (a penumbra within a wider new cone validates),
    // type and controlPoints before the other chain lists (they need the chain's size).
    for (const char* first : {"coneAngle", "controlPoints", "type"}) {
        if (!j.contains(first)) continue;
        if (std::string(first) == "controlPoints") {
            l.type = LightType::Bendy;
            if (!j["controlPoints"].is_array()) return invalid(where + ".controlPoints: expected an array");
            l.controlPoints.assign(j["controlPoints"].size(), Vec3{0, 0, 0});
            l.radii.assign(l.controlPoints.size() + 1, 0.f);
            l.colors.assign(l.controlPoints.size() + 1, Vec3{1, 1, 1});
        }
        if (auto s = setLightProperty(l, first, j[first], where + "." + first); !s) return s.error();
    }
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (it.key() == "coneAngle" || it.key() == "controlPoints" || it.key() == "type" || it.key() == "keys") continue;
        if (auto s = setLightProperty(l, it.key(), it.value(), where + "." + it.key()); !s) return s.error();
    }
    if (l.name.empty()) return invalid(where + ": a light needs a name");
    if (l.type == LightType::Bendy && l.controlPoints.empty()) makeStraightChain(l, 4.f);
    if (j.contains("keys")) {
        if (auto s = setLightProperty(l, "keys", j["keys"], where + ".keys"); !s) return s.error();
    }
    return l;
}

} // namespace

json toJson(const Light& l) {
    json j = json::object();
    for (const Property& p : lightProperties()) {
        if (p.get && (!p.present || p.present(l))) j[p.path] = p.get(l);
    }
    shortestFloats(j); // 0.95, not 0.949999988079071 (the rig's numbers are floats)
    return j;
}

json toJson(const Rig& rig) {
    json lights = json::array();
    for (const Light& l : rig.lights) lights.push_back(toJson(l));
    json r{{"version", rig.version},
           {"exposure", rig.exposureStops},
           {"viewTransform", rig.viewTransform == ViewTransform::Filmic ? "filmic" : "srgb"},
           {"time", rig.time},
           {"lights", std::move(lights)}};
    shortestFloats(r["exposure"]);
    shortestFloats(r["time"]);
    if (!rig.groups.empty()) {
        json groups = json::array();
        for (const LightGroup& g : rig.groups) groups.push_back({{"name", g.name}, {"lights", g.lights}});
        r["groups"] = std::move(groups);
    }
    return r;
}

Result<Rig> rigFromJson(const json& j) {
    if (!j.is_object()) return invalid("rig: expected an object");
    Rig rig;
    const json* groups = nullptr; // after the lights, which its members name
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (it.key() == "groups") {
            groups = &*it;
        } else if (it.key() == "version") {
            if (!it->is_number_unsigned()) return invalid("rig.version: expected a non-negative integer");
            rig.version = it->get<uint64_t>();
        } else if (findRigProperty(it.key())) {
            if (auto s = applyChange(rig, {it.key(), *it}); !s) return invalid("rig." + s.error().message);
        } else if (it.key() == "lights") {
            if (!it->is_array()) return invalid("rig.lights: expected an array");
            std::set<std::string> names;
            for (size_t i = 0; i < it->size(); ++i) {
                auto l = lightFromJson((*it)[i], "rig.lights[" + std::to_string(i) + "]");
                if (!l) return l.error();
                if (!names.insert(l->name).second) return invalid("rig.lights: duplicate light name '" + l->name + "'");
                rig.lights.push_back(l.value());
            }
        } else {
            return invalid("rig: unknown field '" + it.key() + "'");
        }
    }
    if (groups) {
        // A replaced rig drops the members it no longer has (a light deleted by a PUT leaves its
        // groups); everything else is checked as an edit of "groups" is.
        json kept = *groups;
        if (kept.is_array()) {
            for (json& g : kept) {
                if (!g.is_object() || !g.contains("lights") || !g["lights"].is_array()) continue;
                json members = json::array();
                for (const json& n : g["lights"]) {
                    if (!n.is_string() || rig.find(n.get<std::string>())) members.push_back(n);
                }
                g["lights"] = std::move(members);
            }
        }
        if (auto s = applyChange(rig, {"groups", kept}); !s) return invalid("rig." + s.error().message);
    }
    return rig;
}

} // namespace dfb::protocol
