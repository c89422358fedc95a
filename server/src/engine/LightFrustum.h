#pragma once
// Where a light's shadow map looks: its frustum's half-angle and frame, the depth range that
// covers the scene, the view-projections of 2D maps and of a point light's cube faces, and the
// size of a map's texel at unit distance (the receivers' normal offset and the BendyLight's
// subdivision tolerance are measured in it).

#include <dfb/protocol/Rig.h>

#include <glm/glm.hpp>

namespace dfb::engine {

inline glm::vec3 toGlm(const Vec3& v) { return {v[0], v[1], v[2]}; }

/// An axis-aligned box, world units.
struct Box {
    glm::vec3 min{0.f}, max{0.f};
};

/// Corner `i` (0..7) of the box [lo, hi]: bit 0 picks x from hi, bit 1 y, bit 2 z.
inline glm::vec3 boxCorner(const glm::vec3& lo, const glm::vec3& hi, int i) {
    return {(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z};
}

/// Half-angle of a light's shadow frustum, degrees (see LightFrustum.cpp for the steps).
float shadowHalfAngleDeg(const Light& l);

/// The full opening angle of the light's shadow projection, radians: twice the half-angle, or
/// 90 degrees for a point light's cube face.
float shadowFovyRad(const Light& l);

/// The world size of one texel of a perspective shadow map `mapSize` texels wide at unit distance
/// from the light (a cube face spans 90 degrees: 2 / size).
float texelPerDistance(const Light& l, int mapSize);

/// The up vector of the frame along unit `axis` that shadow frusta, barn doors and cookies share:
/// +Y, or +X when the axis is within about 8 degrees of vertical.
glm::vec3 frustumUp(const glm::vec3& axis);

/// Near and far planes (x, y) of a perspective projection from `position` that holds the scene
/// box and everything within `reach` of the position.
glm::vec2 perspectiveDepthRange(const glm::vec3& position, const Box& scene, float reach = 0.f);

/// Half-angle (radians) of an area light's shadow frustum, along its normal from its centre: the
/// widest angle at which a corner of the scene box in front of the emitter is seen from any of the
/// emitter's corners, plus a degree, at most 80 degrees (texels stretch towards 90; what lies
/// beyond grazes the emitter's plane, where its cosine leaves little light).
float areaShadowHalfAngle(const Light& l, const Box& scene);

/// World to clip space of a spot, directional or BendyLight's 2D shadow map: perspective along the
/// light's axis, or for a directional light an orthographic box around what the camera sees
/// (`receivers`) stretched towards the light over the `scene`; an area light's is the centre
/// view of its grid (areaShadowHalfAngle; ShadowMaps::renderArea moves the eye per layer).
glm::mat4 lightViewProj(const Light& l, const Box& scene, const Box& receivers);

/// World to view space of cube face `face` (0..5, GL's +X, -X, +Y, -Y, +Z, -Z order) of a point
/// light at `position`.
glm::mat4 cubeFaceView(const glm::vec3& position, int face);

} // namespace dfb::engine
