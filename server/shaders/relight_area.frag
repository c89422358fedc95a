#version 450 core
// One area light's contribution per pixel from the G-buffer samples (docs/lighting.md, "Area
// lights"): one-shot approximate local shading (Wang, Lin, Li and Guo, "One-Shot Approximate
// Local Shading", 2008, "paper 001"), per sample and lobe a point light on the emitter's plane at
// the lobe's representative point t (common_area.glsl; clamped to the emitter) carrying the
// pattern's integral over the square of half-side alpha rho(|p t1|) (diffuse) or beta rho(|p t2|) / n
// (specular; n the Phong exponent of the GGX roughness; rho = radiusLength, AreaLight.h
// OneShotModel) around it: radiance = sum over the lobes of f_lobe(l) (N.l) (-l.n) I / d^2,
// at unit emitter radiance (colour x intensity in cd/m^2 is applied in the composite); times the
// mean visibility of the grid of shadow maps over the emitter. AREA_REFERENCE g: the reference
// instead, g x g cells of the emitter each with the exact pattern integral over the cell (the
// table) at its centre and the full BRDF (AreaLight.h referenceShading), same visibility.
// AREA_LTC (the light's `shading` is LTC, LightShading::shade; 1 a rectangle, 2 a disk): linearly
// transformed cosines instead of one-shot (Heitz, Dupuy, Hill and Neubelt 2016; Heitz and Hill 2017;
// common_ltc.glsl, Ltc.h), the uniform emitter of the pattern's mean colour, same visibility.
#include "common_uniforms.glsl"
#include "common_brdf.glsl"
#include "common_area.glsl"
#include "common_ltc.glsl" // always, so that the build's validation compiles the LTC path too

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
layout(binding = TEX_GBUFFER_ALBEDO) uniform sampler2D gAlbedo;
layout(binding = TEX_GBUFFER_BRDF) uniform sampler2D gBrdf;
layout(binding = TEX_GBUFFER_SHEEN) uniform sampler2D gSheen;
layout(binding = TEX_GBUFFER_COAT) uniform sampler2D gCoat;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(binding = TEX_SHADOW_ARRAY) uniform sampler2DArray shadowLayers; // raw depths
layout(binding = TEX_AREA_PATTERN) uniform sampler2D patternTable;
layout(binding = TEX_GBUFFER_ID) uniform usampler2D gId;

layout(location = OUT_COLOR) out vec4 oColor;
// The engine's variants define the layer count (LightShading::shadeDefines): a constant loop.
#ifndef AREA_LAYERS
#define AREA_LAYERS int(uLight.lightDoors.w + 0.5)
#endif
layout(early_fragment_tests) in;
layout(location = LOC_RELIGHT_OUTPUT) uniform int uOutput;
layout(location = LOC_RELIGHT_LINKED) uniform int uLinked;
layout(location = LOC_RELIGHT_PIXEL_STEP) uniform int uPixelStep;

// filteredShadowPlane (common_uniforms.glsl) on one layer of the grid: the same receiver-plane
// comparison per texel, (r+1)^2 gathers of four.
float filteredShadowLayer(ShadowLookup l, float layer) {
    int r = SHADE_PCF_RADIUS;
    float size = 1.0 / uLight.lightShadow.x;
    vec2 st = l.st - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    float sum = 0.0;
    for (int y = -r; y <= r; y += 2) {
        float wy0 = y == -r ? 1.0 - f.y : 1.0, wy1 = y == r ? f.y : 1.0;
        for (int x = -r; x <= r; x += 2) {
            float wx0 = x == -r ? 1.0 - f.x : 1.0, wx1 = x == r ? f.x : 1.0;
            vec4 d = textureGather(shadowLayers, vec3((base + vec2(x, y) + 1.0) / size, layer), 0);
            float r00 = l.ref + dot(l.slope, base + vec2(x, y) - st);
            vec4 refs = r00 + vec4(l.slope.y, l.slope.x + l.slope.y, l.slope.x, 0.0);
            sum += dot(step(refs, d), vec4(wx0 * wy1, wx1 * wy1, wx1 * wy0, wx0 * wy0));
        }
    }
    return sum / float((2 * r + 1) * (2 * r + 1));
}

