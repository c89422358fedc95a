// The rig schema's rows (Schema.h): what every property is, how it is validated and stored, and
// what a change of it invalidates. The only list of light properties in the code base.

#include "Validate.h"

#include <dfb/protocol/Schema.h>
#include <dfb/protocol/DragModes.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <type_traits>

namespace dfb::protocol {
namespace {

using namespace detail;

Status ok() { return okStatus(); }

// ---- generic setters, comparisons and getters by field ------------------------------------------

template <auto M> bool sameField(const Light& a, const Light& b) { return a.*M == b.*M; }
template <auto M> json getField(const Light& l) { return json(l.*M); }

template <float Light::*M> Status setNumber(const Property& p, Light& l, const json& v, const std::string& path, int) {
    auto n = getNumber(v, path, p.min, p.max);
    if (!n) return n.error();
    l.*M = n.value();
    return ok();
}

template <int Light::*M> Status setInteger(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_number_integer() || v.get<double>() < p.min || v.get<double>() > p.max) {
        return invalid(path + ": must be an integer in [" + json(p.min).dump() + ", " + json(p.max).dump() + "]" +
                       (*p.unit ? std::string(" (") + p.unit + ")" : std::string()));
    }
    l.*M = int(v.get<int64_t>());
    return ok();
}

template <bool Light::*M> Status setBool(const Property&, Light& l, const json& v, const std::string& path, int) {
    auto b = getBool(v, path);
    if (!b) return b.error();
    l.*M = b.value();
    return ok();
}

template <Vec3 Light::*M> Status setVec3(const Property& p, Light& l, const json& v, const std::string& path, int) {
    auto c = getVec3(v, path, p.min, p.max);
    if (!c) return c.error();
    l.*M = c.value();
    return ok();
}

template <std::vector<uint32_t> Light::*M> Status setIds(const Property&, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_array() || v.size() > 4096) return invalid(path + ": expected an array of object ids (at most 4096)");
    std::vector<uint32_t> ids;
    for (size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_number_unsigned() || v[i].get<uint64_t>() < 1 || v[i].get<uint64_t>() > (1u << 24)) {
            return invalid(path + "[" + std::to_string(i) + "]: object ids are integers from 1");
        }
        ids.push_back(uint32_t(v[i].get<uint64_t>()));
    }
    l.*M = std::move(ids);
    return ok();
}

// ---- the special rows --------------------------------------------------------------------------

Status setName(const Property&, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_string() || !validName(v.get<std::string>())) return invalid(path + ": " + NAME_RULE);
    l.name = v.get<std::string>();
    return ok();
}

Status setType(const Property&, Light& l, const json& v, const std::string& path, int) {
    const auto t = v.is_string() ? lightTypeFromName(v.get<std::string>()) : std::nullopt;
    if (!t) {
        return invalid(path + ": unknown light type " + excerpt(v) +
                       " (\"spot\", \"point\", \"bendy\", \"directional\", \"area\", \"bentArea\" or \"environment\")");
    }
    // A new chain starts straight along the axis, matching the cone: it looks like the spot.
    if (*t == LightType::Bendy && l.controlPoints.empty()) makeStraightChain(l, 4.f);
    // An area light's shadow is a grid of maps (shadowGrid, 4 x 4 by default) of this size each:
    // soft shadows need far fewer texels than one hard map.
    // The grid's average is the softening, so each map needs only one bilinear comparison
    // (shadowFilter 0: 4x4 shadows shade in 98 ms instead of 142 at 960 x 540 on llvmpipe).
    // A bent area light's corners start straight along the normal, matching the cone.
    if (*t == LightType::BentArea && l.cornerPoints.empty()) makeStraightCorners(l, 4.f);
    const auto areaLike = [](LightType x) { return x == LightType::Area || x == LightType::BentArea; };
    if (areaLike(*t) && !areaLike(l.type)) {
        l.shadowMapSize = std::min(l.shadowMapSize, AREA_DEFAULT_MAP_SIZE);
        l.shadowFilter = 0;
    }
    l.type = *t;
    return ok();
}

Status setDirection(const Property& p, Light& l, const json& v, const std::string& path, int) {
    auto d = getVec3(v, path, p.min, p.max);
    if (!d) return d.error();
    const Vec3 a = d.value();
    const float len = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if (!(len > 1e-12f) || !std::isfinite(len)) return invalid(path + ": direction must not be zero");
    // Already-unit directions are kept bit for bit, so a rig survives a JSON round trip.
    l.direction = std::abs(len - 1.f) < 1e-6f ? a : Vec3{a[0] / len, a[1] / len, a[2] / len};
    return ok();
}

Status setCone(const Property& p, Light& l, const json& v, const std::string& path, int) {
    auto n = getNumber(v, path, p.min, p.max);
    if (!n) return n.error();
    l.coneAngleDeg = n.value();
    l.penumbraDeg = std::min(l.penumbraDeg, l.coneAngleDeg); // the penumbra shrinks to fit
    return ok();
}

Status setPenumbra(const Property& p, Light& l, const json& v, const std::string& path, int) {
    auto n = getNumber(v, path, p.min, p.max);
    if (!n) return n.error();
    if (n.value() > l.coneAngleDeg) return invalid(path + ": penumbra must not exceed coneAngle");
    l.penumbraDeg = n.value();
    return ok();
}

Status setMapSize(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_number_integer()) return invalid(path + ": expected an integer");
    const int64_t s = v.get<int64_t>();
    if (s < int64_t(p.min) || s > int64_t(p.max) || (s & (s - 1)) != 0) return invalid(path + ": must be a power of two in [64, 8192]");
    l.shadowMapSize = int(s);
    return ok();
}

// A file name inside the asset folder (a cookie, a pattern): no absolute paths, no way out of it.
Result<std::string> assetFileName(const json& v, const std::string& path, const char* what) {
    if (!v.is_string()) return invalid(path + ": expected a file name (string)");
    const std::string c = v.get<std::string>();
    if (c.size() > 255 || (!c.empty() && (c[0] == '/' || c.find("..") != std::string::npos || c.find('\\') != std::string::npos ||
                                          c.find('\0') != std::string::npos))) {
        return invalid(path + ": a " + what + " is a relative file name inside the asset folder (no '/' at the start, no '..')");
    }
    return c;
}

