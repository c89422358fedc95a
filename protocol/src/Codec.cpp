#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Json.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <type_traits>

namespace dfb::protocol {
namespace {

using json = nlohmann::json;

Error invalid(const std::string& what) { return makeError(ErrorCode::InvalidValue, what); }

bool validName(const std::string& n) {
    if (n.empty() || n.size() > 64) return false;
    for (char c : n) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) return false;
    }
    return true;
}

Result<float> getNumber(const json& v, const std::string& path, double lo, double hi) {
    if (!v.is_number()) return invalid(path + ": expected a number, got " + std::string(v.type_name()));
    const double d = v.get<double>();
    if (!std::isfinite(d)) return invalid(path + ": not a finite number");
    if (d < lo || d > hi) {
        return invalid(path + ": " + excerpt(v) + " is out of range [" + json(lo).dump() + ", " + json(hi).dump() + "]");
    }
    return float(d);
}

Result<Vec3> getVec3(const json& v, const std::string& path, double lo, double hi) {
    if (!v.is_array() || v.size() != 3) return invalid(path + ": expected an array of 3 numbers");
    Vec3 out{};
    for (size_t i = 0; i < 3; ++i) {
        auto n = getNumber(v[i], path + "[" + std::to_string(i) + "]", lo, hi);
        if (!n) return n.error();
        out[i] = n.value();
    }
    return out;
}

Result<bool> getBool(const json& v, const std::string& path) {
    if (!v.is_boolean()) return invalid(path + ": expected true or false, got " + std::string(v.type_name()));
    return v.get<bool>();
}

// Largest coordinate accepted: far beyond any scene, small enough that squares stay finite in float.
constexpr double MAX_COORD = 1e7;

// Resamples a per-control-point list to n entries (linear in the index), when a chain's segment
// count changes.
template <typename V> std::vector<V> resample(const std::vector<V>& in, size_t n) {
    std::vector<V> out(n);
    for (size_t i = 0; i < n; ++i) {
        if (in.empty()) break;
        const double x = n > 1 ? double(i) * double(in.size() - 1) / double(n - 1) : 0.0;
        const size_t a = size_t(x), b = std::min(a + 1, in.size() - 1);
        const float f = float(x - double(a));
        if constexpr (std::is_same_v<V, float>) out[i] = in[a] + (in[b] - in[a]) * f;
        else for (int c = 0; c < 3; ++c) out[i][size_t(c)] = in[a][size_t(c)] + (in[b][size_t(c)] - in[a][size_t(c)]) * f;
    }
    return out;
}

// "cp[3]" -> ("cp", 3); no index -> -1; a malformed index -> -2.
std::pair<std::string, int> splitIndex(const std::string& prop) {
    const size_t open = prop.find('[');
    if (open == std::string::npos) return {prop, -1};
    if (prop.back() != ']' || open + 2 > prop.size() - 1) return {prop.substr(0, open), -2};
    const std::string digits = prop.substr(open + 1, prop.size() - open - 2);
    if (digits.empty() || digits.size() > 3 || digits.find_first_not_of("0123456789") != std::string::npos) {
        return {prop.substr(0, open), -2};
    }
    return {prop.substr(0, open), std::stoi(digits)};
}

