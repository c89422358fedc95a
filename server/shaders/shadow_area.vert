#version 450 core
// An area light's grid of shadow maps in one instanced pass (ShadowMaps::renderArea): instance k
// draws the casters into layer k, the centre view's clip space with the eye moved in the
// emitter's plane (areaLayer[k], common_area.glsl).
#extension GL_ARB_shader_viewport_layer_array : require
#include "common_uniforms.glsl"
#include "common_area.glsl"
layout(location = ATTR_POSITION) in vec3 aPosition;
void main() {
    vec4 clip = uLight.worldToLightClip * vec4(aPosition, 1.0);
    clip.xy -= areaLayer[gl_InstanceID].xy;
    gl_Position = clip;
    gl_Layer = gl_InstanceID;
}