Status setCookie(const Property&, Light& l, const json& v, const std::string& path, int) {
    auto c = assetFileName(v, path, "cookie");
    if (!c) return c.error();
    l.cookie = c.value();
    return ok();
}

Status setBarnDoors(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_array() || v.size() != size_t(p.size)) return invalid(path + ": expected [left, right, top, bottom] in degrees");
    std::array<float, 4> doors{};
    for (size_t i = 0; i < 4; ++i) {
        auto n = getNumber(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!n) return n.error();
        doors[i] = n.value();
    }
    l.barnDoorsDeg = doors;
    return ok();
}

Status setEnvMap(const Property&, Light& l, const json& v, const std::string& path, int) {
    auto c = assetFileName(v, path, "map");
    if (!c) return c.error();
    l.envMap = c.value();
    return ok();
}

bool isEnvironment(const Light& l) { return l.type == LightType::Environment; }

Status setWarning(const Property&, Light&, const json& v, const std::string& path, int) {
    // Server-computed: accepted in a whole rig (round trips) but not meaningful to set.
    if (!v.is_string()) return invalid(path + ": expected a string");
    return ok();
}

// ---- area lights --------------------------------------------------------------------------------

Status setShape(const Property&, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_string() || (v.get<std::string>() != "rect" && v.get<std::string>() != "disk")) {
        return invalid(path + ": unknown area light shape " + excerpt(v) + " (\"rect\" or \"disk\")");
    }
    l.areaShape = v.get<std::string>() == "disk" ? AreaShape::Disk : AreaShape::Rect;
    return ok();
}
json getShape(const Light& l) { return l.areaShape == AreaShape::Disk ? "disk" : "rect"; }

Status setAreaSize(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_array() || v.size() != 2) return invalid(path + ": expected [width, height] in scene units (a disk: [diameter, any])");
    std::array<float, 2> size{};
    for (size_t i = 0; i < 2; ++i) {
        auto n = getNumber(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!n) return n.error();
        size[i] = n.value();
    }
    l.areaSize = size;
    return ok();
}

Status setShadowGrid(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (!v.is_array() || v.size() != 2) return invalid(path + ": expected [m, n], shadow maps across x across the emitter");
    std::array<int, 2> grid{};
    for (size_t i = 0; i < 2; ++i) {
        if (!v[i].is_number_integer() || v[i].get<int64_t>() < int64_t(p.min) || v[i].get<int64_t>() > int64_t(p.max)) {
            return invalid(path + "[" + std::to_string(i) + "]: must be an integer in [1, " + std::to_string(MAX_AREA_SHADOW_GRID) + "]");
        }
        grid[i] = int(v[i].get<int64_t>());
    }
    l.shadowGrid = grid;
    return ok();
}

Status setPattern(const Property&, Light& l, const json& v, const std::string& path, int) {
    auto c = assetFileName(v, path, "pattern");
    if (!c) return c.error();
    l.pattern = c.value();
    return ok();
}

Status setAreaShading(const Property&, Light& l, const json& v, const std::string& path, int) {
    const std::string name = v.is_string() ? v.get<std::string>() : "";
    if (name == "auto") l.areaShading = AreaShading::Auto;
    else if (name == "oneShot") l.areaShading = AreaShading::OneShot;
    else if (name == "ltc") l.areaShading = AreaShading::Ltc;
    else return invalid(path + ": unknown area light shading " + excerpt(v) + " (\"auto\", \"oneShot\" or \"ltc\")");
    return ok();
}
json getAreaShading(const Light& l) {
    return l.areaShading == AreaShading::OneShot ? "oneShot" : l.areaShading == AreaShading::Ltc ? "ltc" : "auto";
}

Status setAlphaBeta(const Property&, Light&, const json& v, const std::string& path, int) {
    // Server-computed (the fit of the light's shape and pattern): accepted in a whole rig (round
    // trips) but not meaningful to set.
    if (!v.is_array() || v.size() != 2) return invalid(path + ": expected [alpha, beta]");
    return ok();
}

bool isArea(const Light& l) { return l.type == LightType::Area; }
bool isAreaLike(const Light& l) { return l.type == LightType::Area || l.type == LightType::BentArea; }
bool isBentArea(const Light& l) { return l.type == LightType::BentArea; }

// ---- BendyLight chains ---------------------------------------------------------------------------

Status needsChain(const Light& l, const Property& p, const std::string& path) {
    if (l.type != LightType::Bendy) {
        return invalid(path + ": '" + std::string(p.path).substr(0, std::string(p.path).find('[')) +
                       "' applies to BendyLights only (set type to \"bendy\")");
    }
    return ok();
}

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

Status setControlPoints(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (auto s = needsChain(l, p, path); !s) return s;
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
        auto q = getVec3(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!q) return q.error();
        pts.push_back(q.value());
    }
    if (pts.size() != l.controlPoints.size()) {
        l.radii = resample(l.radii, pts.size() + 1);
        l.colors = resample(l.colors, pts.size() + 1);
    }
    l.controlPoints = std::move(pts);
    return ok();
}

Status setRadii(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (auto s = needsChain(l, p, path); !s) return s;
    const size_t n = size_t(2 * l.segments() + 1);
    if (!v.is_array() || v.size() != n) return invalid(path + ": expected " + std::to_string(n) + " radii");
    std::vector<float> radii(n);
    for (size_t i = 0; i < n; ++i) {
        auto r = getNumber(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!r) return r.error();
        radii[i] = r.value();
    }
    l.radii = std::move(radii);
    return ok();
}

Status setColors(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (auto s = needsChain(l, p, path); !s) return s;
    const size_t n = size_t(2 * l.segments() + 1);
    if (!v.is_array() || v.size() != n) return invalid(path + ": expected " + std::to_string(n) + " colors");
    std::vector<Vec3> colors(n);
    for (size_t i = 0; i < n; ++i) {
        auto c = getVec3(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!c) return c.error();
        colors[i] = c.value();
    }
    l.colors = std::move(colors);
    return ok();
}

Status setCp(const Property& p, Light& l, const json& v, const std::string& path, int index) {
    if (auto s = needsChain(l, p, path); !s) return s;
    const int K = l.segments();
    if (index == 0) return invalid(path + ": cp[0] is the light's source; move the light instead");
    if (index < 1 || index > 2 * K) return invalid(path + ": index out of range 1.." + std::to_string(2 * K));
    auto q = getVec3(v, path, p.min, p.max);
    if (!q) return q.error();
    l.controlPoints[size_t(index - p.indexBase)] = q.value();
    return ok();
}