// The visibility of the emitter from P: each layer's filtered comparison, weighted by how much its
// eye would light P unshadowed, w_k = max(Ng.l_k, 0) (-l_k.n) / d_k^2 (a Lambert receiver's
// share of the emitter around the eye), so that the parts of the emitter below P's horizon, which
// one-shot's lobes already leave out, neither shadow nor light it. Every layer shares the centre
// view's projection, its eye moved in the emitter's plane: in clip space only x and y move, by
// areaLayer[k].xy, so the centre's receiver-plane lookup moves by that over w in the map (the
// plane's depth slope is the centre's, exact for the depth, within the layer offset's parallax for
// the slope).
float areaVisibility(vec3 P, vec3 Ng) {
    vec3 c = uLight.lightPosition.xyz, n = uLight.lightAxis.xyz;
    if (dot(P - c, n) <= 0.0) return 0.0;
    float dist = max(length(P - c), 1e-6);
    vec3 L = (c - P) / dist;
    vec3 biased = P + Ng * shadowNormalOffset(dist);
    mat2x3 tf = tangentFrame(Ng);
    ShadowLookup l;
    if (!receiverPlaneLookup(biased, tf[0], tf[1], L * shadowLift(dist), l)) return 0.0;
    mat4 M = uLight.worldToLightClip;
    float w = dot(vec4(M[0][3], M[1][3], M[2][3], M[3][3]), vec4(biased, 1.0));
    float size = 1.0 / uLight.lightShadow.x;
    float sum = 0.0, weights = 0.0;
    ShadowLookup k = l;
    for (int i = 0; i < AREA_LAYERS; ++i) {
        vec4 layer = areaLayer[i];
        vec3 e = c + uLight.lightRight.xyz * layer.z + uLight.lightUp.xyz * layer.w - P;
        float e2 = max(dot(e, e), 1e-12);
        float wk = max(dot(Ng, e), 0.0) * max(-dot(e, n), 0.0) / (e2 * e2);
        if (wk <= 0.0) continue;
        k.st = l.st - layer.xy * (0.5 * size / w);
        float v = any(lessThan(k.st, vec2(0.0))) || any(greaterThan(k.st, vec2(size))) ? 1.0 : filteredShadowLayer(k, float(i));
        sum += wk * v;
        weights += wk;
    }
    return weights > 0.0 ? sum / weights : 0.0;
}

// The layered BRDF's two parts times N.L (common_brdf.glsl evaluateLayeredBrdfCos, whose sum they
// are for one direction): what one-shot's diffuse point shades (the base's Lambert lobe and the
// sheen) and what its specular point shades (the base's GGX lobe and the coat), both under the
// coat's and the sheen's attenuation of the base.
void layeredParts(vec3 N, vec3 L, vec3 V, vec3 albedo, vec4 brdf, vec4 sheen, vec2 coat, out vec3 diffuse, out vec3 spec) {
    diffuse = vec3(0.0);
    spec = vec3(0.0);
    float NdotL = dot(N, L);
    if (NdotL <= 0.0) return;
    float NdotV = max(dot(N, V), 1e-4);
    vec3 H = normalize(L + V);
    float NdotH = max(dot(N, H), 0.0);
    float VdotH = clamp(dot(V, H), 0.0, 1.0);
    float metallic = brdf.x, roughness = brdf.y, specular = brdf.z;
    float alpha = max(roughness * roughness, 1e-3);
    vec3 Fd = fresnelSchlick(vec3(0.08 * specular), min(2.0 * specular, 1.0), VdotH);
    vec3 Fm = fresnelSchlick(albedo, 1.0, VdotH);
    float maxFd = max(Fd.x, max(Fd.y, Fd.z));
    diffuse = ((1.0 - metallic) * (1.0 - maxFd)) * (albedo / PI) * NdotL;
    spec = mix(Fd, Fm, metallic) * (distributionGGX(NdotH, alpha) * visibilitySmithGGX(NdotL, NdotV, alpha)) * NdotL;
    if (SHADE_SHEEN && any(greaterThan(sheen.rgb, vec3(0.0)))) {
        float sheenAlpha = max(sheen.a * sheen.a, 1e-3);
        float scaling = 1.0 - max(max(sheen.r, sheen.g), sheen.b);
        diffuse = diffuse * scaling + sheen.rgb * distributionCharlie(NdotH, sheenAlpha) * visibilityNeubelt(NdotL, NdotV) * NdotL;
        spec *= scaling;
    }
    if (SHADE_COAT && coat.x > 0.0) {
        float ca = max(coat.y * coat.y, 1e-3);
        float Fc = 0.04 + 0.96 * pow(1.0 - clamp(NdotV, 0.0, 1.0), 5.0);
        float fc = Fc * distributionGGX(NdotH, ca) * visibilitySmithGGX(NdotL, NdotV, ca);
        diffuse *= 1.0 - coat.x * Fc;
        spec = spec * (1.0 - coat.x * Fc) + vec3(coat.x * fc * NdotL);
    }
}

