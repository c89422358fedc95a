#pragma once
// Value checks shared by the schema's setters and the codec (internal to dfb_protocol). Every
// check returns an InvalidValue error naming the path instead of throwing.

#include <dfb/core/Result.h>
#include <dfb/protocol/Json.h>
#include <dfb/protocol/Rig.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

namespace dfb::protocol::detail {

using json = nlohmann::json;

inline Error invalid(const std::string& what) { return makeError(ErrorCode::InvalidValue, what); }

// Largest coordinate accepted: far beyond any scene, small enough that squares stay finite in float.
constexpr double MAX_COORD = 1e7;

inline bool validName(const std::string& n) {
    if (n.empty() || n.size() > 64) return false;
    for (char c : n) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) return false;
    }
    return true;
}

inline Result<float> getNumber(const json& v, const std::string& path, double lo, double hi) {
    if (!v.is_number()) return invalid(path + ": expected a number, got " + std::string(v.type_name()));
    const double d = v.get<double>();
    if (!std::isfinite(d)) return invalid(path + ": not a finite number");
    // Compared as stored (32-bit float): a value at a bound that float cannot hold exactly (1e-4
    // is kept as 9.9999997e-5) must come back in range when the rig is read back and PUT again.
    const float f = float(d);
    if (!(f >= float(lo) && f <= float(hi))) {
        return invalid(path + ": " + excerpt(v) + " is out of range [" + json(lo).dump() + ", " + json(hi).dump() + "]");
    }
    return float(d);
}

inline Result<Vec3> getVec3(const json& v, const std::string& path, double lo, double hi) {
    if (!v.is_array() || v.size() != 3) return invalid(path + ": expected an array of 3 numbers");
    Vec3 out{};
    for (size_t i = 0; i < 3; ++i) {
        auto n = getNumber(v[i], path + "[" + std::to_string(i) + "]", lo, hi);
        if (!n) return n.error();
        out[i] = n.value();
    }
    return out;
}

inline Result<bool> getBool(const json& v, const std::string& path) {
    if (!v.is_boolean()) return invalid(path + ": expected true or false, got " + std::string(v.type_name()));
    return v.get<bool>();
}

/// Sets one light property (a schema row, an indexed element or a keyframe operation) after
/// validating it; the light is unchanged on error. Edits.cpp; the schema's setters call back for
/// keys (a key's value must be acceptable to its property).
Status setLightProperty(Light& l, const std::string& prop, const json& v, const std::string& path);

/// The keyframe operations "keys" (the whole set), "key" (add or replace one) and "unkey"
/// (remove one); Keyframes.cpp.
Status setKeys(Light& l, const std::string& op, const json& v, const std::string& path);

} // namespace dfb::protocol::detail