Status setR(const Property& p, Light& l, const json& v, const std::string& path, int index) {
    if (auto s = needsChain(l, p, path); !s) return s;
    const int K = l.segments();
    if (index < 0 || index > 2 * K) return invalid(path + ": index out of range 0.." + std::to_string(2 * K));
    auto r = getNumber(v, path, p.min, p.max);
    if (!r) return r.error();
    l.radii[size_t(index)] = r.value();
    return ok();
}

Status setCpColor(const Property& p, Light& l, const json& v, const std::string& path, int index) {
    if (auto s = needsChain(l, p, path); !s) return s;
    const int K = l.segments();
    if (index < 0 || index > 2 * K) return invalid(path + ": index out of range 0.." + std::to_string(2 * K));
    auto c = getVec3(v, path, p.min, p.max);
    if (!c) return c.error();
    l.colors[size_t(index)] = c.value();
    return ok();
}

// ---- bent area lights' corner chains (paper 003 section 4.1) ------------------------------------

Status needsCorners(const Light& l, const Property& p, const std::string& path) {
    if (l.type != LightType::BentArea) {
        return invalid(path + ": '" + std::string(p.path).substr(0, std::string(p.path).find('[')) +
                       "' applies to bent area lights only (set type to \"bentArea\")");
    }
    return ok();
}

// A corner chain whose segment has no length has no direction to carry light along: refused (the
// interior chains blended from it would be degenerate too).
Status checkCornerSegments(const std::vector<Vec3>& pts, const std::string& path) {
    const int K = int(pts.size() / (2 * BENT_AREA_CORNERS));
    auto at = [&](int c, int i) { return i == 0 ? Vec3{0.f, 0.f, 0.f} : pts[size_t(c * 2 * K + i - 1)]; };
    auto far = [](const Vec3& a, const Vec3& b) {
        return std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]) > 1e-6f;
    };
    for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
        for (int k = 0; k < K; ++k) {
            if (!far(at(c, 2 * k), at(c, 2 * k + 2)) && !far(at(c, 2 * k), at(c, 2 * k + 1))) {
                return invalid(path + ": corner " + std::to_string(c) + "'s segment " + std::to_string(k) +
                               " has zero length (its control points " + std::to_string(2 * k) + ".." +
                               std::to_string(2 * k + 2) + " coincide): a degenerate corner chain");
            }
        }
    }
    return ok();
}

Status setCornerPoints(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (auto s = needsCorners(l, p, path); !s) return s;
    constexpr size_t MAX_POINTS = size_t(2 * MAX_BENDY_SEGMENTS * BENT_AREA_CORNERS);
    if (v.is_array() && v.size() > MAX_POINTS) {
        return makeError(ErrorCode::LimitExceeded, path + ": " + std::to_string(v.size()) + " corner points; the limit is " +
                                                       std::to_string(MAX_POINTS) + " (4 chains of " +
                                                       std::to_string(MAX_BENDY_SEGMENTS) + " segments)");
    }
    if (!v.is_array() || v.empty() || v.size() % size_t(2 * BENT_AREA_CORNERS) != 0) {
        return invalid(path + ": expected 4 chains of 2K [a, b, c] points (K = 1.." + std::to_string(MAX_BENDY_SEGMENTS) +
                       "), corner-major, in the emitter's frame");
    }
    std::vector<Vec3> pts;
    for (size_t i = 0; i < v.size(); ++i) {
        auto q = getVec3(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!q) return q.error();
        pts.push_back(q.value());
    }
    if (auto s = checkCornerSegments(pts, path); !s) return s;
    if (pts.size() != l.cornerPoints.size()) {
        // Each corner's radii resampled to the new segment count.
        const size_t oldN = l.cornerRadii.size() / BENT_AREA_CORNERS, newN = pts.size() / BENT_AREA_CORNERS + 1;
        std::vector<float> radii;
        for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
            const std::vector<float> one(l.cornerRadii.begin() + std::ptrdiff_t(size_t(c) * oldN),
                                         l.cornerRadii.begin() + std::ptrdiff_t(size_t(c + 1) * oldN));
            const std::vector<float> r = oldN ? resample(one, newN) : std::vector<float>(newN, 0.f);
            radii.insert(radii.end(), r.begin(), r.end());
        }
        l.cornerRadii = std::move(radii);
    }
    l.cornerPoints = std::move(pts);
    return ok();
}

Status setCornerRadii(const Property& p, Light& l, const json& v, const std::string& path, int) {
    if (auto s = needsCorners(l, p, path); !s) return s;
    const size_t n = size_t(BENT_AREA_CORNERS * (2 * l.cornerSegments() + 1));
    if (!v.is_array() || v.size() != n) return invalid(path + ": expected " + std::to_string(n) + " radii (4 x (2K + 1))");
    std::vector<float> radii(n);
    for (size_t i = 0; i < n; ++i) {
        auto r = getNumber(v[i], path + "[" + std::to_string(i) + "]", p.min, p.max);
        if (!r) return r.error();
        radii[i] = r.value();
    }
    l.cornerRadii = std::move(radii);
    return ok();
}

Status setCornerCp(const Property& p, Light& l, const json& v, const std::string& path, int index) {
    if (auto s = needsCorners(l, p, path); !s) return s;
    const int n = int(l.cornerPoints.size());
    if (index < 0 || index >= n) return invalid(path + ": index out of range 0.." + std::to_string(n - 1));
    auto q = getVec3(v, path, p.min, p.max);
    if (!q) return q.error();
    std::vector<Vec3> pts = l.cornerPoints;
    pts[size_t(index)] = q.value();
    if (auto s = checkCornerSegments(pts, path); !s) return s;
    l.cornerPoints = std::move(pts);
    return ok();
}

Status setCornerR(const Property& p, Light& l, const json& v, const std::string& path, int index) {
    if (auto s = needsCorners(l, p, path); !s) return s;
    const int n = int(l.cornerRadii.size());
    if (index < 0 || index >= n) return invalid(path + ": index out of range 0.." + std::to_string(n - 1));
    auto r = getNumber(v, path, p.min, p.max);
    if (!r) return r.error();
    l.cornerRadii[size_t(index)] = r.value();
    return ok();
}

