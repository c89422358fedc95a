#version 450 core
// Shadow-map pass of a spot light: world-space casters through the light's view-projection.
#include "common_uniforms.glsl"
layout(location = ATTR_POSITION) in vec3 aPosition;
void main() {
    gl_Position = uLight.worldToLightClip * vec4(aPosition, 1.0);
}
