#version 450 core
// Adaptive subdivision of shadow casters for the deformed shadow map. Each edge's level follows
// from how far the deformation bends it, measured in shadow-map texels: the deformed midpoint's
// distance from the straight deformed edge, e, falls as e / n^2 with n pieces, so n = sqrt(e / tol)
// keeps the error under `tol` texels. An edge's level depends on the edge alone, so neighbouring
// triangles agree and the mesh has no cracks.
#include "common_uniforms.glsl"
#include "common_bendy.glsl"

layout(vertices = 3) out;
in vec3 vWorld[];
out vec3 tcWorld[];

layout(location = 0) uniform float uMaxLevel;       // 1 = no subdivision (coarse, for comparison)
layout(location = 1) uniform float uTexelPerDistance; // shadow-map texel size at unit distance
const float TOLERANCE_TEXELS = 0.25;

// Deformed point and validity (w).
vec4 deform(vec3 q) {
    TubeCoords c = inverseMap(q);
    return c.valid ? vec4(deformedPoint(c), 1.0) : vec4(0.0);
}

float edgeLevel(vec4 a, vec4 b, vec3 mid) {
    if (a.w < 0.5 || b.w < 0.5) return 1.0;
    vec4 m = deform(mid);
    if (m.w < 0.5) return uMaxLevel; // the edge crosses the mapping's boundary: subdivide it all
    float dist = max(dot(m.xyz - uBendy.bendyP[0].xyz, uBendy.bendyAxisU.xyz), 1e-6);
    float e = length(m.xyz - 0.5 * (a.xyz + b.xyz)) / (uTexelPerDistance * dist);
    return clamp(ceil(sqrt(e / TOLERANCE_TEXELS)), 1.0, uMaxLevel);
}

void main() {
    tcWorld[gl_InvocationID] = vWorld[gl_InvocationID];
    if (gl_InvocationID == 0) {
        vec4 d0 = deform(vWorld[0]), d1 = deform(vWorld[1]), d2 = deform(vWorld[2]);
        if (d0.w + d1.w + d2.w < 0.5) {
            // No vertex has a mapping (all behind the source): the triangle cannot occlude.
            gl_TessLevelOuter[0] = 0.0; gl_TessLevelOuter[1] = 0.0; gl_TessLevelOuter[2] = 0.0;
            gl_TessLevelInner[0] = 0.0;
            return;
        }
        // Outer level i is the edge opposite vertex i.
        float l0 = edgeLevel(d1, d2, 0.5 * (vWorld[1] + vWorld[2]));
        float l1 = edgeLevel(d2, d0, 0.5 * (vWorld[2] + vWorld[0]));
        float l2 = edgeLevel(d0, d1, 0.5 * (vWorld[0] + vWorld[1]));
        gl_TessLevelOuter[0] = l0;
        gl_TessLevelOuter[1] = l1;
        gl_TessLevelOuter[2] = l2;
        gl_TessLevelInner[0] = max(l0, max(l1, l2));
    }
}