Status setKeysRow(const Property& p, Light& l, const json& v, const std::string& path, int) {
    return setKeys(l, p.path, v, path);
}

bool hasChain(const Light& l) { return l.type == LightType::Bendy || !l.controlPoints.empty(); }

json getType(const Light& l) { return lightTypeName(l.type); }
json getKeys(const Light& l) {
    json keys = json::object();
    for (const auto& [prop, ks] : l.keys) {
        json arr = json::array();
        for (const Key& k : ks) {
            arr.push_back(json{{"t", k.time}, {"value", k.value}, {"interp", k.interp == Interp::Smooth ? "smooth" : "linear"}});
        }
        keys[prop] = arr;
    }
    return keys;
}

bool sameConeForShadow(const Light& a, const Light& b) {
    // A BendyLight's deformed geometry depends on the exact cone (its tube radii follow it).
    if (a.type == LightType::Bendy || a.type == LightType::BentArea) return a.coneAngleDeg == b.coneAngleDeg;
    return shadowHalfAngleDeg(a) == shadowHalfAngleDeg(b);
}

constexpr unsigned LOCATED = APPLIES_SPOT | APPLIES_POINT | APPLIES_BENDY | APPLIES_AREA | APPLIES_BENT_AREA; // has a position
constexpr unsigned AIMED = APPLIES_SPOT | APPLIES_BENDY | APPLIES_DIRECTIONAL | APPLIES_AREA | APPLIES_BENT_AREA; // has a direction
constexpr unsigned CONED = APPLIES_SPOT | APPLIES_BENDY | APPLIES_BENT_AREA;  // has a cone
constexpr unsigned AREA_LIKE = APPLIES_AREA | APPLIES_BENT_AREA;             // has an emitter rectangle

using enum PropType;
using enum Invalidates;

