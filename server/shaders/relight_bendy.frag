#version 450 core
// One BendyLight's contribution per pixel (paper 000 sections 3-4; docs/lighting.md): per
// G-buffer sample, the tube coordinates of P (eqs. 4-6), the deformed point Q' (eq. 7), the light
// direction Li (eq. 9, or the exact flow-line tangent), the chain's colour c(u), the cone falloff
// and the distance falloff of the undeformed spotlight evaluated at Q', and the deformed shadow
// map looked up at the receiver's own Q'.
#include "common_uniforms.glsl"
#include "common_brdf.glsl"
#include "common_falloff.glsl"
#include "common_bendy.glsl"

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
layout(binding = TEX_GBUFFER_ALBEDO) uniform sampler2D gAlbedo;
layout(binding = TEX_GBUFFER_BRDF) uniform sampler2D gBrdf;
layout(binding = TEX_GBUFFER_SHEEN) uniform sampler2D gSheen;
layout(binding = TEX_GBUFFER_COAT) uniform sampler2D gCoat;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(binding = TEX_SHADOW_MAP) uniform sampler2DShadow shadowMap;

layout(location = OUT_COLOR) out vec4 oColor;
// Outside the light's footprint the depth test (relight_mask.frag) rejects pixels before shading.
layout(early_fragment_tests) in;
// 0: the light's radiance. 1: its shadow mask: r = coverage-weighted visibility of the samples the
// light reaches (inside the cone, facing it), g = their coverage.
layout(location = LOC_RELIGHT_OUTPUT) uniform int uOutput;
layout(location = LOC_RELIGHT_LINKED) uniform int uLinked;
// Preview shading (progressive refinement): 2 shades every second pixel of every second row into
// a half-size image; 1 shades every pixel.
layout(location = LOC_RELIGHT_PIXEL_STEP) uniform int uPixelStep;
layout(binding = TEX_GBUFFER_ID) uniform usampler2D gId;

// The deformed shadow map at a receiver with tube coordinates `c` and arc length `s`: the
// receiver is biased along its geometric normal by `offset` (world units) and mapped like any
// caster vertex. The biased point's tube coordinates are those of the receiver moved by the bias
// in the tube's frame (first order: the foot moves along u_hat by the bias's u_hat part, the
// radius with it; the offset across changes by the rest), which spares a second cubic solve per
// sample. Exact for straight chains; on bends it neglects the frame's turn over the bias length
// (a fraction of a shadow-map texel), far below a texel.
float bendyShadow(TubeCoords c, float s, vec3 Ng, float offset) {
    vec3 uHat = c.uHat, vHat = c.vHat, wHat = c.wHat;
    float R = c.foot.w;
    vec3 d = Ng * offset;
    float du = dot(d, uHat);
    float s2 = max(s + du, 0.0);
    // The foot moves du along the chain, where the radius is R + R'(s) du (R' per arc length):
    // the receiver's offset from the chain, (v vHat + w wHat) R + the bias across, over it.
    float R2 = max(R + c.derivative.w / max(length(c.derivative.xyz), 1e-12) * du, 1e-9);
    float v2 = (c.v * R + dot(d, vHat)) / R2, w2 = (c.w * R + dot(d, wHat)) / R2;
    vec3 q = uBendy.bendyP[0].xyz + uBendy.bendyAxisU.xyz * s2 +
             (uBendy.bendyAxisV.xyz * v2 + uBendy.bendyAxisW.xyz * w2) * (s2 * uBendy.bendyAxisU.w);
    vec4 clip = uLight.worldToLightClip * vec4(q, 1.0);
    if (clip.w <= 0.0) return 0.0;
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    float ref = ndc.z * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 1.0;
    return filteredShadow(shadowMap, uv, ref);
}

// t: the sample's texel in the sample textures.
vec3 shadeSample(ivec2 t) {
    vec4 pA = texelFetch(gP, t, 0);
    if (pA.w <= 0.0) return vec3(0.0);
    if (SHADE_LINKED && !objectLinked(texelFetch(gId, t, 0).x)) return vec3(0.0); // light linking
    vec3 P = pA.xyz;
    TubeCoords c = inverseMapForShading(P);
    if (!c.valid) return vec3(0.0); // no foot: unlit
    float arc = tubeArcLength(c);
    vec3 qd = deformedPointAt(c, arc);
    vec3 toSource = uBendy.bendyP[0].xyz - qd;
    float dist2 = max(dot(toSource, toSource), 1e-12);
    float dist = sqrt(dist2);
    float spot = spotCone(uLight.lightCone.xy, toSource / dist, uBendy.bendyAxisU.xyz);
    if (spot <= 0.0) return vec3(0.0);
    vec3 N = normalize(texelFetch(gN, t, 0).xyz);
    vec3 Li = lightDirection(c, P, BENDY_EXACT);
    if (dot(N, Li) <= 0.0) return vec3(0.0);
    float vis = 1.0;
    if (SHADE_SHADOWED) {
        // Facing away geometrically: shadowed by itself (as shadowVisibility, relight_spot.frag).
        vec3 Ng = normalize(texelFetch(gNg, t, 0).xyz);
        vis = dot(Ng, Li) <= 0.0 ? 0.0 : bendyShadow(c, arc, Ng, shadowNormalOffset(Ng, Li, dist));
        if (vis <= 0.0 && SHADE_OUTPUT == 0) return vec3(0.0);
    }
    if (SHADE_OUTPUT == 1) return vec3(vis * pA.w, pA.w, 0.0);
    vec3 f = evaluateLayeredBrdfCos(N, Li, viewVector(P), texelFetch(gAlbedo, t, 0).rgb, texelFetch(gBrdf, t, 0),
                                    texelFetch(gSheen, t, 0), texelFetch(gCoat, t, 0).xy);
    return f * segmentColor(c.g, c.t) * (spot * vis * inverseSquare(dist2)) * pA.w;
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy) * max(uPixelStep, 1);
#ifdef DFB_FLAT_SAMPLES
    // Flat buffer: one sample per pixel, stored at the pixel itself (no indirection, no loop).
    oColor = vec4(shadeSample(pixel), 1.0);
#else
    uvec2 range = texelFetch(gPixelSamples, pixel, 0).xy;
    vec3 sum = vec3(0.0);
    for (uint s = range.x; s < range.x + range.y; ++s) sum += shadeSample(sampleTexel(s));
    oColor = vec4(sum, 1.0);
#endif
}