Status setChainProperty(Light& l, const std::string& name, int index, const json& v, const std::string& path) {
    if (l.type != LightType::Bendy) return invalid(path + ": '" + name + "' applies to BendyLights only (set type to \"bendy\")");
    const int K = l.segments();
    if (name == "controlPoints") {
        if (v.is_array() && v.size() > size_t(2 * MAX_BENDY_SEGMENTS)) {
            return makeError(ErrorCode::LimitExceeded, path + ": " + std::to_string(v.size()) + " control points; the limit is " +
                                                           std::to_string(2 * MAX_BENDY_SEGMENTS) + " per chain (" +
                                                           std::to_string(MAX_BENDY_SEGMENTS) + " segments)");
        }
        if (!v.is_array() || v.size() < 2 || v.size() % 2 != 0) {
            return invalid(path + ": expected an even number (2.." + std::to_string(2 * MAX_BENDY_SEGMENTS) +
                           ") of [a, b, c] points in the light's frame");
        }
        std::vector<Vec3> pts;
        for (size_t i = 0; i < v.size(); ++i) {
            auto p = getVec3(v[i], path + "[" + std::to_string(i) + "]", -MAX_COORD, MAX_COORD);
            if (!p) return p.error();
            pts.push_back(p.value());
        }
        if (pts.size() != l.controlPoints.size()) {
            l.radii = resample(l.radii, pts.size() + 1);
            l.colors = resample(l.colors, pts.size() + 1);
        }
        l.controlPoints = std::move(pts);
    } else if (name == "cp") {
        if (index == 0) return invalid(path + ": cp[0] is the light's source; move the light instead");
        if (index < 1 || index > 2 * K) return invalid(path + ": index out of range 1.." + std::to_string(2 * K));
        auto p = getVec3(v, path, -MAX_COORD, MAX_COORD);
        if (!p) return p.error();
        l.controlPoints[size_t(index - 1)] = p.value();
    } else if (name == "radii") {
        if (!v.is_array() || v.size() != size_t(2 * K + 1)) return invalid(path + ": expected " + std::to_string(2 * K + 1) + " radii");
        for (size_t i = 0; i < v.size(); ++i) {
            auto r = getNumber(v[i], path + "[" + std::to_string(i) + "]", 0.0, MAX_COORD);
            if (!r) return r.error();
            l.radii[i] = r.value();
        }
    } else if (name == "r") {
        if (index < 0 || index > 2 * K) return invalid(path + ": index out of range 0.." + std::to_string(2 * K));
        auto r = getNumber(v, path, 0.0, MAX_COORD);
        if (!r) return r.error();
        l.radii[size_t(index)] = r.value();
    } else if (name == "colors") {
        if (!v.is_array() || v.size() != size_t(2 * K + 1)) return invalid(path + ": expected " + std::to_string(2 * K + 1) + " colours");
        for (size_t i = 0; i < v.size(); ++i) {
            auto c = getVec3(v[i], path + "[" + std::to_string(i) + "]", 0.0, 1e6);
            if (!c) return c.error();
            l.colors[i] = c.value();
        }
    } else if (name == "cpColor") {
        if (index < 0 || index > 2 * K) return invalid(path + ": index out of range 0.." + std::to_string(2 * K));
        auto c = getVec3(v, path, 0.0, 1e6);
        if (!c) return c.error();
        l.colors[size_t(index)] = c.value();
    } else {
        return invalid(path + ": unknown light property '" + name + "'");
    }
    return okStatus();
}

Status setLightProperty(Light& l, const std::string& prop, const json& v, const std::string& path);

json keyToJson(const Key& k) {
    return json{{"t", k.time}, {"value", k.value}, {"interp", k.interp == Interp::Smooth ? "smooth" : "linear"}};
}

// Parses and validates one key of `prop` (its value must be acceptable to the property).
Result<Key> keyFromJson(const Light& l, const std::string& prop, const json& j, const std::string& path) {
    if (!j.is_object() || !j.contains("t") || !j["t"].is_number() || !j.contains("value")) {
        return invalid(path + ": a key is {\"t\": seconds, \"value\": ..., \"interp\": \"linear\"|\"smooth\"}");
    }
    Key k;
    k.time = j["t"].get<double>();
    if (!std::isfinite(k.time)) return invalid(path + ".t: not a finite number");
    k.value = j["value"];
    if (!(k.value.is_number() || (k.value.is_array() && !k.value.empty() &&
                                  std::all_of(k.value.begin(), k.value.end(), [](const json& e) { return e.is_number(); })))) {
        return invalid(path + ".value: only numeric properties can be keyed");
    }
    const std::string interp = j.value("interp", std::string("linear"));
    if (interp != "linear" && interp != "smooth") return invalid(path + ".interp: \"linear\" or \"smooth\"");
    k.interp = interp == "smooth" ? Interp::Smooth : Interp::Linear;
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (it.key() != "t" && it.key() != "value" && it.key() != "interp") return invalid(path + ": unknown key field '" + it.key() + "'");
    }
    Light probe = l;
    if (auto s = setLightProperty(probe, prop, k.value, path + ".value"); !s) return s.error();
    return k;
}