const std::vector<Property> LIGHT_PROPERTIES = {
    {.path = "name", .label = "Name", .type = String, .unit = "", .invalidates = Shadow, .valueDoc = "string",
     .doc = "1-64 of `[A-Za-z0-9_-]`, unique in the rig", .set = setName, .same = sameField<&Light::name>,
     .get = getField<&Light::name>},
    {.path = "type", .label = "Type", .type = Enum, .unit = "", .invalidates = Shadow, .values = "spot,point,directional,bendy,area,bentArea,environment",
     .valueDoc = "string",
     .doc = "`\"spot\"`, `\"point\"` (every direction from `position`, candela, cube-map shadows; `direction` and the cone "
            "unused), `\"directional\"` (parallel light along `direction`, `intensity` in lux, no cone; `position` unused) or "
            "`\"bendy\"`; switching a light without a chain to `bendy` gives it a straight 4-unit chain matching its cone (it "
            "looks unchanged), or `\"area\"` (a one-sided rectangle or disk at `position` emitting towards `direction`, "
            "`intensity` its radiance in cd/m²; switching to `area` caps `shadowMapSize` at 512, the size of each map of its "
            "`shadowGrid`, and sets `shadowFilter` to 0: the grid's average softens), or `\"bentArea\"` (an area light's "
            "rectangle whose light travels along four corner BendyLight chains, `cornerPoints`; each of its `shadowGrid` "
            "interior BendyLights has the cone `coneAngle`; switching gives it straight 4-unit corner chains, and caps the map "
            "size and sets the filter as for `area`), or `\"environment\"` (radiance from every direction: the HDR image "
            "`map` turned by `rotation`, or the constant `color`; `intensity` a unitless multiplier; `shadow`: the shot's "
            "baked visibility; no position or direction)",
     .set = setType, .same = sameField<&Light::type>, .get = getType},
    {.path = "enabled", .label = "Enabled", .type = Boolean, .unit = "", .invalidates = Composite, .valueDoc = "bool",
     .doc = "", .set = setBool<&Light::enabled>, .same = sameField<&Light::enabled>, .get = getField<&Light::enabled>},
    {.path = "position", .label = "Position", .type = Vec3, .unit = "scene units", .min = -MAX_COORD, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = LOCATED, .valueDoc = "[x, y, z]",
     .doc = "world space, scene units, each within ±1e7", .set = setVec3<&Light::position>,
     .same = sameField<&Light::position>, .get = getField<&Light::position>},
    {.path = "direction", .label = "Direction", .type = Direction, .unit = "", .min = -MAX_COORD, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = AIMED, .valueDoc = "[x, y, z]",
     .doc = "where the light points, world space; normalised by the server; not zero", .set = setDirection,
     .same = sameField<&Light::direction>, .get = getField<&Light::direction>},
    {.path = "color", .label = "Color", .type = Color, .unit = "linear RGB", .min = 0, .max = 1e6, .uiMin = 0, .uiMax = 1,
     .step = 0.01, .keyframable = true, .invalidates = Scale, .valueDoc = "[r, g, b]", .doc = "linear RGB, each in [0, 1e6]",
     .set = setVec3<&Light::color>, .same = sameField<&Light::color>, .get = getField<&Light::color>},
    {.path = "intensity", .label = "Intensity", .type = Number, .unit = "cd (lux for directional, cd/m² for area)", .min = 0, .max = 1e12,
     .uiMin = 0, .uiMax = 1000, .step = 0.1, .keyframable = true, .invalidates = Scale, .valueDoc = "number",
     .doc = "candela for spot, point and BendyLights, lux for directional lights (glTF `KHR_lights_punctual`), the emitter's "
            "radiance in cd/m² (nits) for area lights, [0, 1e12]",
     .set = setNumber<&Light::intensityCd>, .same = sameField<&Light::intensityCd>, .get = getField<&Light::intensityCd>},
    {.path = "coneAngle", .label = "Cone angle", .type = Number, .unit = "degrees", .min = 0.1, .max = 85, .uiMin = 1,
     .uiMax = 85, .step = 0.5, .keyframable = true, .invalidates = Shadow, .appliesTo = CONED, .valueDoc = "number",
     .doc = "outer half-angle, degrees, [0.1, 85]; the penumbra shrinks to fit", .set = setCone,
     .same = sameField<&Light::coneAngleDeg>, .sameShadow = sameConeForShadow, .get = getField<&Light::coneAngleDeg>},
    {.path = "penumbra", .label = "Penumbra", .type = Number, .unit = "degrees", .min = 0, .max = 85, .uiMin = 0, .uiMax = 30,
     .step = 0.5, .keyframable = true, .invalidates = Shade, .appliesTo = CONED, .valueDoc = "number",
     .doc = "degrees of soft edge inside the cone, [0, coneAngle]", .set = setPenumbra,
     .same = sameField<&Light::penumbraDeg>, .get = getField<&Light::penumbraDeg>},
    {.path = "shadow", .label = "Shadow", .type = Boolean, .unit = "", .invalidates = Shadow, .valueDoc = "bool",
     .doc = "casts shadows", .set = setBool<&Light::shadow>, .same = sameField<&Light::shadow>, .get = getField<&Light::shadow>},
    {.path = "shadowMapSize", .label = "Shadow map", .type = Integer, .unit = "texels", .min = 64, .max = 8192,
     .invalidates = Shadow, .values = "64,128,256,512,1024,2048,4096,8192", .valueDoc = "integer",
     .doc = "power of two in [64, 8192]", .set = setMapSize, .same = sameField<&Light::shadowMapSize>,
     .get = getField<&Light::shadowMapSize>},
    {.path = "shadowBias", .label = "Shadow bias", .type = Number, .unit = "shadow-map texels", .min = 0, .max = 16,
     .uiMin = 0, .uiMax = 4, .step = 0.05, .keyframable = true, .invalidates = Shade, .valueDoc = "number",
     .doc = "receiver offset along the geometric normal, in shadow-map texels, [0, 16]", .set = setNumber<&Light::shadowBias>,
     .same = sameField<&Light::shadowBias>, .get = getField<&Light::shadowBias>},
    {.path = "shadowFilter", .label = "Shadow softness", .type = Integer, .unit = "shadow-map texels", .min = 0, .max = 4,
     .uiMin = 0, .uiMax = 4, .step = 1, .invalidates = Shade, .valueDoc = "integer",
     .doc = "soft-shadow filter radius in shadow-map texels, [0, 4] ((2r+1)² percentage-closer taps; default 1)",
     .set = setInteger<&Light::shadowFilter>, .same = sameField<&Light::shadowFilter>, .get = getField<&Light::shadowFilter>},
    {.path = "barnDoors", .label = "Barn doors", .type = Numbers, .unit = "degrees", .min = 0, .max = 90, .uiMin = 0,
     .uiMax = 90, .step = 1, .keyframable = true, .invalidates = Shade, .appliesTo = APPLIES_SPOT, .size = 4,
     .valueDoc = "[left, right, top, bottom]",
     .doc = "spot lights: the four flaps' angles from the axis, degrees, each in [0, 90] (90 = open; default all open); in the "
            "light's frame (docs/lighting.md)",
     .set = setBarnDoors, .same = sameField<&Light::barnDoorsDeg>, .get = getField<&Light::barnDoorsDeg>},
    {.path = "cookie", .label = "Cookie", .type = String, .unit = "", .invalidates = Shade, .appliesTo = APPLIES_SPOT,
     .valueDoc = "string",
     .doc = "spot lights: an image file in the server's asset folder (`--assets`, default the shot's folder) projected across "
            "the cone, multiplying the color; `\"\"` = none. Relative, no `..`, at most 255 characters; an edit naming a file "
            "that is not a readable image is refused (`invalid_value`)",
     .set = setCookie, .same = sameField<&Light::cookie>, .present = [](const Light& l) { return !l.cookie.empty(); },
     .get = getField<&Light::cookie>},
    {.path = "shape", .label = "Shape", .type = Enum, .unit = "", .invalidates = Shadow, .appliesTo = APPLIES_AREA,
     .values = "rect,disk", .valueDoc = "string",
     .doc = "area lights: `\"rect\"` (`size` = [width, height]) or `\"disk\"` (`size[0]` = diameter)", .set = setShape,
     .same = sameField<&Light::areaShape>, .present = isArea, .get = getShape},
    {.path = "size", .label = "Size", .type = Numbers, .unit = "scene units", .min = 1e-4, .max = MAX_COORD, .uiMin = 0.05,
     .uiMax = 10, .step = 0.05, .keyframable = true, .invalidates = Shadow, .appliesTo = AREA_LIKE, .size = 2,
     .valueDoc = "[width, height]",
     .doc = "area lights: the emitter's width (along its right) and height (along its up), scene units, each in [1e-4, 1e7]; "
            "a disk's diameter is `size[0]`",
     .set = setAreaSize, .same = sameField<&Light::areaSize>, .present = isAreaLike, .get = getField<&Light::areaSize>},
    {.path = "roll", .label = "Roll", .type = Number, .unit = "degrees", .min = -360, .max = 360, .uiMin = -180, .uiMax = 180,
     .step = 1, .keyframable = true, .invalidates = Shadow, .appliesTo = AREA_LIKE, .valueDoc = "number",
     .doc = "area lights: the emitter's turn about its normal, degrees, [-360, 360] (docs/lighting.md, \"Area lights\")",
     .set = setNumber<&Light::rollDeg>, .same = sameField<&Light::rollDeg>, .present = isAreaLike, .get = getField<&Light::rollDeg>},
    {.path = "pattern", .label = "Pattern", .type = String, .unit = "", .invalidates = Shade, .appliesTo = APPLIES_AREA,
     .valueDoc = "string",
     .doc = "area lights: an RGB image in the asset folder across the emitter (its top row at the emitter's up edge), "
            "multiplying the color (linear for float files, sRGB decoded otherwise); `\"\"` = uniform. Relative, no `..`, "
            "at most 255 characters; an edit naming a file that is not a readable image is refused (`invalid_value`)",
     .set = setPattern, .same = sameField<&Light::pattern>, .present = [](const Light& l) { return !l.pattern.empty(); },
     .get = getField<&Light::pattern>},
    {.path = "shading", .label = "Shading", .type = Enum, .unit = "", .invalidates = Shade, .appliesTo = APPLIES_AREA,
     .values = "auto,oneShot,ltc", .valueDoc = "string",
     .doc = "area lights: `\"oneShot\"` (one-shot approximate local shading, Wang et al. 2008: any pattern at the cost of two "
            "point lights), `\"ltc\"` (linearly transformed cosines, Heitz et al. 2016 and 2017: the uniform emitter integrated "
            "under the fitted GGX lobe, accurate; with a pattern it uses the pattern's mean color) or `\"auto\"` (the default: "
            "`oneShot` when the light has a `pattern`, `ltc` otherwise); docs/lighting.md",
     .set = setAreaShading, .same = sameField<&Light::areaShading>, .present = isArea, .get = getAreaShading},
    {.path = "shadowGrid", .label = "Shadow grid", .type = Numbers, .unit = "shadow maps", .min = 1,
     .max = MAX_AREA_SHADOW_GRID, .uiMin = 1, .uiMax = 8, .step = 1, .invalidates = Shadow, .appliesTo = AREA_LIKE,
     .size = 2, .valueDoc = "[m, n]",
     .doc = "area lights: m x n shadow maps (each `shadowMapSize` square) from points spread over the emitter, their "
            "visibilities averaged: soft shadows; each an integer in [1, 16], default [4, 4]; previews during drags use 2 x 2. "
            "Bent area lights: the m x n interior BendyLights, each with its deformed shadow map",
     .set = setShadowGrid, .same = sameField<&Light::shadowGrid>, .present = isAreaLike, .get = getField<&Light::shadowGrid>},
    {.path = "alphaBeta", .label = "One-shot fit", .type = Numbers, .unit = "", .appliesTo = APPLIES_AREA, .size = 2,
     .readOnly = true, .valueDoc = "[alpha, beta]",
     .doc = "written by the server: the one-shot radius factors fitted for the area light's shape and pattern (Wang et al. "
            "2008, section 3; docs/lighting.md), fitted while the light shades one-shot (a light shading with LTC costs no "
            "fit); [0.30, 0.57] before a fit; clients cannot set it",
     .set = setAlphaBeta, .present = isArea, .get = getField<&Light::alphaBeta>},
    {.path = "map", .label = "Map", .type = String, .unit = "", .invalidates = Shade, .appliesTo = APPLIES_ENVIRONMENT,
     .valueDoc = "string",
     .doc = "environment lights: an HDR latitude-longitude image in the asset folder (OpenEXR or Radiance HDR: float data; "
            "8- and 16-bit integer images such as PNG are refused), its values radiance in cd/m² before `intensity` and "
            "`color`; at most 8192 x 4096 texels; `\"\"` = the constant `color`. Relative, no `..`, at most 255 characters",
     .set = setEnvMap, .same = sameField<&Light::envMap>, .present = [](const Light& l) { return !l.envMap.empty(); },
     .get = getField<&Light::envMap>},
    {.path = "rotation", .label = "Rotation", .type = Numbers, .unit = "degrees", .min = -360, .max = 360, .uiMin = -180,
     .uiMax = 180, .step = 1, .keyframable = true, .invalidates = Shade, .appliesTo = APPLIES_ENVIRONMENT, .size = 3,
     .valueDoc = "[yaw, pitch, roll]",
     .doc = "environment lights: the map's turn, degrees, each in [-360, 360]: yaw about +Y, then pitch about +X, then roll "
            "about +Z (docs/lighting.md, \"Environment light\")",
     .set = setVec3<&Light::envRotationDeg>, .same = sameField<&Light::envRotationDeg>, .present = isEnvironment,
     .get = getField<&Light::envRotationDeg>},
    {.path = "include", .label = "Lights only", .type = IdList, .unit = "object ids", .invalidates = Shade, .valueDoc = "[ids]",
     .doc = "light linking: when not empty, the light lights only these objects (1-based ids of the shot's manifest, "
            "`welcome.session.objects[id-1]`)",
     .set = setIds<&Light::include>, .same = sameField<&Light::include>,
     .present = [](const Light& l) { return !l.include.empty(); }, .get = getField<&Light::include>},
    {.path = "exclude", .label = "Never lights", .type = IdList, .unit = "object ids", .invalidates = Shade, .valueDoc = "[ids]",
     .doc = "light linking: objects the light never lights (shading only: they still cast shadows)",
     .set = setIds<&Light::exclude>, .same = sameField<&Light::exclude>,
     .present = [](const Light& l) { return !l.exclude.empty(); }, .get = getField<&Light::exclude>},
    {.path = "controlPoints", .label = "Control points", .type = Points, .unit = "scene units", .min = -MAX_COORD,
     .max = MAX_COORD, .invalidates = Shadow, .appliesTo = APPLIES_BENDY, .valueDoc = "[[a, b, c], ...]",
     .doc = "BendyLight: the 2K control points p1..p2K (K = 1..8) in the light's frame: position + a uL + b vL + c wL "
            "(docs/lighting.md); changing K resamples `radii` and `colors`",
     .set = setControlPoints, .same = sameField<&Light::controlPoints>, .present = hasChain,
     .get = getField<&Light::controlPoints>},
    {.path = "cp[]", .label = "Control point", .type = Vec3, .unit = "scene units", .min = -MAX_COORD, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = APPLIES_BENDY, .indexOf = "controlPoints", .indexBase = 1, .valueDoc = "[a, b, c]",
     .doc = "BendyLight: one control point, i = 1..2K (cp[0] is the light's position)", .set = setCp},
    {.path = "radii", .label = "Radii", .type = Numbers, .unit = "scene units", .min = 0, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = APPLIES_BENDY, .valueDoc = "[r0, ..., r2K]",
     .doc = "BendyLight: tube radii, scene units, >= 0", .set = setRadii, .same = sameField<&Light::radii>,
     .present = hasChain, .get = getField<&Light::radii>},
    {.path = "r[]", .label = "Radius", .type = Number, .unit = "scene units", .min = 0, .max = MAX_COORD, .keyframable = true,
     .invalidates = Shadow, .appliesTo = APPLIES_BENDY, .indexOf = "radii", .valueDoc = "number",
     .doc = "BendyLight: one radius, i = 0..2K", .set = setR},
    {.path = "colors", .label = "Chain colors", .type = Colors, .unit = "linear RGB", .min = 0, .max = 1e6,
     .invalidates = Shade, .appliesTo = APPLIES_BENDY, .valueDoc = "[[r, g, b], ...]",
     .doc = "BendyLight: 2K+1 linear color multipliers along the chain", .set = setColors, .same = sameField<&Light::colors>,
     .present = hasChain, .get = getField<&Light::colors>},
    {.path = "cpColor[]", .label = "Chain color", .type = Color, .unit = "linear RGB", .min = 0, .max = 1e6,
     .keyframable = true, .invalidates = Shade, .appliesTo = APPLIES_BENDY, .indexOf = "colors", .valueDoc = "[r, g, b]",
     .doc = "BendyLight: one of them", .set = setCpColor},
    {.path = "exactDirection", .label = "Exact direction", .type = Boolean, .unit = "", .invalidates = Shade,
     .appliesTo = APPLIES_BENDY, .valueDoc = "bool", .doc = "BendyLight: the exact flow-line tangent instead of paper eq. 9",
     .set = setBool<&Light::exactDirection>, .same = sameField<&Light::exactDirection>, .present = hasChain,
     .get = getField<&Light::exactDirection>},
    {.path = "cornerPoints", .label = "Corner chains", .type = Points, .unit = "scene units", .min = -MAX_COORD,
     .max = MAX_COORD, .invalidates = Shadow, .appliesTo = APPLIES_BENT_AREA, .valueDoc = "[[a, b, c], ...]",
     .doc = "bent area lights: the four corner chains' control points p1..p2K (K = 1..8, the same for all four), corner-major "
            "(corner c's p[i] at index c·2K + i − 1; corners 0..3 at (−w/2, −h/2), (+w/2, −h/2), (−w/2, +h/2), (+w/2, +h/2)), "
            "each relative to its corner in the emitter's frame: corner + a·normal + b·up + c·right (docs/lighting.md); a "
            "segment of zero length is refused; changing K resamples `cornerRadii`",
     .set = setCornerPoints, .same = sameField<&Light::cornerPoints>, .present = isBentArea,
     .get = getField<&Light::cornerPoints>},
    {.path = "ccp[]", .label = "Corner point", .type = Vec3, .unit = "scene units", .min = -MAX_COORD, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = APPLIES_BENT_AREA, .indexOf = "cornerPoints",
     .valueDoc = "[a, b, c]", .doc = "bent area lights: one corner point, i = c·2K + j − 1 for corner c's p[j]", .set = setCornerCp},
    {.path = "cornerRadii", .label = "Corner radii", .type = Numbers, .unit = "scene units", .min = 0, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = APPLIES_BENT_AREA, .valueDoc = "[r, ...]",
     .doc = "bent area lights: the four corner chains' tube radii r0..r2K, corner-major (corner c's r[j] at c·(2K + 1) + j), "
            "scene units, >= 0; the interior chains' radii are their bilinear blend (paper 003 eq. 9)",
     .set = setCornerRadii, .same = sameField<&Light::cornerRadii>, .present = isBentArea,
     .get = getField<&Light::cornerRadii>},
    {.path = "cr[]", .label = "Corner radius", .type = Number, .unit = "scene units", .min = 0, .max = MAX_COORD,
     .keyframable = true, .invalidates = Shadow, .appliesTo = APPLIES_BENT_AREA, .indexOf = "cornerRadii",
     .valueDoc = "number", .doc = "bent area lights: one corner radius, i = c·(2K + 1) + j", .set = setCornerR},
    {.path = "keys", .label = "Keys", .type = Keys, .unit = "", .valueDoc = "object",
     .doc = "all keyframes: `{\"PROPERTY\": [{\"t\": s, \"value\": v, \"interp\": \"linear\"|\"smooth\"}, ...]}`; PROPERTY is "
            "any keyframable property path of the light (`intensity`, `position`, `cp[2]`, ...: `keyframable` in the schema)",
     .set = setKeysRow, .present = [](const Light& l) { return !l.keys.empty(); }, .get = getKeys},
    {.path = "key", .label = "Key", .type = Keys, .unit = "", .valueDoc = "object",
     .doc = "add or replace one key: `{\"path\": \"cp[2]\", \"t\": 1.5, \"value\": [3, 0, 1], \"interp\": \"smooth\"}`",
     .set = setKeysRow},
    {.path = "unkey", .label = "Unkey", .type = Keys, .unit = "", .valueDoc = "object",
     .doc = "remove one: `{\"path\": \"cp[2]\", \"t\": 1.5}`", .set = setKeysRow},
    {.path = "warning", .label = "Warning", .type = String, .unit = "", .readOnly = true, .valueDoc = "string",
     .doc = "written by the server: why a BendyLight's chain is doubtful (a cusp, a fold inside a bend, a self-intersecting "
            "tube); absent when fine; clients cannot set it",
     .set = setWarning, .present = [](const Light& l) { return !l.warning.empty(); }, .get = getField<&Light::warning>},
};

