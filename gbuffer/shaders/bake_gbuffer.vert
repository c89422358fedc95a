#version 450 core
// Bake pass: world-space vertices in, clip-space out; forwards what the G-buffer stores.
layout(location = 0) in vec3 aPosition; // world space
layout(location = 1) in vec3 aNormal;   // world space, unit

layout(location = 0) uniform mat4 uWorldToClip;
layout(location = 1) uniform mat4 uWorldToCamera;

out vec3 vPosition;
out vec3 vNormal;
out float vDepth;

void main() {
    vPosition = aPosition;
    vNormal = aNormal;
    vDepth = -(uWorldToCamera * vec4(aPosition, 1.0)).z; // camera looks down -Z
    gl_Position = uWorldToClip * vec4(aPosition, 1.0);
}
