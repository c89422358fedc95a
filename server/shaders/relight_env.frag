#version 450 core
// An environment light's contribution per pixel from the G-buffer samples (docs/lighting.md,
// "Environment light"), at unit radiance (the composite scales by colour x intensity):
// - diffuse = (1 - metallic)(1 - F_d(N.v)) albedo sum_i L_i T_i: the map's spherical harmonics
//   L (UBO_ENV_SH: projected once per map on the CPU, Environment.h envProjectSh, and turned by
//   the light's rotation, SphericalHarmonics.h shRotate25) against the
//   sample's diffuse transfer T (ENV_BANDS bands), its baked visibility when the light is
//   shadowed and the shot has one (precomputed radiance transfer: Sloan, Kautz and Snyder 2002),
//   else the unshadowed clamped cosine (Ramamoorthi and Hanrahan 2001);
// - specular = the prefiltered map at the mirror direction and the lobe's roughness times
//   F0 A + F90 B from the DFG table (the split sum: Karis 2013), with KHR_materials_specular's
//   F0 and F90 as common_brdf.glsl, and for shadowed lights the shot's baked specular lobe
//   (ENV_LOBE: read towards its visible part, scaled by its visible share; ENV_RINGS: each of its
//   rings' visible parts read on its own, towards its mean direction and as wide as it), or
//   without one a specular occlusion from the transfer (directionalVisibility);
// - clear coat: its own GGX lobe on top, the base attenuated by 1 - coat Fc(N.v) as
//   evaluateLayeredBrdfCos; sheen scales the base as there (the sheen lobe's own reflection of
//   the environment is left out);
// - the suns taken out of the map (engine extractSuns): directional lights of unit intensity
//   weighted by their irradiance, each with its own shadow map, shaded as relight_spot.frag
//   shades a directional light, in this pass (one read of the sample for all of them).
#include "common_uniforms.glsl"
#include "common_brdf.glsl"
#include "common_env.glsl"
#include "common_pixel_footprint.glsl"
#include "common_horizon.glsl"

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_ALBEDO) uniform sampler2D gAlbedo;
layout(binding = TEX_GBUFFER_BRDF) uniform sampler2D gBrdf;
layout(binding = TEX_GBUFFER_SHEEN) uniform sampler2D gSheen;
layout(binding = TEX_GBUFFER_COAT) uniform sampler2D gCoat;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(binding = TEX_GBUFFER_ID) uniform usampler2D gId;
layout(binding = TEX_ENV_PREFILTERED) uniform samplerCube envPrefiltered; // ENV_LEVELS mips by roughness
layout(binding = TEX_ENV_DFG) uniform sampler2D envDfg;                 // (A, B) by (N.v, roughness)
layout(binding = TEX_ENV_IRRADIANCE) uniform sampler2D envIrradiance;   // E(N) / pi less the expansion, by map-frame normal
#ifdef ENV_TRANSFER
// ENV_BANDS: the shot's transfer's bands, 3 or 5 (DeepBuffer::envBands). Its ENV_COEFFS values,
// then the lobe's u, v, share (ENV_LOBE), four per layer over ENV_LAYERS layers (both defined by
// LightShading from GBufferTextures: envBands, envTransferLayers); then with ENV_RINGS the lobe's
// rings, ring r's u, v, share, roughness at layer ENV_LAYERS + r.
#define ENV_COEFFS (ENV_BANDS * ENV_BANDS)
layout(binding = TEX_GBUFFER_ENV) uniform sampler2DArray gEnv;
#else
#define ENV_COEFFS 9
#endif
#if ENV_COEFFS == 25
#define shOpenTransfer shUnshadowedTransfer25
#else
#define shOpenTransfer shUnshadowedTransfer
#endif
layout(std140, binding = UBO_ENV_SH) uniform EnvShBlock { vec4 envSh[25]; }; // rgb L_i of the turned map, five bands