void insertKey(std::vector<Key>& keys, Key k) {
    auto it = std::find_if(keys.begin(), keys.end(), [&](const Key& e) { return e.time >= k.time; });
    if (it != keys.end() && it->time == k.time) *it = std::move(k);
    else keys.insert(it, std::move(k));
}

Status setKeys(Light& l, const std::string& name, const json& v, const std::string& path) {
    if (name == "keys") { // the whole set: {"prop": [key, ...], ...}
        if (!v.is_object()) return invalid(path + ": expected {\"property\": [keys...]}");
        std::map<std::string, std::vector<Key>> all;
        for (auto it = v.begin(); it != v.end(); ++it) {
            if (!it->is_array()) return invalid(path + "." + it.key() + ": expected an array of keys");
            for (size_t i = 0; i < it->size(); ++i) {
                auto k = keyFromJson(l, it.key(), (*it)[i], path + "." + it.key() + "[" + std::to_string(i) + "]");
                if (!k) return k.error();
                insertKey(all[it.key()], k.value());
            }
        }
        l.keys = std::move(all);
        return okStatus();
    }
    // "key": {"path": PROP, "t": .., "value": .., "interp": ..} adds or replaces the key at t;
    // "unkey": {"path": PROP, "t": ..} removes it.
    if (!v.is_object() || !v.contains("path") || !v["path"].is_string()) return invalid(path + ": expected {\"path\": property, ...}");
    const std::string prop = v["path"];
    if (name == "key") {
        json k = v;
        k.erase("path");
        auto key = keyFromJson(l, prop, k, path);
        if (!key) return key.error();
        insertKey(l.keys[prop], key.value());
        return okStatus();
    }
    if (!v.contains("t") || !v["t"].is_number()) return invalid(path + ".t: expected a number");
    auto it = l.keys.find(prop);
    const double t = v["t"].get<double>();
    if (it == l.keys.end()) return makeError(ErrorCode::MissingData, path + ": '" + prop + "' has no keys");
    auto& ks = it->second;
    const auto before = ks.size();
    ks.erase(std::remove_if(ks.begin(), ks.end(), [&](const Key& k) { return std::abs(k.time - t) < 1e-9; }), ks.end());
    if (ks.size() == before) return makeError(ErrorCode::MissingData, path + ": no key of '" + prop + "' at t = " + excerpt(json(t)));
    if (ks.empty()) l.keys.erase(it);
    return okStatus();
}

