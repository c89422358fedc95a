#version 450 core
// Deforms every generated caster vertex Q to Q' (eqs. 4-7) and projects it with the undeformed
// spotlight's perspective: an ordinary depth test on this geometry equals tracing the bent rays.
// Corners reuse the deformation computed per vertex; only new vertices are mapped here.
// Vertices without a mapping are flagged; the fragment stage drops what touches them.
#include "common_uniforms.glsl"
#include "common_bendy.glsl"

layout(triangles, equal_spacing, ccw) in;
in vec3 tcWorld[];
in vec4 tcDeformed[];
out float teValid;

void main() {
    vec3 b = gl_TessCoord;
    vec4 qd;
    if (b.x > 0.99999) qd = tcDeformed[0];
    else if (b.y > 0.99999) qd = tcDeformed[1];
    else if (b.z > 0.99999) qd = tcDeformed[2];
    else {
        TubeCoords c = inverseMap(b.x * tcWorld[0] + b.y * tcWorld[1] + b.z * tcWorld[2]);
        // An unmapped vertex goes to the source, where the near plane clips it.
        qd = c.valid ? vec4(deformedPoint(c), 1.0) : vec4(uBendy.bendyP[0].xyz, 0.0);
    }
    teValid = qd.w;
    gl_Position = uLight.worldToLightClip * vec4(qd.xyz, 1.0);
}