// The map's suns (GpuInterface.h EnvSunData): ENV_SUNS of them, a specialisation (LightShading),
// else the block's count.
struct EnvSun {
    mat4 worldToLightClip; // its shadow map's projection
    vec4 toSun;            // xyz unit direction towards it, w = 1 / its map's size
    vec4 weight;           // rgb its irradiance at normal incidence
    vec4 shadow;           // x = normal offset, y = lift towards it (world), z = 1 if it has a map,
                           // w = its filter radius
};
layout(std140, binding = UBO_ENV_SUNS) uniform EnvSunBlock {
    EnvSun envSun[ENV_SUN_SLOTS];
    ivec4 envSunCount;
};
// Raw depths, one sampler each: llvmpipe (Mesa 22) fails to compile a gather from an indexed
// sampler array.
#if ENV_SUN_SLOTS != 3
#error "sunsRadiance shades ENV_SUN_SLOTS suns, one call each"
#endif
layout(binding = TEX_ENV_SUN_MAPS) uniform sampler2D envSunMap0;
layout(binding = TEX_ENV_SUN_MAPS + 1) uniform sampler2D envSunMap1;
layout(binding = TEX_ENV_SUN_MAPS + 2) uniform sampler2D envSunMap2;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
#ifndef ENV_SUNS
#define ENV_SUNS envSunCount.x
#endif
// The suns' filter radius (engine environmentSun), a specialisation like ENV_SUNS.
#ifndef ENV_SUN_FILTER
#define ENV_SUN_FILTER int(envSun[0].shadow.w)
#endif

layout(location = OUT_COLOR) out vec4 oColor;
layout(early_fragment_tests) in;
layout(location = LOC_RELIGHT_OUTPUT) uniform int uOutput;
layout(location = LOC_RELIGHT_LINKED) uniform int uLinked;
layout(location = LOC_RELIGHT_PIXEL_STEP) uniform int uPixelStep;

// The map's radiance towards `dirWorld` prefiltered for `roughness`: worldToLightClip holds the
// world-to-map rotation (R^T of envRotation). A cube map (Cookies::environment), filtered across
// its faces' edges (GL_TEXTURE_CUBE_MAP_SEAMLESS, enabled by GlEngine::init).
vec3 prefiltered(vec3 dirWorld, float roughness) {
    return textureLod(envPrefiltered, mat3(uLight.worldToLightClip) * dirWorld, roughness * float(ENV_LEVELS - 1)).rgb;
}

// The direction a GGX lobe of `roughness` mostly reads: from the mirror direction towards N as
// roughness grows (Lagarde and de Rousiers 2014, section 4.9.3, getSpecularDominantDir).
vec3 dominantDirection(vec3 N, vec3 V, float roughness) {
    float a = roughness * roughness;
    return normalize(mix(N, reflect(-V, N), (1.0 - a) * (sqrt(1.0 - a) + a)));
}

// Specular occlusion from the baked transfer's first three bands (G-buffer env.sh0..8): how much
// of the open hemisphere's clamped cosine the sample's visibility lets through towards `d`, the
// ratio of the shadowed to the unshadowed order-3 transfer functions evaluated there (both
// band-limited the same way; Sloan, Kautz and Snyder, "Precomputed Radiance Transfer", 2002, for the transfer
// vectors). Unlike the ambient-visibility formula (Lagarde and de Rousiers 2014, eq. 34) it knows
// where the opening is: the inside of a bowl sees the sky above it and not the bowl's wall. On the
// tabletop at 320x180 against the ray-traced reference it took the specular mean error from
// 67 / 87 / 131 % to 27 / 31 / 59 % (sunrise / interior / courtyard; dfb-env-bench).
float directionalVisibility(float T[ENV_COEFFS], float open[ENV_COEFFS], vec3 d) {
    float y[9];
    shEvaluate(d, y);
    float shadowed = 0.0, unshadowed = 0.0;
    for (int i = 0; i < 9; ++i) {
        shadowed += T[i] * y[i];
        unshadowed += open[i] * y[i];
    }
    return clamp(shadowed / max(unshadowed, 1e-3), 0.0, 1.0);
}