// The layered BRDF (common_brdf.glsl evaluateLayeredBrdfCos) integrated over the uniform emitter
// of unit radiance by LTC: the base layer as Ltc.h ltcShading (specular (F0 norm + (F90 - F0)
// fresnel) E_spec, LTC 2016's Fresnel term; Lambert's form factor E_diff dimmed by the dielectric
// Fresnel at the light's mean direction), the coat exactly as a second lobe (its Fresnel is of
// N.v alone: coat F_c norm_c E_coat, the table at the coat's roughness), the sheen evaluated at
// the mean direction times the cosine's integral pi E_diff (an approximation: no LTC is fitted to
// the Charlie lobe). Both under the coat's and the sheen's attenuation of the base, as
// layeredParts.
vec3 ltcLayered(vec3 P, vec3 N, vec3 V, vec3 albedo, vec4 brdf, vec4 sheen, vec2 coat) {
    mat3 R = ltcShadingFrame(N, V);
    float NdotV = max(dot(N, V), 1e-4);
    vec3 ld, unused;
    float ed = ltcEmitterIntegral(R, P, false, vec4(0.0), ld);
    LtcLobe lobe = ltcLookup(brdf.y, NdotV);
    float es = ltcEmitterIntegral(R, P, true, lobe.m, unused);
    float metallic = brdf.x, specular = brdf.z;
    float f0d = 0.08 * specular, f90d = min(2.0 * specular, 1.0);
    vec3 F0 = mix(vec3(f0d), albedo, metallic);
    float F90 = mix(f90d, 1.0, metallic);
    vec3 spec = (F0 * lobe.amp.x + (vec3(F90) - F0) * lobe.amp.y) * es;
    vec3 Vl = R * V;
    float VdotH = clamp(dot(Vl, normalize(ld + Vl)), 0.0, 1.0);
    float maxFd = f0d + (f90d - f0d) * pow(1.0 - VdotH, 5.0);
    vec3 diffuse = ((1.0 - metallic) * (1.0 - maxFd) * ed) * albedo;
    if (SHADE_SHEEN && any(greaterThan(sheen.rgb, vec3(0.0)))) {
        vec3 L = transpose(R) * ld; // the shading frame's rows: its transpose turns back to world
        float NdotH = max(dot(N, normalize(L + V)), 0.0);
        float sheenAlpha = max(sheen.a * sheen.a, 1e-3);
        float scaling = 1.0 - max(max(sheen.r, sheen.g), sheen.b);
        vec3 fs = sheen.rgb * distributionCharlie(NdotH, sheenAlpha) * visibilityNeubelt(max(ld.z, 0.0), NdotV);
        diffuse = diffuse * scaling + fs * (PI * ed);
        spec *= scaling;
    }
    if (SHADE_COAT && coat.x > 0.0) {
        float Fc = 0.04 + 0.96 * pow(1.0 - clamp(NdotV, 0.0, 1.0), 5.0);
        LtcLobe cl = ltcLookup(coat.y, NdotV);
        float ec = ltcEmitterIntegral(R, P, true, cl.m, unused);
        diffuse *= 1.0 - coat.x * Fc;
        spec = spec * (1.0 - coat.x * Fc) + vec3(coat.x * Fc * cl.amp.x * ec);
    }
    // The pattern's mean over the emitter (Ltc.h ltcEmitterColour): the table's mean is over the
    // unit square, of which a disk covers pi / 4.
    vec3 colour = uLight.lightCube.xyz / (uLight.lightDoors.z > 0.5 ? 0.25 * PI : 1.0);
    return (diffuse + spec) * colour;
}

