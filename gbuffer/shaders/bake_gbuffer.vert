#version 450 core
// Bake pass: world-space vertices in, clip-space out; forwards what the G-buffer needs.
layout(location = 0) in vec3 aPosition; // world space
layout(location = 1) in vec3 aNormal;   // world space, unit
layout(location = 2) in vec4 aTangent;  // world space xyz, w = bitangent sign
layout(location = 3) in vec2 aUv0;
layout(location = 4) in vec2 aUv1;
layout(location = 5) in vec4 aColor;    // COLOR_0, linear

layout(location = 0) uniform mat4 uWorldToClip; // jittered per sample pass

out vec3 vPosition;
out vec3 vNormal;
out vec4 vTangent;
out vec2 vUv0;
out vec2 vUv1;
out vec4 vColor;

void main() {
    vPosition = aPosition;
    vNormal = aNormal;
    vTangent = aTangent;
    vUv0 = aUv0;
    vUv1 = aUv1;
    vColor = aColor;
    gl_Position = uWorldToClip * vec4(aPosition, 1.0);
}