Status setLightProperty(Light& l, const std::string& prop, const json& v, const std::string& path) {
    if (prop == "keys" || prop == "key" || prop == "unkey") return setKeys(l, prop, v, path);
    const auto [base, index] = splitIndex(prop);
    if (index == -2) return invalid(path + ": malformed index (expected NAME[integer])");
    if (index >= 0 || base == "controlPoints" || base == "radii" || base == "colors") {
        if (index >= 0 && base != "cp" && base != "r" && base != "cpColor") {
            return invalid(path + ": '" + base + "' takes no index");
        }
        return setChainProperty(l, base, index, v, path);
    }
    if (prop == "name") {
        if (!v.is_string() || !validName(v.get<std::string>())) {
            return invalid(path + ": a name is 1-64 characters of letters, digits, '_' or '-'");
        }
        l.name = v.get<std::string>();
    } else if (prop == "type") {
        if (v == "spot") {
            l.type = LightType::Spot;
        } else if (v == "directional") {
            l.type = LightType::Directional;
        } else if (v == "point") {
            l.type = LightType::Point;
        } else if (v == "bendy") {
            // A new chain starts straight along the axis, matching the cone: it looks like the spot.
            if (l.controlPoints.empty()) makeStraightChain(l, 4.f);
            l.type = LightType::Bendy;
        } else {
            return invalid(path + ": unknown light type " + excerpt(v) + " (\"spot\", \"point\", \"bendy\" or \"directional\")");
        }
    } else if (prop == "include" || prop == "exclude") {
        if (!v.is_array() || v.size() > 4096) return invalid(path + ": expected an array of object ids (at most 4096)");
        std::vector<uint32_t> ids;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!v[i].is_number_unsigned() || v[i].get<uint64_t>() < 1 || v[i].get<uint64_t>() > (1u << 24)) {
                return invalid(path + "[" + std::to_string(i) + "]: object ids are integers from 1");
            }
            ids.push_back(uint32_t(v[i].get<uint64_t>()));
        }
        (prop == "include" ? l.include : l.exclude) = std::move(ids);
    } else if (prop == "exactDirection") {
        auto b = getBool(v, path);
        if (!b) return b.error();
        l.exactDirection = b.value();
    } else if (prop == "warning") {
        if (!v.is_string()) return invalid(path + ": expected a string");
        // Server-computed: accepted in a whole rig (round trips) but not meaningful to set.
    } else if (prop == "enabled") {
        auto b = getBool(v, path);
        if (!b) return b.error();
        l.enabled = b.value();
    } else if (prop == "position") {
        auto p = getVec3(v, path, -MAX_COORD, MAX_COORD);
        if (!p) return p.error();
        l.position = p.value();
    } else if (prop == "direction") {
        auto d = getVec3(v, path, -MAX_COORD, MAX_COORD);
        if (!d) return d.error();
        const Vec3 a = d.value();
        const float len = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        if (!(len > 1e-12f) || !std::isfinite(len)) return invalid(path + ": direction must not be zero");
        // Already-unit directions are kept bit for bit, so a rig survives a JSON round trip.
        l.direction = std::abs(len - 1.f) < 1e-6f ? a : Vec3{a[0] / len, a[1] / len, a[2] / len};
    } else if (prop == "color") {
        auto c = getVec3(v, path, 0.0, 1e6);
        if (!c) return c.error();
        l.color = c.value();
    } else if (prop == "intensity") {
        auto n = getNumber(v, path, 0.0, 1e12);
        if (!n) return n.error();
        l.intensityCd = n.value();
    } else if (prop == "coneAngle") {
        auto n = getNumber(v, path, 0.1, 85.0);
        if (!n) return n.error();
        l.coneAngleDeg = n.value();
        l.penumbraDeg = std::min(l.penumbraDeg, l.coneAngleDeg);
    } else if (prop == "penumbra") {
        auto n = getNumber(v, path, 0.0, 85.0);
        if (!n) return n.error();
        if (n.value() > l.coneAngleDeg) return invalid(path + ": penumbra must not exceed coneAngle");
        l.penumbraDeg = n.value();
    } else if (prop == "shadow") {
        auto b = getBool(v, path);
        if (!b) return b.error();
        l.shadow = b.value();
    } else if (prop == "shadowMapSize") {
        if (!v.is_number_integer()) return invalid(path + ": expected an integer");
        const int64_t s = v.get<int64_t>();
        if (s < 64 || s > 8192 || (s & (s - 1)) != 0) return invalid(path + ": must be a power of two in [64, 8192]");
        l.shadowMapSize = int(s);
    } else if (prop == "shadowBias") {
        auto n = getNumber(v, path, 0.0, 16.0);
        if (!n) return n.error();
        l.shadowBias = n.value();
    } else if (prop == "shadowFilter") {
        if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > 4) {
            return invalid(path + ": must be an integer in [0, 4] (shadow-map texels)");
        }
        l.shadowFilter = int(v.get<int64_t>());
    } else if (prop == "cookie") {
        if (!v.is_string()) return invalid(path + ": expected a file name (string)");
        const std::string c = v.get<std::string>();
        // A name inside the asset folder: no absolute paths, no way out of it.
        if (c.size() > 255 || (!c.empty() && (c[0] == '/' || c.find("..") != std::string::npos || c.find('\\') != std::string::npos ||
                                              c.find('\0') != std::string::npos))) {
            return invalid(path + ": a cookie is a relative file name inside the asset folder (no '/' at the start, no '..')");
        }
        l.cookie = c;
    } else if (prop == "barnDoors") {
        if (!v.is_array() || v.size() != 4) return invalid(path + ": expected [left, right, top, bottom] in degrees");
        std::array<float, 4> doors{};
        for (size_t i = 0; i < 4; ++i) {
            auto n = getNumber(v[i], path + "[" + std::to_string(i) + "]", 0.0, 90.0);
            if (!n) return n.error();
            doors[i] = n.value();
        }
        l.barnDoorsDeg = doors;
    } else {
        return invalid(path + ": unknown light property '" + prop + "'");
    }
    return okStatus();
}

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

