#include "LightFrustum.h"

#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Schema.h>

#include <dfb/server/AreaPattern.h>
#include <dfb/server/BendyChain.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace dfb::engine {

// One rule for the frustum and the cache key: protocol::shadowHalfAngleDeg (the rig schema's
// coneAngle row re-renders a spot's map only when it changes).
float shadowHalfAngleDeg(const Light& l) { return protocol::shadowHalfAngleDeg(l); }

// 2 x radians(45) is radians(90) to the bit (a power-of-two scaling of the same product).
float shadowFovyRad(const Light& l) {
    return 2.f * glm::radians(l.type == LightType::Point ? 45.f : shadowHalfAngleDeg(l));
}

float texelPerDistance(const Light& l, int mapSize) {
    return 2.f * std::tan(0.5f * shadowFovyRad(l)) / float(std::max(mapSize, 1));
}

glm::vec3 frustumUp(const glm::vec3& axis) { return lightmath::frameUpHint(axis); }

// Near/far from the scene's bounds seen from the light: tight planes keep depth precision.
glm::vec2 perspectiveDepthRange(const glm::vec3& position, const Box& scene, float reach) {
    float farthest = 0.f;
    for (int i = 0; i < 8; ++i) farthest = std::max(farthest, glm::length(boxCorner(scene.min, scene.max, i) - position));
    farthest = std::max(farthest, reach);
    const float zfar = std::max(farthest * 1.01f, 1e-3f);
    const float znear = std::max(zfar * 1e-4f, 1e-5f);
    return {znear, zfar};
}

float areaShadowHalfAngle(const Light& l, const Box& scene) {
    const auto f = areaFrameOf<float>(l);
    float widest = 0.f;
    for (int c = 0; c < 4; ++c) {
        const glm::vec3 eye = f.centre + f.right * ((c & 1 ? 0.5f : -0.5f) * f.width) + f.up * ((c & 2 ? 0.5f : -0.5f) * f.height);
        for (int i = 0; i < 8; ++i) {
            const glm::vec3 d = boxCorner(scene.min, scene.max, i) - eye;
            const float z = glm::dot(d, f.normal);
            const float lateral = glm::length(d - f.normal * z);
            // Beside or behind the emitter's plane: as wide as the map may be.
            widest = std::max(widest, z > 1e-6f ? std::atan2(lateral, z) : glm::radians(90.f));
        }
    }
    return std::min(widest + glm::radians(1.f), glm::radians(80.f));
}

glm::mat4 lightViewProj(const Light& l, const Box& scene, const Box& receivers) {
    const glm::vec3 axis = glm::normalize(toGlm(l.direction));
    const glm::vec3 up = frustumUp(axis);
    if (l.type == LightType::Directional) {
        // An orthographic frustum fitted to what the camera sees (the receivers' bounds) across
        // the light, and stretched towards the light over the whole scene so that every caster
        // that can shadow a receiver is inside.
        const glm::vec3 centre = 0.5f * (scene.min + scene.max);
        const float radius = 0.5f * glm::length(scene.max - scene.min) + 1e-3f;
        const glm::mat4 view = glm::lookAt(centre - axis * (2.f * radius), centre, up);
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (int i = 0; i < 8; ++i) {
            const glm::vec3 v = glm::vec3(view * glm::vec4(boxCorner(receivers.min, receivers.max, i), 1.f));
            lo = glm::min(lo, v);
            hi = glm::max(hi, v);
        }
        return glm::ortho(lo.x, hi.x, lo.y, hi.y, 1e-3f * radius, 4.f * radius) * view;
    }
    const glm::vec3 pos = toGlm(l.position);
    const glm::mat4 view = glm::lookAt(pos, pos + axis, up);
    float reach = 0.f;
    if (l.type == LightType::Bendy && !l.controlPoints.empty()) {
        // Deformed geometry lies at arc-length distances: up to the chain's length plus whatever
        // the straight extension reaches (at most the scene's extent past the chain's end).
        const auto ch = chainFromLight<float>(l);
        reach = ch.arcStart[ch.segments] + glm::length(scene.max - scene.min);
    }
    if (l.type == LightType::Area) {
        // Every layer's eye lies on the emitter: the depth range must hold the scene from each.
        const float diagonal = std::hypot(l.areaSize[0], l.areaSize[1]);
        const glm::vec2 depth = perspectiveDepthRange(pos, scene, diagonal);
        return glm::perspective(2.f * areaShadowHalfAngle(l, scene), 1.f, depth.x * 0.5f, depth.y + diagonal) * view;
    }
    const glm::vec2 depth = perspectiveDepthRange(pos, scene, reach);
    // The frustum's half-angle must contain the cone's; a square map circumscribes the circle.
    return glm::perspective(shadowFovyRad(l), 1.f, depth.x, depth.y) * view;
}

// GL's cube-map face orientations (GL 4.5 section 8.13, table 8.19): face i is looked up for
// directions whose major axis is `target`, with s and t along the faces' -z/x/.. axes, which is
// what a camera with these up vectors renders.
glm::mat4 cubeFaceView(const glm::vec3& position, int face) {
    static const glm::vec3 targets[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    static const glm::vec3 ups[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
    return glm::lookAt(position, position + targets[face], ups[face]);
}

} // namespace dfb::engine
