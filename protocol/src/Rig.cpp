#include <dfb/protocol/Rig.h>

#include <algorithm>
#include <cmath>

namespace dfb {

Light* Rig::find(const std::string& name) {
    auto it = std::find_if(lights.begin(), lights.end(), [&](const Light& l) { return l.name == name; });
    return it == lights.end() ? nullptr : &*it;
}

const Light* Rig::find(const std::string& name) const {
    return const_cast<Rig*>(this)->find(name);
}

namespace {

Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 scale(const Vec3& a, float s) { return {a[0] * s, a[1] * s, a[2] * s}; }
float length(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

} // namespace

void makeStraightChain(Light& light, float length, int segments) {
    light.type = LightType::Bendy;
    const int n = 2 * segments;
    const float tanTheta = std::tan(light.coneAngleDeg * 3.14159265358979f / 180.f);
    light.controlPoints.clear();
    light.radii = {0.f};
    light.colors = {Vec3{1.f, 1.f, 1.f}};
    for (int i = 1; i <= n; ++i) {
        const float a = length * float(i) / float(n);
        light.controlPoints.push_back({a, 0.f, 0.f});
        light.radii.push_back(a * tanTheta);
        light.colors.push_back({1.f, 1.f, 1.f});
    }
}

void makeStraightCorners(Light& light, float length, int segments) {
    const int n = 2 * segments;
    const float tanTheta = std::tan(light.coneAngleDeg * 3.14159265358979f / 180.f);
    light.cornerPoints.clear();
    light.cornerRadii.clear();
    for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
        light.cornerRadii.push_back(0.f);
        for (int i = 1; i <= n; ++i) {
            const float a = length * float(i) / float(n);
            light.cornerPoints.push_back({a, 0.f, 0.f});
            light.cornerRadii.push_back(a * tanTheta);
        }
    }
}

Rig defaultRig(const Vec3& bmin, const Vec3& bmax) {
    const Vec3 size = sub(bmax, bmin);
    const float radius = std::max(0.5f * length(size), 1e-3f);
    // Aim a little above the bottom of the bounds: most scenes stand on a floor or a table.
    const Vec3 target = {0.5f * (bmin[0] + bmax[0]), bmin[1] + 0.25f * size[1], 0.5f * (bmin[2] + bmax[2])};
    Rig rig;
    rig.version = 1;

    // A spot light at `offset` (in units of the bounds' radius) from the target, aimed at it, with
    // an intensity giving `lux` of irradiance there (2 lux: a mid-grey Lambertian surface reads
    // about 0.5).
    auto aimed = [&](const char* name, const Vec3& offset, float lux, const Vec3& color, float cone, float penumbra) {
        Light l;
        l.name = name;
        l.position = add(target, scale(offset, radius));
        const Vec3 toTarget = sub(target, l.position);
        const float d = length(toTarget);
        l.direction = scale(toTarget, 1.f / d);
        l.color = color;
        l.intensityCd = lux * d * d;
        l.coneAngleDeg = cone;
        l.penumbraDeg = penumbra;
        return l;
    };
    rig.lights.push_back(aimed("key", {-0.55f, 0.95f, 0.6f}, 2.f, {1.f, 0.95f, 0.88f}, 28.f, 6.f));
    Light fill = aimed("fill", {0.9f, 0.45f, 0.8f}, 0.35f, {0.8f, 0.88f, 1.f}, 60.f, 30.f);
    fill.shadow = false;
    rig.lights.push_back(fill);
    return rig;
}

} // namespace dfb