// (-l.n) / d^2 of the emitter point t seen from p, and l; 0 behind the emitter.
float emitterFactor(vec3 p, vec3 t, out vec3 l) {
    vec3 d = t - p;
    float d2 = max(dot(d, d), 1e-12);
    l = d * inversesqrt(d2);
    return max(-dot(l, uLight.lightAxis.xyz), 0.0) / d2;
}

vec3 shadeSample(ivec2 t) {
    vec4 pA = texelAt(gP, t);
    if (pA.w <= 0.0) return vec3(0.0);
    if (SHADE_LINKED && !objectLinked(texelFetch(gId, t, 0).x)) return vec3(0.0);
    vec3 P = pA.xyz;
    if (dot(P - uLight.lightPosition.xyz, uLight.lightAxis.xyz) <= 0.0) return vec3(0.0); // one-sided
    vec3 N = normalize(texelAt(gN, t).xyz);
    float vis = 1.0;
    if (SHADE_SHADOWED) {
        vis = areaVisibility(P, normalize(texelAt(gNg, t).xyz));
        if (SHADE_OUTPUT == 1) return vec3(vis * pA.w, pA.w, 0.0);
        if (vis <= 0.0) return vec3(0.0);
    } else if (SHADE_OUTPUT == 1) {
        return vec3(pA.w, pA.w, 0.0);
    }
    vec3 V = viewVector(P);
    vec3 albedo = texelAt(gAlbedo, t).rgb;
    vec4 brdf = texelAt(gBrdf, t), sheen = texelAt(gSheen, t);
    vec2 coat = texelAt(gCoat, t).xy;
    vec3 sum = vec3(0.0);
#ifdef AREA_REFERENCE
    int g = AREA_REFERENCE;
    for (int j = 0; j < g; ++j) {
        for (int i = 0; i < g; ++i) {
            vec2 lo = vec2(i, j) / float(g), hi = vec2(i + 1, j + 1) / float(g);
            vec3 I = uvBoxIntegral(patternTable, lo, hi);
            if (max(I.x, max(I.y, I.z)) <= 0.0) continue;
            vec2 uv = 0.5 * (lo + hi) - 0.5;
            vec3 q = uLight.lightPosition.xyz + uLight.lightRight.xyz * (uv.x * uLight.lightRight.w) +
                     uLight.lightUp.xyz * (uv.y * uLight.lightUp.w);
            vec3 l;
            float k = emitterFactor(P, q, l);
            if (k <= 0.0) continue;
            vec3 fd, fs;
            layeredParts(N, l, V, albedo, brdf, sheen, coat, fd, fs);
            sum += (fd + fs) * k * I;
        }
    }
#elif defined(AREA_LTC)
    sum = ltcLayered(P, N, V, albedo, brdf, sheen, coat);
#else
    float m = phongExponent(brdf.y);
    vec3 t1 = clampToEmitter(representativePoint(P, N, 1.0)), t2 = clampToEmitter(representativePoint(P, reflect(-V, N), m));
    vec3 l1, l2, fd, fs, unused;
    float k1 = emitterFactor(P, t1, l1), k2 = emitterFactor(P, t2, l2);
    if (k1 > 0.0) {
        layeredParts(N, l1, V, albedo, brdf, sheen, coat, fd, unused);
        sum += fd * k1 * boxIntegral(patternTable, t1, uLight.lightDoors.x * radiusLength(length(t1 - P)));
    }
    if (k2 > 0.0) {
        layeredParts(N, l2, V, albedo, brdf, sheen, coat, unused, fs);
        sum += fs * k2 * boxIntegral(patternTable, t2, uLight.lightDoors.y * radiusLength(length(t2 - P)) / m);
    }
#endif
    return sum * (vis * pA.w);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy) * max(uPixelStep, 1);
#ifdef DFB_FLAT_SAMPLES
    oColor = vec4(shadeSample(pixel), 1.0);
#else
    uvec2 range = texelFetch(gPixelSamples, pixel, 0).xy;
    vec3 sum = vec3(0.0);
    for (uint s = range.x; s < range.x + range.y; ++s) sum += shadeSample(sampleTexel(s));
    oColor = vec4(sum, 1.0);
#endif
}