// Specular occlusion from the ambient visibility (Lagarde and de Rousiers, "Moving Frostbite to
// Physically Based Rendering", 2014, eq. 34 / listing 26).
float ambientSpecularOcclusion(float NdotV, float visibility, float roughness) {
    float alpha = max(roughness * roughness, 1e-3);
    return clamp(pow(NdotV + visibility, exp2(-16.0 * alpha - 1.0)) - 1.0 + visibility, 0.0, 1.0);
}

// The split sum's second factor (Karis 2013): F0 A + F90 B from the DFG table.
vec3 splitSumScale(float NdotV, float roughness, vec3 f0, float f90) {
    vec2 ab = texture(envDfg, vec2(NdotV, roughness)).rg;
    return f0 * ab.x + vec3(f90 * ab.y);
}

// The split sum of a GGX lobe (Karis 2013): prefiltered radiance x (F0 A + F90 B), read towards
// `d`: the lobe's dominant direction (dominantDirection), or for shadowed lights the baked
// direction of its visible part (ENV_LOBE).
vec3 specularLobe(vec3 d, float NdotV, float roughness, vec3 f0, float f90) {
    return prefiltered(d, roughness) * splitSumScale(NdotV, roughness, f0, f90);
}

#ifdef ENV_RINGS
// The baked lobe's rings (DeepBuffer::envRings): the lobe's GGX samples split by their half
// vector's polar coordinate, each ring's visible part read from the prefiltered map towards its
// mean direction at the roughness whose kernel is as wide as it, weighted by its share of the
// lobe, times F0 A + F90 B. One read of the whole lobe cannot hold a grazing lobe's peak near the
// mirror direction and its tail towards the horizon at once (docs/lighting.md, "Environment
// light"; the tabletop's specular error 11.4 / 16.6 % -> the figures there).
vec3 ringsSpecular(ivec2 t, float NdotV, float roughness, vec3 f0, float f90) {
    vec3 sum = vec3(0.0);
    for (int r = 0; r < ENV_LOBE_RINGS; ++r) {
        vec4 ring = texelAt(gEnv, ivec3(t, ENV_LAYERS + r));
        sum += prefiltered(octDecode(ring.xy), ring.w) * ring.z;
    }
    return sum * splitSumScale(NdotV, roughness, f0, f90);
}
#endif

// Sun k's visibility at receiver point q of the sample at texel t (geometric normal Ng, highest
// horizon sine `highest`), towards L: relight_spot.frag's shadowVisibility for a directional light
// (dist 1), in the sun's own map and filter radius (ENV_SUN_FILTER: environmentSun's shadowFilter).
float sunVisibility(int k, sampler2D map, ivec2 t, vec3 q, vec3 Ng, float highest, vec3 L) {
    vec3 biased;
    float lift;
    if (!nearFieldReceiver(t, q, Ng, highest, L, envSun[k].shadow.x, envSun[k].shadow.y, biased, lift)) return 0.0;
    return planarShadow(map, envSun[k].worldToLightClip, envSun[k].toSun.w, ENV_SUN_FILTER, biased, Ng, L, lift);
}

// Sun k's radiance at the sample (unit coverage; its map `map`), as relight_spot.frag shades a
// directional light: the layered BRDF times its visibility, over the sample's pixel footprint's
// taps `fp` when the shot has them (footprintLight), times its irradiance.
vec3 sunRadiance(int k, sampler2D map, ivec2 t, vec3 P, vec4 ng, mat2x3 fp, vec3 N, vec3 V, vec3 albedo, vec4 brdf, vec4 sheen,
                 vec2 coat) {
    vec3 L = envSun[k].toSun.xyz;
    if (dot(N, L) <= 0.0) return vec3(0.0);
    float vis = 1.0;
    if (SHADE_SHADOWED && envSun[k].shadow.z > 0.5) {
        vec3 Ng = normalize(ng.xyz);
        if (SHADE_FOOTPRINT_TAPS > 1) {
            vis = 0.0;
            for (int j = 0; j < SHADE_FOOTPRINT_TAPS; ++j) vis += sunVisibility(k, map, t, P + footprintTap(fp, j), Ng, ng.w, L);
            vis /= float(SHADE_FOOTPRINT_TAPS);
        } else {
            vis = sunVisibility(k, map, t, P, Ng, ng.w, L);
        }
    }
    if (vis <= 0.0) return vec3(0.0);
    return envSun[k].weight.rgb * evaluateLayeredBrdfCos(N, L, V, albedo, brdf, sheen, coat) * vis;
}