const std::vector<Property> RIG_PROPERTIES = {
    {.path = "exposure", .label = "Exposure", .type = Number, .unit = "stops", .min = -20, .max = 20, .uiMin = -10,
     .uiMax = 10, .step = 0.1, .invalidates = Composite, .valueDoc = "number",
     .doc = "stops, [-20, 20]; the image is multiplied by 2^exposure"},
    {.path = "time", .label = "Time", .type = Number, .unit = "seconds", .step = 0.04,
     .invalidates = None, .valueDoc = "number",
     .doc = "the session clock, seconds: where keyframes are evaluated (a keyed property's change invalidates what its row says)"},
    {.path = "groups", .label = "Light groups", .type = Groups, .unit = "", .invalidates = None,
     .valueDoc = "[{\"name\", \"lights\": [names]}]",
     .doc = "named sets of lights (the page mutes, solos and scales a group in one edit): at most 64, names by the lights' "
            "rule, unique, each light of the rig at most once per group; renaming a light renames it in its groups, "
            "replacing the rig drops the members it no longer has"},
    {.path = "viewTransform", .label = "View", .type = Enum, .unit = "", .invalidates = Composite, .values = "srgb,filmic",
     .valueDoc = "string",
     .doc = "`\"srgb\"` (default: the sRGB transfer function alone) or `\"filmic\"` (the ACES fitted curve, then sRGB: "
            "highlights roll off instead of clipping)"},
};

