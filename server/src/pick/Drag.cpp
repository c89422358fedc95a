#include <dfb/server/Drag.h>

#include <dfb/protocol/Schema.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/LocalShadowEdit.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace dfb {

namespace {

using json = nlohmann::json;
using glm::dvec3;
using protocol::DragMode;

std::string pixelName(int x, int y) { return "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")"; }

Status checkPixel(const DeepBuffer& shot, int x, int y) {
    if (x >= 0 && y >= 0 && x < shot.width && y < shot.height) return okStatus();
    return makeError(ErrorCode::InvalidValue, "drag: " + pixelName(x, y) + " is outside the " + std::to_string(shot.width) + "x" +
                                                  std::to_string(shot.height) + " image");
}

Result<PickResult> pickSurface(const Picker& picker, int x, int y) {
    auto p = picker.pick(x, y);
    if (!p) {
        if (p.error().code == ErrorCode::MissingData) {
            return makeError(ErrorCode::MissingData, "drag: " + pixelName(x, y) + " shows no surface (the background)");
        }
        return p.error();
    }
    return p;
}

json vec(const Vec3& v) { return json::array({v[0], v[1], v[2]}); }
json vec(const glm::vec3& v) { return json::array({v.x, v.y, v.z}); }

// The unit direction from X towards the eye (Vi of paper 000 eq. 13).
dvec3 viewDirection(const DragGrab& g, const dvec3& X) {
    if (g.orthographic) return -glm::normalize(g.forward);
    return glm::normalize(g.eye - X);
}

// Local shadow modes: points of the occluder's object (objectId) that `light` reaches, whose tube
// coordinates the solve keeps besides S's (LocalShadowEdit.h; issue 17 point 8: S alone is one
// point of a vase that spans the moved segment). The front samples of the object's pixels inside
// the tube, on a grid of at most ~65,536 pixels; the lit ones among up to 4x the bound of them,
// evenly spaced in scan order (one shadow ray each, so the begin stays cheap), then the bound of
// those, evenly spaced again.
std::vector<dvec3> occluderSamples(const Picker& picker, const DeepBuffer& shot, const Light& light, uint32_t objectId) {
    std::vector<dvec3> out;
    if (objectId == 0) return out;
    const auto ch = chainFromLight<double>(light);
    const int stride = std::max(1, int(std::ceil(std::sqrt(double(shot.width) * shot.height / 65536.0))));
    std::vector<PickResult> inTube;
    for (int y = 0; y < shot.height; y += stride)
        for (int x = 0; x < shot.width; x += stride) {
            auto p = picker.pick(x, y);
            if (!p || p->objectId != objectId) continue;
            dvec3 uvw;
            bool inside = false;
            if (indirect::local::coordsOf(ch, dvec3(p->P), uvw, &inside) && inside) inTube.push_back(p.value());
        }
    const size_t tries = std::min(inTube.size(), size_t(4 * indirect::LOCAL_MAX_OCCLUDER_SAMPLES));
    std::vector<dvec3> lit;
    for (size_t i = 0; i < tries; ++i) {
        const PickResult& c = inTube[i * inTube.size() / tries];
        auto o = picker.occluder(light, c.P, c.Ng);
        if (o && !o->found) lit.push_back(dvec3(c.P));
    }
    const size_t n = std::min(lit.size(), size_t(indirect::LOCAL_MAX_OCCLUDER_SAMPLES));
    for (size_t i = 0; i < n; ++i) out.push_back(lit[i * lit.size() / n]);
    return out;
}

} // namespace

Result<DragGrab> beginDrag(const Picker& picker, const DeepBuffer& shot, const Rig& rig, const DragStart& start) {
    const protocol::DragModeInfo& info = protocol::dragModeInfo(start.mode);
    if (auto st = checkPixel(shot, start.x, start.y); !st) return st.error();
    const Light* stored = rig.find(start.light);
    if (!stored) return makeError(ErrorCode::MissingData, "drag: the rig has no light '" + start.light + "'");
    const Rig evaluated = protocol::evaluateRig(rig);
    const Light& light = *evaluated.find(start.light);
    if (!(info.lights & protocol::lightBit(light.type))) {
        return makeError(ErrorCode::InvalidValue, "drag mode '" + std::string(info.name) + "' does not apply to " +
                                                      protocol::lightTypeName(light.type) + " light '" + light.name +
                                                      "' (it applies to: " + protocol::dragModeLightNames(info) + ")");
    }
    if (!light.enabled) return makeError(ErrorCode::InvalidValue, "drag: light '" + light.name + "' is disabled");
    if (auto st = indirect::detail::checkLight(light, start.points); !st) return makeError(st.error().code, "drag: " + st.error().message);
    DragGrab g;
    g.mode = start.mode;
    g.light = light;
    g.stored = *stored;
    g.time = rig.time;
    g.points = start.points;
    g.x = start.x;
    g.y = start.y;
    auto at = pickSurface(picker, start.x, start.y);
    if (!at) return at.error();
    g.at = at.value();
    if (info.needsOccluder) {
        auto o = picker.occluder(light, g.at.P, g.at.Ng);
        if (!o) return makeError(o.error().code, "drag: " + o.error().message);
        if (!o->found) {
            return makeError(ErrorCode::MissingData, "drag: " + pixelName(start.x, start.y) + " is not in a shadow of light '" + light.name +
                                                         "' (nothing lies between it and the light): grab a shadowed pixel");
        }
        g.occluder = o.value();
        if (start.mode == DragMode::LocalShadowMove || start.mode == DragMode::LocalShadowScale) {
            g.occluderSamples = occluderSamples(picker, shot, light, o->objectId);
        }
    }
    g.eye = dvec3(shot.camera.position());
    g.orthographic = shot.camera.orthographic;
    g.forward = dvec3(shot.camera.forward());
    return g;
}

