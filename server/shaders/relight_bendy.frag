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
#include "common_pixel_footprint.glsl"
#include "common_horizon.glsl"

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
layout(binding = TEX_GBUFFER_ALBEDO) uniform sampler2D gAlbedo;
layout(binding = TEX_GBUFFER_BRDF) uniform sampler2D gBrdf;
layout(binding = TEX_GBUFFER_SHEEN) uniform sampler2D gSheen;
layout(binding = TEX_GBUFFER_COAT) uniform sampler2D gCoat;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(binding = TEX_SHADOW_MAP) uniform sampler2D shadowMap; // raw depth: filteredShadowPlane compares

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

// A bent area light's interior light (docs/lighting.md, "Bent area lights") is a cell of a
// Lambertian emitter: its intensity falls with the cosine between the (undeformed) emission
// direction and the emitter's normal, the spotlight's axis.
#ifndef BENDY_EMITTER_COSINE
#define BENDY_EMITTER_COSINE (uLight.lightCube.z > 0.5)
#endif

// The tube coordinates and arc length (`s2`) of P + d from those of P (c, s), to first order,
// which spares a cubic solve per shifted point. The foot moves along u_hat by
// ds = (d . u_hat) / (1 - (P - foot) . du_hat/ds): on a bend the frame turns under the offset
// (P - foot) = R (v v_hat + w w_hat), so a point off the chain's inner side moves its foot faster
// than itself, one off the outer side slower (the foot condition (P - foot) . u_hat = 0,
// differentiated). The radius moves with the foot, R + R'(s) ds (R' per arc length), and the
// offset across changes by d's parts across (the rotation-minimising frame turns v_hat and w_hat
// only towards u_hat: second order there). Exact for straight chains.
// The rates of that first-order shift at a point, computed once and used for every shift of it
// (its bias and its plane's two tangents; a sample's footprint taps): the foot's arc length per
// unit of d . u_hat, and the radius per arc length.
struct TubeShift {
    float footRate;
    float radiusRate;
};

TubeShift tubeShift(TubeCoords c) {
    float speed = max(length(c.derivative.xyz), 1e-12);
    vec3 turn = segmentUnitTangentDerivative(c.g, c.t) / speed; // du_hat/ds
    TubeShift r;
    r.footRate = 1.0 / max(1.0 - c.foot.w * dot(c.v * c.vHat + c.w * c.wHat, turn), 1e-3);
    r.radiusRate = c.derivative.w / speed;
    return r;
}

TubeCoords shiftedTube(TubeCoords c, TubeShift k, float s, vec3 d, out float s2) {
    float R = c.foot.w;
    float du = dot(d, c.uHat) * k.footRate;
    s2 = max(s + du, 0.0);
    float R2 = max(R + k.radiusRate * du, 1e-9);
    TubeCoords o = c;
    o.v = (c.v * R + dot(d, c.vHat)) / R2;
    o.w = (c.w * R + dot(d, c.wHat)) / R2;
    o.foot = vec4(c.foot.xyz + c.uHat * du, R2);
    return o;
}

// The straight-space point (the undeformed spot light's, where the deformed map's casters are
// drawn) of the receiver moved by d (world).
vec3 bendyStraightPoint(TubeCoords c, TubeShift k, float s, vec3 d) {
    float s2;
    TubeCoords o = shiftedTube(c, k, s, d, s2);
    return uBendy.bendyP[0].xyz + uBendy.bendyAxisU.xyz * s2 +
           (uBendy.bendyAxisV.xyz * o.v + uBendy.bendyAxisW.xyz * o.w) * (s2 * uBendy.bendyAxisU.w);
}

// The deformed shadow map at a receiver with tube coordinates `c` and arc length `s`, at distance
// `dist` from the source along its flow line: the receiver is biased along its geometric normal
// by `offset` (world units) and mapped like any caster vertex; its plane's tangents are carried
// through the same map for the receiver-plane comparison (filteredShadowPlane). NgL: the cosine
// of Ng with the light direction at the receiver (nearFieldLift).
float bendyShadow(TubeCoords c, TubeShift k, float s, vec3 Ng, float offset, float dist, float NgL) {
    vec3 d = Ng * offset;
    vec3 q = bendyStraightPoint(c, k, s, d);
    // The tangents by a small step: the map is smooth, receiverPlaneLookup needs only directions.
    mat2x3 tf = tangentFrame(Ng);
    float e = 1e-3 * (s + c.foot.w) + 1e-6;
    ShadowLookup l;
    vec3 lift = normalize(uBendy.bendyP[0].xyz - q) * nearFieldLift(shadowLift(dist), NgL);
    if (!receiverPlaneLookup(q, bendyStraightPoint(c, k, s, d + tf[0] * e) - q, bendyStraightPoint(c, k, s, d + tf[1] * e) - q, lift, l))
        return 0.0;
    if (any(lessThan(l.st, vec2(0.0))) || any(greaterThan(l.st * uLight.lightShadow.x, vec2(1.0)))) return 1.0;
    return filteredShadowPlane(shadowMap, l);
}