json rigDefault(const Property& p) {
    const Rig r;
    const std::string path = p.path;
    if (path == "exposure") return r.exposureStops;
    if (path == "time") return r.time;
    if (path == "viewTransform") return r.viewTransform == ViewTransform::Filmic ? "filmic" : "srgb";
    if (path == "groups") return json::array();
    return nullptr;
}

json rowJson(const Property& p, bool rigLevel) {
    json j{{"path", p.path}, {"label", p.label}, {"type", toString(p.type)}, {"keyframable", p.keyframable},
           {"invalidates", toString(p.invalidates)}};
    if (*p.unit) j["unit"] = p.unit;
    if (p.min != 0 || p.max != 0) j["min"] = p.min, j["max"] = p.max;
    if (p.uiMin != 0 || p.uiMax != 0) j["uiMin"] = p.uiMin, j["uiMax"] = p.uiMax;
    if (p.step != 0) j["step"] = p.step;
    if (p.size) j["size"] = p.size;
    if (*p.indexOf) j["indexOf"] = p.indexOf;
    if (p.readOnly) j["readOnly"] = true;
    if (*p.values) {
        json values = json::array();
        std::stringstream ss(p.values);
        for (std::string v; std::getline(ss, v, ',');) {
            if (p.type == PropType::Integer) values.push_back(std::stoi(v));
            else values.push_back(v);
        }
        j["values"] = values;
    }
    if (!rigLevel) {
        json types = json::array();
        for (LightType t : {LightType::Spot, LightType::Point, LightType::Bendy, LightType::Directional, LightType::Area,
                            LightType::BentArea, LightType::Environment}) {
            if (p.appliesTo & (1u << unsigned(t))) types.push_back(lightTypeName(t));
        }
        j["appliesTo"] = types;
        if (p.get && p.type != PropType::Keys && !p.readOnly) j["default"] = p.get(Light{});
    } else {
        j["default"] = rigDefault(p);
    }
    std::string doc = p.doc;
    j["doc"] = doc;
    return j;
}

} // namespace