Result<DragStep> dragTo(const Picker& picker, const DeepBuffer& shot, const DragGrab& g, int x, int y) {
    const auto t0 = std::chrono::steady_clock::now();
    if (auto st = checkPixel(shot, x, y); !st) return st.error();
    auto now = pickSurface(picker, x, y);
    if (!now) return now.error();
    DragStep s;
    s.at = now.value();
    s.x = x;
    s.y = y;
    if (x == g.x && y == g.y) {
        // The pointer back on the grab: the feature is where it was. (The closed forms would give
        // the begin light again only up to rounding.)
        s.light = g.light;
        s.solveMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        return s;
    }
    const dvec3 M(g.at.P), Mnew(now->P), N(g.at.N), Nnew(now->N);
    const dvec3 S = g.occluder ? dvec3(g.occluder->S) : dvec3(0.0);
    Result<indirect::Edit> e = makeError(ErrorCode::InvalidValue, "drag: unknown mode");
    switch (g.mode) {
    case DragMode::Shadow: e = indirect::shadowDrag(g.light, S, M, Mnew, g.points); break;
    case DragMode::Hotspot: e = indirect::hotspotDrag(g.light, M, Mnew, g.points); break;
    case DragMode::Highlight: e = indirect::highlightDrag(g.light, Mnew, Nnew, viewDirection(g, Mnew), g.points); break;
    case DragMode::PhysicalShadowMove: e = indirect::physicalShadowMove(g.light, S, M, Mnew, g.points); break;
    case DragMode::DiffuseMove: e = indirect::diffuseMove(g.light, M, N, Mnew, Nnew, g.points); break;
    case DragMode::LocalShadowMove: e = indirect::localShadowMove(g.light, S, M, Mnew, g.points, g.occluderSamples); break;
    case DragMode::LocalShadowScale: e = indirect::localShadowScale(g.light, S, M, Mnew, g.points, g.occluderSamples); break;
    }
    if (!e) return makeError(e.error().code, "drag: " + e.error().message);
    if (g.light.type == LightType::Bendy && chainWarning(g.light).empty()) {
        if (const std::string w = chainWarning(e->light); !w.empty()) {
            return makeError(ErrorCode::InvalidValue, "drag: the solved BendyLight would fold (" + w + "); nothing was changed");
        }
    }
    s.light = e->light;
    s.changes = dragChanges(g, s.light);
    s.iterations = e->iterations;
    s.residual = e->residual;
    s.solveMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return s;
}

std::vector<protocol::Change> dragChanges(const DragGrab& g, const Light& solved) {
    std::vector<protocol::Change> out;
    auto put = [&](const std::string& prop, json value) {
        auto it = g.stored.keys.find(prop);
        if (it == g.stored.keys.end() || it->second.empty()) {
            out.push_back({g.light.name + "." + prop, std::move(value)});
            return;
        }
        // Keyed: a key at the session's time (keeping the interpolation of one already there), as
        // the browser's handles do; a plain value would be overridden by the keys.
        std::string interp = "linear";
        for (const Key& k : it->second) {
            if (std::abs(k.time - g.time) < 1e-9 && k.interp == Interp::Smooth) interp = "smooth";
        }
        out.push_back({g.light.name + ".key", json{{"path", prop}, {"t", g.time}, {"value", std::move(value)}, {"interp", interp}}});
    };
    const Light& a = g.light;
    if (solved.position != a.position) put("position", vec(solved.position));
    if (solved.direction != a.direction) put("direction", vec(solved.direction));
    for (size_t i = 0; i < std::min(a.controlPoints.size(), solved.controlPoints.size()); ++i) {
        if (solved.controlPoints[i] != a.controlPoints[i]) put("cp[" + std::to_string(i + 1) + "]", vec(solved.controlPoints[i]));
    }
    for (size_t i = 0; i < std::min(a.radii.size(), solved.radii.size()); ++i) {
        if (solved.radii[i] != a.radii[i]) put("r[" + std::to_string(i) + "]", json(solved.radii[i]));
    }
    return out;
}

std::vector<protocol::Change> restoreChanges(const DragGrab& g) {
    const json j = protocol::toJson(g.stored);
    std::vector<protocol::Change> out;
    for (const char* prop : {"position", "direction", "controlPoints", "radii"}) {
        if (j.contains(prop)) out.push_back({g.stored.name + "." + prop, j[prop]});
    }
    out.push_back({g.stored.name + ".keys", j.contains("keys") ? j["keys"] : json::object()});
    return out;
}

json toJson(const DragGrab& g) {
    json j{{"mode", protocol::dragModeInfo(g.mode).name},
           {"light", g.light.name},
           {"x", g.x},
           {"y", g.y},
           {"point", vec(g.at.P)},
           {"normal", vec(g.at.N)},
           {"objectId", g.at.objectId},
           {"points", g.points}};
    if (g.occluder) {
        j["occluder"] = {{"S", vec(g.occluder->S)},
                         {"objectId", g.occluder->objectId},
                         {"distance", g.occluder->distance},
                         {"samples", g.occluderSamples.size()}};
    }
    return j;
}

json toJson(const DragStep& s) {
    return json{{"x", s.x},
                {"y", s.y},
                {"point", vec(s.at.P)},
                {"iterations", s.iterations},
                {"residual", s.residual},
                {"solveMs", s.solveMs},
                {"changed", !s.changes.empty()}};
}

} // namespace dfb