std::string lightTypeName(LightType t) {
    return t == LightType::Bendy ? "bendy" : t == LightType::Directional ? "directional" : t == LightType::Point ? "point" : "spot";
}

} // namespace

json toJson(const Light& l) {
    json j = json{{"name", l.name},         {"type", lightTypeName(l.type)}, {"enabled", l.enabled},
                {"position", l.position}, {"direction", l.direction},      {"color", l.color},
                {"intensity", l.intensityCd}, {"coneAngle", l.coneAngleDeg}, {"penumbra", l.penumbraDeg},
                {"shadow", l.shadow},     {"shadowMapSize", l.shadowMapSize}, {"shadowBias", l.shadowBias},
                {"shadowFilter", l.shadowFilter}, {"barnDoors", l.barnDoorsDeg}};
    if (!l.cookie.empty()) j["cookie"] = l.cookie;
    if (l.type == LightType::Bendy || !l.controlPoints.empty()) {
        j["controlPoints"] = l.controlPoints;
        j["radii"] = l.radii;
        j["colors"] = l.colors;
        j["exactDirection"] = l.exactDirection;
    }
    if (!l.include.empty()) j["include"] = l.include;
    if (!l.exclude.empty()) j["exclude"] = l.exclude;
    if (!l.warning.empty()) j["warning"] = l.warning;
    if (!l.keys.empty()) {
        json keys = json::object();
        for (const auto& [prop, ks] : l.keys) {
            json arr = json::array();
            for (const Key& k : ks) arr.push_back(keyToJson(k));
            keys[prop] = arr;
        }
        j["keys"] = keys;
    }
    return j;
}

json toJson(const Rig& rig) {
    json lights = json::array();
    for (const Light& l : rig.lights) lights.push_back(toJson(l));
    return json{{"version", rig.version},
                {"exposure", rig.exposureStops},
                {"viewTransform", rig.viewTransform == ViewTransform::Filmic ? "filmic" : "srgb"},
                {"time", rig.time},
                {"lights", lights}};
}

