#version 450 core
// Adds one cached contribution, times its colour x intensity, into the accumulation target
// (additive blending is enabled). Contributions are shaded at unit radiance, so a colour or
// intensity edit changes only uScale (DESIGN section 6); capped at RADIANCE_LIMIT so that no sum
// or exposure of them overflows.
#include "common_uniforms.glsl"
layout(binding = TEX_INPUT) uniform sampler2D uInput;
layout(location = LOC_COMPOSITE_SCALE) uniform vec3 uScale;
// 2 for a contribution shaded at half resolution while dragging (a preview, upsampled by nearest
// pixel); 1 otherwise.
layout(location = LOC_COMPOSITE_PIXEL_STEP) uniform int uPixelStep;
layout(location = OUT_COLOR) out vec4 oColor;
void main() {
    oColor = vec4(scaledContribution(texelAt(uInput, previewTexel(ivec2(gl_FragCoord.xy), uPixelStep)).rgb, uScale), 0.0);
}
