#version 450 core
// Deforms every (subdivided) caster vertex Q to Q' (eqs. 4-7) and projects it with the
// undeformed spotlight's perspective: an ordinary depth test on this geometry equals tracing the
// bent rays. Vertices without a mapping are flagged; the fragment stage drops what touches them.
#include "common_uniforms.glsl"
#include "common_bendy.glsl"

layout(triangles, equal_spacing, ccw) in;
in vec3 tcWorld[];
out float teValid;

void main() {
    vec3 q = gl_TessCoord.x * tcWorld[0] + gl_TessCoord.y * tcWorld[1] + gl_TessCoord.z * tcWorld[2];
    TubeCoords c = inverseMap(q);
    // An unmapped vertex goes to the source, where the near plane clips it.
    vec3 qd = c.valid ? deformedPoint(c) : uBendy.bendyP[0].xyz;
    teValid = c.valid ? 1.0 : 0.0;
    gl_Position = uLight.worldToLightClip * vec4(qd, 1.0);
}