Result<Rig> rigFromJson(const json& j) {
    if (!j.is_object()) return invalid("rig: expected an object");
    Rig rig;
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (it.key() == "version") {
            if (!it->is_number_unsigned()) return invalid("rig.version: expected a non-negative integer");
            rig.version = it->get<uint64_t>();
        } else if (it.key() == "exposure") {
            auto n = getNumber(*it, "rig.exposure", -20.0, 20.0);
            if (!n) return n.error();
            rig.exposureStops = n.value();
        } else if (it.key() == "viewTransform") {
            if (auto s = applyChange(rig, {"viewTransform", *it}); !s) return invalid("rig." + s.error().message);
        } else if (it.key() == "time") {
            if (!it->is_number() || !std::isfinite(it->get<double>())) return invalid("rig.time: expected a finite number");
            rig.time = it->get<double>();
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
    return rig;
}

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
    if (c.path == "exposure") {
        auto n = getNumber(c.value, c.path, -20.0, 20.0);
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

namespace {

// Catmull-Rom on scalars: p1 at s = 0, p2 at s = 1, with the neighbours p0, p3 (non-uniform in
// time: tangents from the neighbours' time spacing).
double catmullRom(double p0, double p1, double p2, double p3, double t0, double t1, double t2, double t3, double s) {
    const double dt = t2 - t1;
    const double m1 = (t2 - t0) > 0 ? (p2 - p0) / (t2 - t0) * dt : 0.0;
    const double m2 = (t3 - t1) > 0 ? (p3 - p1) / (t3 - t1) * dt : 0.0;
    const double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * p1 + (s3 - 2 * s2 + s) * m1 + (-2 * s3 + 3 * s2) * p2 + (s3 - s2) * m2;
}

json interpolateKeys(const std::vector<Key>& ks, double time) {
    if (time <= ks.front().time) return ks.front().value;
    if (time >= ks.back().time) return ks.back().value;
    size_t i = 0;
    while (i + 1 < ks.size() && ks[i + 1].time <= time) ++i;
    const Key &a = ks[i], &b = ks[i + 1];
    const double s = (time - a.time) / (b.time - a.time);
    const Key& before = i > 0 ? ks[i - 1] : a;
    const Key& after = i + 2 < ks.size() ? ks[i + 2] : b;
    auto one = [&](const json& va, const json& vb, const json& v0, const json& v3) {
        const double x1 = va.get<double>(), x2 = vb.get<double>();
        if (a.interp == Interp::Linear) return x1 + (x2 - x1) * s;
        return catmullRom(v0.get<double>(), x1, x2, v3.get<double>(), before.time, a.time, b.time, after.time, s);
    };
    if (a.value.is_number()) {
        if (!b.value.is_number()) return a.value;
        const json v0 = before.value.is_number() ? before.value : a.value, v3 = after.value.is_number() ? after.value : b.value;
        return one(a.value, b.value, v0, v3);
    }
    if (!b.value.is_array() || b.value.size() != a.value.size()) return a.value;
    json out = json::array();
    for (size_t c = 0; c < a.value.size(); ++c) {
        const json v0 = before.value.is_array() && before.value.size() == a.value.size() ? before.value[c] : a.value[c];
        const json v3 = after.value.is_array() && after.value.size() == a.value.size() ? after.value[c] : b.value[c];
        out.push_back(one(a.value[c], b.value[c], v0, v3));
    }
    return out;
}

} // namespace

Rig evaluateRig(const Rig& rig) {
    Rig out = rig;
    for (Light& l : out.lights) {
        const auto keys = l.keys; // assigning `l` below replaces its key map
        for (const auto& [prop, ks] : keys) {
            if (ks.empty()) continue;
            Light probe = l;
            if (setLightProperty(probe, prop, interpolateKeys(ks, rig.time), l.name + "." + prop).ok()) l = probe;
        }
    }
    return out;
}

uint64_t lightMemoryBytes(const Light& l, const RigLimits& limits) {
    if (!l.enabled) return 0;
    uint64_t bytes = limits.imagePixels * 8; // its contribution image, RGBA16F
    if (l.shadow) {
        const uint64_t side = uint64_t(l.shadowMapSize);
        bytes += side * side * 4 * (l.type == LightType::Point ? 6 : 1);
    }
    return bytes;
}

Status checkRigLimits(const Rig& rig, const RigLimits& limits) {
    auto over = [](const std::string& what) { return makeError(ErrorCode::LimitExceeded, what); };
    if (rig.lights.size() > limits.maxLights) {
        return over("the rig would have " + std::to_string(rig.lights.size()) + " lights; the limit is " +
                    std::to_string(limits.maxLights) + " lights per rig (--max-lights)");
    }
    uint64_t bytes = 0;
    for (const Light& l : rig.lights) {
        for (const auto& [prop, ks] : l.keys) {
            if (ks.size() > limits.maxKeysPerProperty) {
                return over(l.name + ".keys." + prop + ": " + std::to_string(ks.size()) + " keyframes; the limit is " +
                            std::to_string(limits.maxKeysPerProperty) + " per property (--max-keys)");
            }
        }
        bytes += lightMemoryBytes(l, limits);
    }
    if (bytes > limits.maxLightMemoryBytes) {
        const auto mb = [](uint64_t b) { return std::to_string((b + (1u << 20) - 1) >> 20); };
        return over("the lights' shadow maps and cached images would need " + mb(bytes) + " MB; the limit is " +
                    mb(limits.maxLightMemoryBytes) + " MB per session (--max-light-memory-mb); use smaller shadow maps "
                    "(shadowMapSize), fewer shadowed lights, or disable lights");
    }
    return okStatus();
}

// A command-line value is at most what one WebSocket message may carry.
constexpr size_t MAX_TEXT_MESSAGE_VALUE_BYTES = 1 << 20;

Result<Change> parseAssignment(std::string_view text) {
    const size_t eq = text.find('=');
    if (eq == std::string_view::npos || eq == 0) return invalid("'" + std::string(text) + "': expected PATH=VALUE");
    Change c;
    c.path = std::string(text.substr(0, eq));
    const std::string rhs(text.substr(eq + 1));
    auto v = parseJson(rhs, MAX_TEXT_MESSAGE_VALUE_BYTES, c.path);
    if (v) {
        c.value = std::move(v.value());
        return c;
    }
    if (v.error().code == ErrorCode::LimitExceeded) return v.error();
    if (rhs.find(',') != std::string::npos) {
        json arr = json::array();
        size_t start = 0;
        while (start <= rhs.size()) {
            size_t end = rhs.find(',', start);
            if (end == std::string::npos) end = rhs.size();
            auto n = parseJson(std::string_view(rhs).substr(start, end - start), 64, c.path);
            if (!n || !n->is_number()) {
                return invalid("'" + std::string(text) + "': list items must be numbers");
            }
            arr.push_back(n.value());
            start = end + 1;
        }
        c.value = arr;
        return c;
    }
    c.value = rhs;
    return c;
}

namespace {
void put16(uint8_t* p, uint16_t v) { p[0] = uint8_t(v); p[1] = uint8_t(v >> 8); }
void put32(uint8_t* p, uint32_t v) { for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i)); }
void put64(uint8_t* p, uint64_t v) { for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i)); }
uint16_t get16(const uint8_t* p) { return uint16_t(p[0] | (p[1] << 8)); }
uint32_t get32(const uint8_t* p) { uint32_t v = 0; for (int i = 3; i >= 0; --i) v = (v << 8) | p[i]; return v; }
uint64_t get64(const uint8_t* p) { uint64_t v = 0; for (int i = 7; i >= 0; --i) v = (v << 8) | p[i]; return v; }
constexpr uint16_t FRAME_HEADER_VERSION = 1;
} // namespace

