#version 450 core
// Adaptive subdivision of shadow casters for the deformed shadow map. A straight edge of deformed
// length L in a region bending with curvature kappa deviates from the true deformed curve by about
// e = kappa L^2 / 8; with n pieces the deviation falls to e / n^2, so n = sqrt(e / tol) keeps it
// under tol = 0.25 shadow-map texels at the edge's distance. An edge's level depends on the edge
// alone, so neighbouring triangles agree and the mesh has no cracks.
#include "common_uniforms.glsl"
#include "common_bendy.glsl"

layout(vertices = 3) out;
in vec3 vWorld[];
in vec4 vDeformed[];
in vec4 vBend[];
out vec3 tcWorld[];
out vec4 tcDeformed[];

layout(location = LOC_TESS_MAX_LEVEL) uniform float uMaxLevel; // 1 = no subdivision (coarse, for comparison)
layout(location = LOC_TESS_TEXEL_PER_DISTANCE) uniform float uTexelPerDistance; // shadow-map texel size at unit distance

float edgeLevel(int a, int b) {
    return bendyEdgeLevel(vDeformed[a], vDeformed[b], vBend[a], vBend[b], uTexelPerDistance, uMaxLevel);
}

void main() {
    tcWorld[gl_InvocationID] = vWorld[gl_InvocationID];
    tcDeformed[gl_InvocationID] = vDeformed[gl_InvocationID];
    if (gl_InvocationID == 0) {
        if (vDeformed[0].w + vDeformed[1].w + vDeformed[2].w < 0.5) {
            // No vertex has a mapping (all behind the source): the triangle cannot occlude.
            gl_TessLevelOuter[0] = 0.0; gl_TessLevelOuter[1] = 0.0; gl_TessLevelOuter[2] = 0.0;
            gl_TessLevelInner[0] = 0.0;
            return;
        }
        // Outer level i is the edge opposite vertex i.
        float l0 = edgeLevel(1, 2), l1 = edgeLevel(2, 0), l2 = edgeLevel(0, 1);
        gl_TessLevelOuter[0] = l0;
        gl_TessLevelOuter[1] = l1;
        gl_TessLevelOuter[2] = l2;
        gl_TessLevelInner[0] = max(l0, max(l1, l2));
    }
}