const std::vector<Property>& lightProperties() { return LIGHT_PROPERTIES; }
const std::vector<Property>& rigProperties() { return RIG_PROPERTIES; }

const Property* findLightProperty(std::string_view prop, int* index) {
    if (index) *index = -1;
    const size_t open = prop.find('[');
    if (open != std::string_view::npos) {
        const std::string_view digits = prop.substr(open + 1, prop.size() >= open + 2 ? prop.size() - open - 2 : 0);
        if (prop.back() != ']' || digits.empty() || digits.size() > 3 || digits.find_first_not_of("0123456789") != std::string_view::npos) {
            if (index) *index = -2;
            return nullptr;
        }
        if (index) *index = std::stoi(std::string(digits));
        const std::string row = std::string(prop.substr(0, open)) + "[]";
        for (const Property& p : LIGHT_PROPERTIES) {
            if (*p.indexOf && row == p.path) return &p;
        }
        return nullptr;
    }
    for (const Property& p : LIGHT_PROPERTIES) {
        if (!*p.indexOf && prop == p.path) return &p;
    }
    return nullptr;
}

const Property* findRigProperty(std::string_view path) {
    for (const Property& p : RIG_PROPERTIES) {
        if (path == p.path) return &p;
    }
    return nullptr;
}

float shadowHalfAngleDeg(const Light& l) { return std::min(5.f * std::ceil((l.coneAngleDeg + 1.f) / 5.f), 86.f); }

bool sameInputs(const Light& a, const Light& b, Invalidates level) {
    if (a.type != b.type) return false;
    const unsigned type = 1u << unsigned(a.type);
    for (const Property& p : LIGHT_PROPERTIES) {
        if (!p.same || p.invalidates < level || !(p.appliesTo & type)) continue;
        const bool same = level == Invalidates::Shadow && p.sameShadow ? p.sameShadow(a, b) : p.same(a, b);
        if (!same) return false;
    }
    return true;
}

std::string_view toString(PropType t) {
    switch (t) {
    case Number: return "number";
    case Integer: return "integer";
    case Boolean: return "boolean";
    case String: return "string";
    case Enum: return "enum";
    case PropType::Vec3: return "vec3";
    case Color: return "color";
    case Direction: return "direction";
    case Numbers: return "numbers";
    case IdList: return "idList";
    case Points: return "points";
    case Colors: return "colors";
    case Keys: return "keys";
    case Groups: return "groups";
    }
    return "?";
}

std::string_view toString(Invalidates i) {
    switch (i) {
    case None: return "none";
    case Composite: return "composite";
    case Scale: return "scale";
    case Shade: return "shade";
    case Shadow: return "shadow";
    }
    return "?";
}

std::string lightTypeName(LightType t) {
    switch (t) {
    case LightType::Bendy: return "bendy";
    case LightType::Directional: return "directional";
    case LightType::Point: return "point";
    case LightType::Area: return "area";
    case LightType::BentArea: return "bentArea";
    case LightType::Environment: return "environment";
    case LightType::Spot: break;
    }
    return "spot";
}

bool isValidName(const std::string& name) { return validName(name); }

std::optional<LightType> lightTypeFromName(std::string_view n) {
    if (n == "spot") return LightType::Spot;
    if (n == "point") return LightType::Point;
    if (n == "directional") return LightType::Directional;
    if (n == "bendy") return LightType::Bendy;
    if (n == "area") return LightType::Area;
    if (n == "bentArea") return LightType::BentArea;
    if (n == "environment") return LightType::Environment;
    return std::nullopt;
}

json schemaJson() {
    json rig = json::array(), light = json::array();
    for (const Property& p : RIG_PROPERTIES) rig.push_back(rowJson(p, true));
    for (const Property& p : LIGHT_PROPERTIES) light.push_back(rowJson(p, false));
    return json{{"schema", 1},
                {"lightTypes", {"spot", "point", "bendy", "directional", "area", "bentArea", "environment"}},
                {"rig", rig},
                {"light", light},
                {"dragModes", dragModesJson()}};
}

std::string markdownTable() {
    std::string out = "| path | value | unit, range | keyframable | a change re-renders |\n|---|---|---|---|---|\n";
    auto row = [&](const Property& p, const std::string& path) {
        std::string name = path;
        if (*p.indexOf) name.replace(name.find("[]"), 2, "[i]");
        static const char* what[] = {"nothing", "the final sum", "a rescale of the light's image", "the light's shading",
                                     "its shadow map and shading"};
        out += "| `" + name + "` | " + p.valueDoc + " | " + p.doc + " | " + (p.keyframable ? "yes" : "") + " | " +
               (p.readOnly || p.type == PropType::Keys ? "" : what[int(p.invalidates)]) + " |\n";
    };
    for (const Property& p : RIG_PROPERTIES) row(p, p.path);
    for (const Property& p : LIGHT_PROPERTIES) row(p, std::string("L.") + p.path);
    return out;
}

} // namespace dfb::protocol