// The suns' radiance at the sample (unit coverage): ENV_SUNS of them, a constant in the engine's
// variants, so the calls past it compile out.
vec3 sunsRadiance(ivec2 t, vec3 P, vec3 N, vec3 V, float coverage, vec3 albedo, vec4 brdf, vec4 sheen, vec2 coat) {
    vec4 ng = texelAt(gNg, t);
    mat2x3 fp = mat2x3(0.0);
    if (SHADE_SHADOWED && SHADE_FOOTPRINT_TAPS > 1) fp = pixelFootprint(P, normalize(ng.xyz), coverage);
    vec3 sum = vec3(0.0);
    if (ENV_SUNS > 0) sum += sunRadiance(0, envSunMap0, t, P, ng, fp, N, V, albedo, brdf, sheen, coat);
    if (ENV_SUNS > 1) sum += sunRadiance(1, envSunMap1, t, P, ng, fp, N, V, albedo, brdf, sheen, coat);
    if (ENV_SUNS > 2) sum += sunRadiance(2, envSunMap2, t, P, ng, fp, N, V, albedo, brdf, sheen, coat);
    return sum;
}

vec3 shadeSample(ivec2 t) {
    vec4 pA = texelAt(gP, t);
    if (pA.w <= 0.0) return vec3(0.0);
    if (SHADE_LINKED && !objectLinked(texelFetch(gId, t, 0).x)) return vec3(0.0); // light linking
    vec3 N = normalize(texelAt(gN, t).xyz);
    vec3 V = viewVector(pA.xyz);
    float visibility = 1.0;
#ifdef ENV_TRANSFER
    float T[ENV_COEFFS]; // the baked transfer, read only for shadowed lights
    vec4 last = vec4(0.0); // the last layer: T_{n-1}, the specular lobe's u, v, share (ENV_LOBE)
    if (SHADE_SHADOWED) {
        for (int k = 0; k < ENV_LAYERS; ++k) {
            vec4 v = texelAt(gEnv, ivec3(t, k));
            for (int c = 0; c < 4; ++c)
                if (4 * k + c < ENV_COEFFS) T[4 * k + c] = v[c];
            last = v;
        }
        // The ambient visibility: T_0 / Y_0 (1 where the whole hemisphere sees the map).
        visibility = clamp(T[0] / 0.282094791773878, 0.0, 1.0);
    }
#endif
    if (SHADE_OUTPUT == 1) return vec3(visibility * pA.w, pA.w, 0.0);
    // The map's exact unshadowed irradiance at N, times the spherical harmonics' share of it that
    // the sample's visibility lets through (1 unshadowed): open surfaces are exact, and only the
    // visibility is band-limited, to the shot's ENV_BANDS (docs/lighting.md, "Environment light").
    // The exact irradiance is the order-3 expansion plus the residual grid, which holds what
    // those nine miss.
    float open[ENV_COEFFS];
    shOpenTransfer(N, open);
    vec3 unshadowed = vec3(0.0), unshadowed9 = vec3(0.0);
    for (int i = 0; i < ENV_COEFFS; ++i) {
        unshadowed += envSh[i].rgb * open[i];
        if (i == 8) unshadowed9 = unshadowed;
    }
    // The grid is in the map's frame (read at R^T N: a rotation turns where it is read) and its
    // rows run from pole to pole inclusive (envIrradianceNormal).
    vec2 uv = envLatLong(normalize(mat3(uLight.worldToLightClip) * N));
    float rows = float(ENV_IRRADIANCE_WIDTH / 2);
    vec3 residual = texture(envIrradiance, vec2(uv.x, (uv.y * (rows - 1.0) + 0.5) / rows)).rgb;
    vec3 irradiance = max(unshadowed9 + residual, vec3(0.0));
#ifdef ENV_TRANSFER
    if (SHADE_SHADOWED) {
        vec3 shadowed = vec3(0.0);
        for (int i = 0; i < ENV_COEFFS; ++i) shadowed += envSh[i].rgb * T[i];
        irradiance *= clamp(shadowed / max(unshadowed, vec3(1e-6)), 0.0, 1.0);
    }
#endif

    vec3 albedo = texelAt(gAlbedo, t).rgb;
    vec4 brdf = texelAt(gBrdf, t);
    float metallic = brdf.x, roughness = brdf.y, specular = brdf.z;
    float NdotV = clamp(dot(N, V), 1e-4, 1.0);
    vec3 Fd = fresnelSchlick(vec3(0.08 * specular), min(2.0 * specular, 1.0), NdotV);
    float maxFd = max(Fd.x, max(Fd.y, Fd.z));
    vec3 diffuse = ((1.0 - metallic) * (1.0 - maxFd)) * albedo * irradiance;
    vec3 f0 = mix(vec3(0.08 * specular), albedo, metallic);
    float f90 = mix(min(2.0 * specular, 1.0), 1.0, metallic);
    // Specular occlusion: the baked lobe's visible share, or towards the lobe from the baked
    // transfer (directionalVisibility), or from the ambient visibility (1 where nothing is baked).
    float occlusion;
    vec3 lobeDirection = dominantDirection(N, V, roughness);
#ifdef ENV_TRANSFER
    if (!SHADE_SHADOWED) occlusion = ambientSpecularOcclusion(NdotV, visibility, roughness);
    else {
#ifdef ENV_LOBE
        // The lobe as the shot's camera sees it, baked against the scene (DeepBuffer::envLobe):
        // the map read towards its visible part's mean direction, scaled by the visible share.
        // On the tabletop against the ray-traced reference (320x180, 256 rays) the specular mean
        // error went from 27 / 31 / 59 % (directionalVisibility) to the figures in
        // docs/lighting.md, "Environment light".
        lobeDirection = octDecode(last.yz);
        occlusion = last.w;
#else
        occlusion = directionalVisibility(T, open, lobeDirection);
#endif
    }
#else
    occlusion = ambientSpecularOcclusion(NdotV, visibility, roughness);
#endif
#ifdef ENV_RINGS
    vec3 specularTerm = SHADE_SHADOWED ? ringsSpecular(t, NdotV, roughness, f0, f90)
                                       : specularLobe(lobeDirection, NdotV, roughness, f0, f90) * occlusion;
#else
    vec3 specularTerm = specularLobe(lobeDirection, NdotV, roughness, f0, f90) * occlusion;
#endif
    vec3 base = diffuse + specularTerm;
    vec4 sheen = texelAt(gSheen, t);
    if (SHADE_SHEEN && any(greaterThan(sheen.rgb, vec3(0.0)))) base *= 1.0 - max(max(sheen.r, sheen.g), sheen.b);
    vec2 coat = texelAt(gCoat, t).xy;
    if (SHADE_COAT && coat.x > 0.0) {
        float Fc = 0.04 + 0.96 * pow(1.0 - NdotV, 5.0);
        float coatOcclusion = ambientSpecularOcclusion(NdotV, visibility, coat.y);
        base = base * (1.0 - coat.x * Fc) + coat.x * specularLobe(dominantDirection(N, V, coat.y), NdotV, coat.y, vec3(0.04), 1.0) * coatOcclusion;
    }
    if (SHADE_OUTPUT == 0 && ENV_SUNS > 0) base += sunsRadiance(t, pA.xyz, N, V, pA.w, albedo, brdf, sheen, coat);
    return base * pA.w;
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
