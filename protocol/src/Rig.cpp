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

Rig defaultRig(const Vec3& bmin, const Vec3& bmax) {
    const Vec3 size = sub(bmax, bmin);
    const float radius = std::max(0.5f * length(size), 1e-3f);
    // Aim a little above the bottom of the bounds: most scenes stand on a floor or a table.
    const Vec3 target = {0.5f * (bmin[0] + bmax[0]), bmin[1] + 0.25f * size[1], 0.5f * (bmin[2] + bmax[2])};
    Rig rig;
    rig.version = 1;

    Light key;
    key.name = "key";
    key.position = add(target, scale({-0.55f, 0.95f, 0.6f}, radius));
    const Vec3 toTarget = sub(target, key.position);
    const float dKey = length(toTarget);
    key.direction = scale(toTarget, 1.f / dKey);
    key.color = {1.f, 0.95f, 0.88f};
    // Irradiance of about 2 lux at the target: a mid-grey Lambertian surface then reads about 0.5.
    key.intensityCd = 2.f * dKey * dKey;
    key.coneAngleDeg = 28.f;
    key.penumbraDeg = 6.f;
    rig.lights.push_back(key);

    Light fill;
    fill.name = "fill";
    fill.position = add(target, scale({0.9f, 0.45f, 0.8f}, radius));
    const Vec3 toTarget2 = sub(target, fill.position);
    const float dFill = length(toTarget2);
    fill.direction = scale(toTarget2, 1.f / dFill);
    fill.color = {0.8f, 0.88f, 1.f};
    fill.intensityCd = 0.35f * dFill * dFill;
    fill.coneAngleDeg = 60.f;
    fill.penumbraDeg = 30.f;
    fill.shadow = false;
    rig.lights.push_back(fill);
    return rig;
}

} // namespace dfb
