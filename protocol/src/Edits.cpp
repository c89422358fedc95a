// Property-path edits (docs/protocol.md "Property paths"): one light property through its schema
// row, or a rig-level property; all-or-nothing batches.

#include "Validate.h"

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Schema.h>

#include <algorithm>
#include <set>

namespace dfb::protocol {

namespace detail {

Status setLightProperty(Light& l, const std::string& prop, const json& v, const std::string& path) {
    int index = -1;
    const Property* p = findLightProperty(prop, &index);
    if (!p) {
        if (index == -2) return invalid(path + ": malformed index (expected NAME[integer])");
        if (index >= 0 && findLightProperty(prop.substr(0, prop.find('[')))) {
            return invalid(path + ": '" + prop.substr(0, prop.find('[')) + "' takes no index");
        }
        return invalid(path + ": unknown light property '" + prop + "'");
    }
    if (p->type == PropType::Keys) return setKeys(l, prop, v, path);
    return p->set(*p, l, v, path, index);
}

} // namespace detail

using namespace detail;

Status applyChange(Rig& rig, const Change& c) {
    if (c.path == "time") {
        if (!c.value.is_number() || !std::isfinite(c.value.get<double>())) return invalid("time: expected a finite number of seconds");
        rig.time = c.value.get<double>();
        return okStatus();
    }
    if (c.path == "viewTransform") {
        if (c.value == "srgb") rig.viewTransform = ViewTransform::Srgb;
        else if (c.value == "filmic") rig.viewTransform = ViewTransform::Filmic;
        else return invalid("viewTransform: " + excerpt(c.value) + " is not \"srgb\" or \"filmic\"");
        return okStatus();
    }
    if (c.path == "groups") {
        if (!c.value.is_array()) return invalid("groups: expected an array of {\"name\", \"lights\"}");
        if (c.value.size() > MAX_LIGHT_GROUPS) {
            return makeError(ErrorCode::LimitExceeded, "groups: " + std::to_string(c.value.size()) + " groups, at most " +
                                                           std::to_string(MAX_LIGHT_GROUPS));
        }
        std::vector<LightGroup> groups;
        std::set<std::string> names;
        for (size_t i = 0; i < c.value.size(); ++i) {
            const json& g = c.value[i];
            const std::string at = "groups[" + std::to_string(i) + "]";
            if (!g.is_object() || !g.contains("name") || !g.contains("lights") || g.size() != 2) {
                return invalid(at + ": expected {\"name\", \"lights\"}");
            }
            if (!g["name"].is_string() || !validName(g["name"].get<std::string>())) {
                return invalid(at + ".name: a name is 1-64 characters of letters, digits, '_' or '-'");
            }
            LightGroup group{g["name"].get<std::string>(), {}};
            if (!names.insert(group.name).second) return invalid(at + ".name: a group named '" + group.name + "' already exists");
            if (!g["lights"].is_array()) return invalid(at + ".lights: expected an array of light names");
            std::set<std::string> members;
            for (const json& n : g["lights"]) {
                if (!n.is_string() || !rig.find(n.get<std::string>())) {
                    return makeError(ErrorCode::MissingData, at + ".lights: no light named " + excerpt(n));
                }
                if (members.insert(n.get<std::string>()).second) group.lights.push_back(n.get<std::string>());
            }
            groups.push_back(std::move(group));
        }
        rig.groups = std::move(groups);
        return okStatus();
    }
    if (c.path == "exposure") {
        const Property& row = *findRigProperty("exposure");
        auto n = getNumber(c.value, c.path, row.min, row.max);
        if (!n) return n.error();
        rig.exposureStops = n.value();
        return okStatus();
    }
    const size_t dot = c.path.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == c.path.size()) {
        return invalid("path '" + c.path + "': expected LIGHT.PROPERTY, 'exposure', 'viewTransform' or 'time'");
    }
    const std::string lightName = c.path.substr(0, dot), prop = c.path.substr(dot + 1);
    Light* l = rig.find(lightName);
    if (!l) return makeError(ErrorCode::MissingData, "path '" + c.path + "': no light named '" + lightName + "'");
    Light copy = *l;
    if (auto s = setLightProperty(copy, prop, c.value, c.path); !s) return s;
    if (prop == "name" && copy.name != lightName && rig.find(copy.name)) {
        return invalid(c.path + ": a light named '" + copy.name + "' already exists");
    }
    if (prop == "name") {
        for (LightGroup& g : rig.groups) std::replace(g.lights.begin(), g.lights.end(), lightName, copy.name);
    }
    *l = copy;
    return okStatus();
}

Status applyChanges(Rig& rig, const std::vector<Change>& changes) {
    Rig copy = rig;
    for (const Change& c : changes) {
        if (auto s = applyChange(copy, c); !s) return s;
    }
    rig = std::move(copy);
    return okStatus();
}

} // namespace dfb::protocol
