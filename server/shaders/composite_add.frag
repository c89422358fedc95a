#version 450 core
// Adds one cached contribution, times its rescale, into the accumulation target (additive
// blending is enabled). A colour or intensity edit changes only the rescale: the contribution was
// shaded with the colour x intensity it had then, and uScale = new / shaded (DESIGN section 6).
#include "common_uniforms.glsl"
layout(binding = TEX_INPUT) uniform sampler2D uInput;
layout(location = LOC_COMPOSITE_SCALE) uniform vec3 uScale;
// 2 for a contribution shaded at half resolution while dragging (a preview, upsampled by nearest
// pixel); 1 otherwise.
layout(location = LOC_COMPOSITE_PIXEL_STEP) uniform int uPixelStep;
layout(location = OUT_COLOR) out vec4 oColor;
void main() { oColor = vec4(texelFetch(uInput, previewTexel(ivec2(gl_FragCoord.xy), uPixelStep), 0).rgb * uScale, 0.0); }
