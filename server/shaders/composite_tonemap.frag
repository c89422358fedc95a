#version 450 core
// Exposure and the view transform (none, or the filmic curve); the sRGB transfer function
// (IEC 61966-2-1) to 8 bits is applied by the GL as it stores into the sRGB target
// (GL_FRAMEBUFFER_SRGB, Compositor::toneMap).
#include "common_uniforms.glsl"
layout(binding = TEX_INPUT) uniform sampler2D uInput;
layout(location = OUT_COLOR) out vec4 oColor;
#ifdef TONEMAP_ADD_HOT
// The usual frame of an edit in one pass (Compositor::toneMap): the static sum of every other light
// (uInput) plus the edited light's contribution times its rescale, as composite_add.frag adds it.
layout(binding = TEX_INPUT_HOT) uniform sampler2D uHot;
layout(location = LOC_COMPOSITE_SCALE) uniform vec3 uScale;
layout(location = LOC_COMPOSITE_PIXEL_STEP) uniform int uPixelStep;
#endif
// The ACES filmic curve fitted by K. Narkowicz ("ACES Filmic Tone Mapping Curve", 2016): a toe
// and a shoulder that roll highlights off instead of clipping them. Mirror: Outputs.cpp. The
// curve reaches 1 at x = 7.24; inputs are capped at 1e4 so that x * x cannot overflow to Inf / Inf.
vec3 filmic(vec3 x) {
    x = min(x, vec3(1e4));
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
void main() {
    vec3 c = texelAt(uInput, ivec2(gl_FragCoord.xy)).rgb;
#ifdef TONEMAP_ADD_HOT
    c += scaledContribution(texelAt(uHot, previewTexel(ivec2(gl_FragCoord.xy), uPixelStep)).rgb, uScale);
#endif
    c *= uView.exposure.x;
    if (uView.exposure.y > 0.5) c = filmic(max(c, vec3(0.0)));
    oColor = vec4(clamp(c, 0.0, 1.0), 1.0); // sRGB-encoded on store (GL_FRAMEBUFFER_SRGB)
}