// ---- Edges inside a pixel (common_pixel_footprint.glsl; docs/lighting.md) ----

// The mean over the sample's footprint taps of the cone falloff at the tap's Q' times its
// visibility (bendyShadow with the tap as the receiver). `vis`: the mean visibility alone;
// `reach` > 0 where some tap lies inside the cone.
// Li: the sample's light direction (its turn over the pixel is neglected, as for the bias).
float bendyFootprintLight(ivec2 t, TubeCoords c, float arc, vec3 P, vec3 Ng, float highest, vec3 Li, float coverage, out float vis,
                          out float reach) {
    mat2x3 fp = pixelFootprint(P, Ng, coverage);
    // Facing away geometrically or below the near-field horizon: shadowed at every tap
    // (shadowVisibility's rule, relight_spot.frag).
    bool facing = !SHADE_SHADOWED || nearFieldVisibility(t, Ng, highest, Li) > 0.0;
    TubeShift shift = tubeShift(c);
    float sum = 0.0, visSum = 0.0;
    reach = 0.0;
    for (int k = 0; k < SHADE_FOOTPRINT_TAPS; ++k) {
        float s;
        TubeCoords q = shiftedTube(c, shift, arc, footprintTap(fp, k), s);
        vec3 toSource = uBendy.bendyP[0].xyz - deformedPointAt(q, s);
        float dist = max(length(toSource), 1e-6);
        float m = spotCone(uLight.lightCone.xy, toSource / dist, uBendy.bendyAxisU.xyz);
        float v = !SHADE_SHADOWED ? 1.0 : facing ? bendyShadow(q, tubeShift(q), s, Ng, shadowNormalOffset(dist), dist, dot(Ng, Li)) : 0.0;
        sum += m * v;
        visSum += v;
        reach = max(reach, m);
    }
    vis = visSum / float(SHADE_FOOTPRINT_TAPS);
    return sum / float(SHADE_FOOTPRINT_TAPS);
}

// t: the sample's texel in the sample textures.
vec3 shadeSample(ivec2 t) {
    vec4 pA = texelAt(gP, t);
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
    float spot = SHADE_FOOTPRINT_TAPS > 1 ? 1.0 : spotCone(uLight.lightCone.xy, toSource / dist, uBendy.bendyAxisU.xyz);
    if (spot <= 0.0) return vec3(0.0);
    vec3 N = normalize(texelAt(gN, t).xyz);
    vec3 Li = lightDirection(c, P, BENDY_EXACT);
    if (dot(N, Li) <= 0.0) return vec3(0.0);
    float vis = 1.0;
    vec4 ng = texelAt(gNg, t); // w: the highest horizon sine
    vec3 Ng = normalize(ng.xyz);
    if (SHADE_FOOTPRINT_TAPS > 1) {
        // Edges inside the pixel: cone and visibility over the footprint's taps.
        float reach;
        spot = bendyFootprintLight(t, c, arc, P, Ng, ng.w, Li, pA.w, vis, reach);
        if (reach <= 0.0) return vec3(0.0);
        if (SHADE_OUTPUT == 1) return vec3(vis * pA.w, pA.w, 0.0);
        vis = 1.0; // in spot
    } else if (SHADE_SHADOWED) {
        // Facing away geometrically or below the near-field horizon: shadowed (as
        // shadowVisibility, relight_spot.frag).
        vis = nearFieldVisibility(t, Ng, ng.w, Li) <= 0.0 ? 0.0 : bendyShadow(c, tubeShift(c), arc, Ng, shadowNormalOffset(dist), dist, dot(Ng, Li));
        if (vis <= 0.0 && SHADE_OUTPUT == 0) return vec3(0.0);
    }
    if (SHADE_OUTPUT == 1) return vec3(vis * pA.w, pA.w, 0.0);
    vec3 f = evaluateLayeredBrdfCos(N, Li, viewVector(P), texelAt(gAlbedo, t).rgb, texelAt(gBrdf, t),
                                    texelAt(gSheen, t), texelAt(gCoat, t).xy);
    float emitter = BENDY_EMITTER_COSINE ? max(dot(toSource / dist, -uBendy.bendyAxisU.xyz), 0.0) : 1.0;
    return f * segmentColor(c.g, c.t) * (spot * vis * emitter * inverseSquare(dist2)) * pA.w;
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
