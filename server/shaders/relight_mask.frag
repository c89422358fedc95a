#version 450 core
// The light's footprint, before its shading pass (LightShading::shade): keeps (writes the depth of)
// the pixels with a sample the light may reach and discards the others, whose depth stays cleared
// so that the shading pass's depth test rejects them. llvmpipe runs a fragment shader on every
// pixel of a 4x4 block unless the early depth test rejects the whole block, so the costly shading
// then runs only where the light can land. Conservative: a kept pixel may still shade to zero,
// a rejected one would have (its contribution is cleared to zero).
//   point and directional lights: a surface that faces the light (N . L > 0);
//   area light: in front of its emitting side;
//   spot: inside the outer cone (barn doors and cookie only cut further);
//   BendyLight: inside the round cone around one segment's chord that holds its tube
//   (segmentFootprintContains), or inside the tube around the extension past the last control
//   point. Its kept pixels get depth 0.75 where a sample lies in two segments' cones or more,
//   0.25 elsewhere: LightShading::shade shades the latter with a variant that solves one segment
//   (BENDY_SINGLE).
#include "common_uniforms.glsl"
#ifdef SHADE_BENDY
#include "common_bendy.glsl"
#endif

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(location = LOC_RELIGHT_PIXEL_STEP) uniform int uPixelStep;
#include "common_pixel_footprint.glsl"

// BendyLight samples in the round cones of two segments or more (relight_bendy.frag then solves all
// segments); the others solve one (BENDY_SINGLE).
bool multiple = false;

// The sample's shading normal, for point and directional lights only: for spots the cone alone
// keeps almost only surfaces that face the light on the scenes measured, and the extra read
// cost more than it saved (cone edit 10.8 -> 12.1 ms); BendyLights have no cheap facing bound.
vec3 normal(ivec2 t) {
#ifdef SHADE_BENDY
    return vec3(0.0);
#else
    return SHADE_KIND == 1 || SHADE_KIND == 3 ? vec3(0.0) : normalize(texelAt(gN, t).xyz);
#endif
}

bool reachable(vec3 P, vec3 N) {
#ifdef SHADE_BENDY
    int K = bendySegments();
    int segments = 0;
    for (int k = 0; k < K; ++k) {
        if (segmentFootprintContains(k, P)) ++segments;
    }
    multiple = multiple || segments > 1;
    if (segments > 0) return true;
    // The extension: foot t >= 0 on the line p + E t, within the radius R + R' t there (+ 1%).
    vec4 p = uBendy.bendyP[2 * K];
    vec4 E = uBendy.bendyEnd;
    float t = dot(P - p.xyz, E.xyz) / max(dot(E.xyz, E.xyz), 1e-30);
    vec3 d = P - p.xyz - E.xyz * t;
    float R = (p.w + E.w * max(t, 0.0)) * 1.01 + 1e-3;
    return t >= -1e-3 && dot(d, d) <= R * R;
#else
    // Environment light: every sample.
    if (SHADE_KIND == 4) return true;
    // Area light: the side of its plane it emits to (one-sided).
    if (SHADE_KIND == 3) return dot(P - uLight.lightPosition.xyz, uLight.lightAxis.xyz) > 0.0;
    vec3 toLight = SHADE_KIND == 0 ? -uLight.lightAxis.xyz : uLight.lightPosition.xyz - P;
    float len = length(toLight);
    // Spot: the outer cone (cos of the angle to the axis above the outer cosine, with a little
    // slack). Point and directional: the shaders shade only where N . L > 0.
    if (SHADE_KIND == 1) return dot(-toLight, uLight.lightAxis.xyz) >= (uLight.lightCone.x - 1e-4) * len;
    return dot(N, toLight) > -1e-6 * len;
#endif
}

// With edge taps (common_pixel_footprint.glsl) a sample is kept when its pixel footprint may reach
// the light: spots widen the outer cone by the footprint's angular radius seen from the light
// (half the sum of its sides over the distance, delta; cos(a + delta) >= cos a - delta -
// delta^2 / 2); BendyLights test the footprint's corners too (the round cones are convex and far
// wider than a pixel); point and directional lights' N . L > 0 is the same at every tap.
bool reachableFootprint(vec3 P, vec3 N, ivec2 t, float coverage) {
    if (SHADE_FOOTPRINT_TAPS <= 1) return reachable(P, N);
    mat2x3 fp = pixelFootprint(P, normalize(texelAt(gNg, t).xyz), coverage);
#ifdef SHADE_BENDY
    bool any = reachable(P, N);
    for (int c = 0; c < 4; ++c) any = reachable(P + fp * vec2((c & 1) == 0 ? -0.5 : 0.5, c < 2 ? -0.5 : 0.5), N) || any;
    return any;
#else
    if (SHADE_KIND != 1) return reachable(P, N);
    vec3 toLight = uLight.lightPosition.xyz - P;
    float len = length(toLight);
    float delta = 0.5 * (length(fp[0]) + length(fp[1])) / max(len, 1e-12);
    return dot(-toLight, uLight.lightAxis.xyz) >= (uLight.lightCone.x - 1e-4 - delta - 0.5 * delta * delta) * len;
#endif
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy) * max(uPixelStep, 1);
#ifdef DFB_FLAT_SAMPLES
    vec4 pA = texelAt(gP, pixel);
    if (!(pA.w > 0.0 && reachableFootprint(pA.xyz, normal(pixel), pixel, pA.w))) discard;
#ifdef SHADE_BENDY
    gl_FragDepth = multiple ? 0.75 : 0.25;
#endif
#else
    uvec2 range = texelFetch(gPixelSamples, pixel, 0).xy;
    bool any = false;
    for (uint s = range.x; s < range.x + range.y; ++s) {
        ivec2 t = sampleTexel(s);
        vec4 pA = texelAt(gP, t);
        any = any || (pA.w > 0.0 && reachableFootprint(pA.xyz, normal(t), t, pA.w));
    }
    if (!any) discard;
#ifdef SHADE_BENDY
    gl_FragDepth = multiple ? 0.75 : 0.25;
#endif
#endif
}
