// Keyframes (docs/protocol.md "Property paths": keys, key, unkey) and the rig evaluated at its
// session time. The browser's timeline mirrors interpolateKeys; a parity test compares them.

#include "Validate.h"

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Schema.h>

#include <algorithm>
#include <cmath>

namespace dfb::protocol {
namespace detail {
namespace {

// Parses and validates one key of `prop` (its value must be acceptable to the property).
Result<Key> keyFromJson(const Light& l, const std::string& prop, const json& j, const std::string& path) {
    if (!j.is_object() || !j.contains("t") || !j["t"].is_number() || !j.contains("value")) {
        return invalid(path + ": a key is {\"t\": seconds, \"value\": ..., \"interp\": \"linear\"|\"smooth\"}");
    }
    const Property* row = findLightProperty(prop);
    if (row && !row->keyframable) {
        return invalid(path + ": '" + prop + "' cannot be keyed (only the properties the schema marks keyframable)");
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

// Keys stay sorted by time; a key at an existing key's time replaces it.
void insertKey(std::vector<Key>& keys, Key k) {
    auto it = std::find_if(keys.begin(), keys.end(), [&](const Key& e) { return e.time >= k.time; });
    if (it != keys.end() && it->time == k.time) *it = std::move(k);
    else keys.insert(it, std::move(k));
}

} // namespace

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

} // namespace detail

namespace {

using json = nlohmann::json;

// Catmull-Rom on scalars: p1 at s = 0, p2 at s = 1, with the neighbours p0, p3 (non-uniform in
// time: tangents from the neighbours' time spacing).
double catmullRom(double p0, double p1, double p2, double p3, double t0, double t1, double t2, double t3, double s) {
    const double dt = t2 - t1;
    const double m1 = (t2 - t0) > 0 ? (p2 - p0) / (t2 - t0) * dt : 0.0;
    const double m2 = (t3 - t1) > 0 ? (p3 - p1) / (t3 - t1) * dt : 0.0;
    const double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * p1 + (s3 - 2 * s2 + s) * m1 + (-2 * s3 + 3 * s2) * p2 + (s3 - s2) * m2;
}

} // namespace

json interpolateKeys(const std::vector<Key>& ks, double time) {
    if (ks.empty()) return nullptr;
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

Rig evaluateRig(const Rig& rig) {
    Rig out = rig;
    for (Light& l : out.lights) {
        const auto keys = l.keys; // assigning `l` below replaces its key map
        for (const auto& [prop, ks] : keys) {
            if (ks.empty()) continue;
            Light probe = l;
            if (detail::setLightProperty(probe, prop, interpolateKeys(ks, rig.time), l.name + "." + prop).ok()) l = probe;
        }
    }
    return out;
}

} // namespace dfb::protocol