void writeFrameHeader(const FrameHeader& h, uint8_t* out) {
    std::memcpy(out, "DFBF", 4);
    put16(out + 4, FRAME_HEADER_VERSION);
    put16(out + 6, static_cast<uint16_t>(h.encoding));
    put64(out + 8, h.frameNumber);
    put64(out + 16, h.rigVersion);
    put32(out + 24, h.width);
    put32(out + 28, h.height);
}

Result<FrameHeader> readFrameHeader(const uint8_t* data, size_t size) {
    if (size < FRAME_HEADER_BYTES) return makeError(ErrorCode::Protocol, "frame message shorter than its header");
    if (std::memcmp(data, "DFBF", 4) != 0) return makeError(ErrorCode::Protocol, "frame message has a bad magic");
    if (get16(data + 4) != FRAME_HEADER_VERSION) {
        return makeError(ErrorCode::Protocol, "frame header version " + std::to_string(get16(data + 4)) + " is not supported");
    }
    FrameHeader h;
    const uint16_t enc = get16(data + 6);
    if (enc < 1 || enc > 3) return makeError(ErrorCode::Protocol, "frame has unknown encoding " + std::to_string(enc));
    h.encoding = static_cast<Encoding>(enc);
    h.frameNumber = get64(data + 8);
    h.rigVersion = get64(data + 16);
    h.width = get32(data + 24);
    h.height = get32(data + 28);
    return h;
}

} // namespace dfb::protocol
