#version 450 core
// One spot, point or directional light's contribution per pixel from the G-buffer samples
// (DESIGN section 6; docs/lighting.md): every sample of the pixel is shaded and the results
// averaged with their coverages. Radiance = f(l, v) * cos * I / d^2 * spot(cone) * doors * cookie
// * visibility, with I in candela (KHR_lights_punctual, with the smooth cone falloff of its
// reference implementation), or in lux without falloff for a directional light.
#include "common_uniforms.glsl"
#include "common_brdf.glsl"
#include "common_falloff.glsl"
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
layout(binding = TEX_SHADOW_CUBE) uniform samplerCube shadowCube; // raw depth: filteredShadowCube compares
layout(binding = TEX_COOKIE) uniform sampler2D cookie;

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

const int KIND_DIRECTIONAL = 0, KIND_POINT = 2;

// The point light's percentage-closer filter at direction `dir` (from the light) in the face the
// direction selects (the cube-map selection of the GL specification, section 8.13), on that face's
// texel grid: the same (r+1)^2 weighted four-texel gathers as filteredShadowPlane, each texel
// compared with the receiver plane (normal Ng, at signed distance h < 0 from the light) along the
// texel's own direction, lifted towards the light by `lift` (world; depth only). A texel's
// direction is ma + sa cx + ta cy (cx, cy its centre's face coordinates, beyond +-1 past an edge,
// where the seamless gather reads the next face): it meets the plane at view depth
// max(1, |cx|, |cy|) h / (direction . Ng) along its own major axis, which is the depth its face
// stored (past an edge the next face's texels sit up to a texel from this grid's extension).
float filteredShadowCube(vec3 dir, vec3 Ng, float h, float lift) {
    vec3 a = abs(dir);
    vec3 ma, sa, ta; // the face's axis and its s and t directions
    if (a.x >= a.y && a.x >= a.z) {
        ma = vec3(sign(dir.x), 0.0, 0.0);
        sa = vec3(0.0, 0.0, -sign(dir.x));
        ta = vec3(0.0, -1.0, 0.0);
    } else if (a.y >= a.z) {
        ma = vec3(0.0, sign(dir.y), 0.0);
        sa = vec3(1.0, 0.0, 0.0);
        ta = vec3(0.0, 0.0, sign(dir.y));
    } else {
        ma = vec3(0.0, 0.0, sign(dir.z));
        sa = vec3(sign(dir.z), 0.0, 0.0);
        ta = vec3(0.0, -1.0, 0.0);
    }
    float size = 1.0 / uLight.lightShadow.x, step1 = 2.0 / size;
    vec2 st = (vec2(dot(dir, sa), dot(dir, ta)) / dot(dir, ma) * 0.5 + 0.5) * size - 0.5;
    vec2 base = floor(st), f = st - base;
    float nA = dot(ma, Ng), nS = dot(sa, Ng), nT = dot(ta, Ng);
    float n = uLight.lightCube.x, fa = uLight.lightCube.y;
    int r = SHADE_PCF_RADIUS;
    float sum = 0.0;
    for (int y = -r; y <= r; y += 2) {
        float wy0 = y == -r ? 1.0 - f.y : 1.0, wy1 = y == r ? f.y : 1.0;
        for (int x = -r; x <= r; x += 2) {
            float wx0 = x == -r ? 1.0 - f.x : 1.0, wx1 = x == r ? f.x : 1.0;
            // Texels b .. b + (1, 1); gather order (x0 y1, x1 y1, x1 y0, x0 y0).
            vec2 b = base + vec2(x, y);
            vec2 corner = (b + 1.0) * step1 - 1.0;
            vec4 depth = textureGather(shadowCube, ma + sa * corner.x + ta * corner.y, 0);
            vec2 c0 = (b + 0.5) * step1 - 1.0;
            vec4 cx = c0.x + vec4(0.0, step1, step1, 0.0), cy = c0.y + vec4(step1, step1, 0.0, 0.0);
            vec4 dd = nA + cx * nS + cy * nT;
            vec4 major = max(vec4(1.0), max(abs(cx), abs(cy)));
            // Directions that never meet the plane (dd >= 0) compare as infinitely far: shadowed.
            vec4 viewDepth = mix(vec4(1e30), major * h / min(dd, vec4(-1e-30)), lessThan(dd, vec4(0.0)));
            vec4 refs = 0.5 * ((fa + n) / (fa - n) - (2.0 * fa * n / (fa - n)) / max(viewDepth - lift, vec4(1e-12))) + 0.5;
            sum += dot(step(refs, depth), vec4(wx0 * wy1, wx1 * wy1, wx1 * wy0, wx0 * wy0));
        }
    }
    return sum / float((2 * r + 1) * (2 * r + 1));
}

// t: the sample's texel, highest: its highest horizon sine (its near-field horizon).
float shadowVisibility(ivec2 t, vec3 P, vec3 Ng, float highest, vec3 L, float dist) {
    // Below the sample's geometric plane or its near-field horizon: shadowed by geometry the map
    // cannot resolve (issue 16: most leaks were on the bunny's terminator and at grazing contacts).
    vec3 biased;
    float lift;
    if (!nearFieldReceiver(t, P, Ng, highest, L, shadowNormalOffset(dist), shadowLift(dist), biased, lift)) return 0.0;
    if (SHADE_KIND == KIND_POINT) {
        // Point light: the filter on the cube face, each texel compared with the receiver plane
        // (filteredShadowCube; receiver-plane depth bias as filteredShadowPlane).
        vec3 d = biased - uLight.lightPosition.xyz;
        return filteredShadowCube(d, Ng, dot(d, Ng), lift);
    }
    return planarShadow(shadowMap, uLight.worldToLightClip, uLight.lightShadow.x, SHADE_PCF_RADIUS, biased, Ng, L, lift);
}

// Barn doors and cookie of a spot light, for the direction `fromLight` (unit, light to point):
// each flap cuts the light past its half-angle with a 0.5-degree soft edge; the cookie is
// projected across the cone (its edge circle inscribed in the image), the image's top towards the
// light's up.
vec2 cookieCoord(vec3 fromLight, float z) {
    return 0.5 + 0.5 * vec2(dot(fromLight, uLight.lightRight.xyz), dot(fromLight, uLight.lightUp.xyz)) / (z * uLight.lightUp.w);
}

vec3 spotMask(vec3 fromLight) {
    float z = dot(fromLight, uLight.lightAxis.xyz);
    if (z <= 0.0) return vec3(0.0);
    float doors = 1.0;
    if (SHADE_DOORS) doors = barnDoors(uLight.lightAxis.xyz, uLight.lightRight.xyz, uLight.lightUp.xyz, uLight.lightDoors, fromLight);
    vec3 mask = vec3(doors);
    if (SHADE_COOKIE && doors > 0.0) {
        mask *= texture(cookie, cookieCoord(fromLight, z)).rgb; // uploaded with the image's top row at t = 1
    }
    return mask;
}

// ---- Edges inside a pixel (common_pixel_footprint.glsl; docs/lighting.md) ----

// spotMask with explicit cookie gradients (gx, gy: texture coordinates per tap spacing): the
// implicit derivatives of a per-sample pass are between unrelated samples.
vec3 spotMaskGrad(vec3 fromLight, vec2 gx, vec2 gy) {
    float z = dot(fromLight, uLight.lightAxis.xyz);
    if (z <= 0.0) return vec3(0.0);
    float doors = 1.0;
    if (SHADE_DOORS) doors = barnDoors(uLight.lightAxis.xyz, uLight.lightRight.xyz, uLight.lightUp.xyz, uLight.lightDoors, fromLight);
    vec3 mask = vec3(doors);
    if (SHADE_COOKIE && doors > 0.0) mask *= textureGrad(cookie, cookieCoord(fromLight, z), gx, gy).rgb;
    return mask;
}

// The mean over the sample's footprint taps of the light's mask (cone x doors x cookie) times its
// visibility, each evaluated at the tap (shadowVisibility with the tap as the receiver). `vis`:
// the mean visibility alone; `reach` > 0 where some tap lies inside the mask (the shadow-mask
// output's samples the light reaches).
vec3 footprintLight(ivec2 t, vec3 P, vec3 Ng, float highest, float coverage, out float vis, out float reach) {
    mat2x3 fp = pixelFootprint(P, Ng, coverage);
    vec2 gx = vec2(0.0), gy = vec2(0.0);
    if (SHADE_KIND == 1 && SHADE_COOKIE) {
        // The cookie's footprint per tap: the pixel's, over the taps' spacing (1 / sqrt(taps) of it).
        vec3 S = uLight.lightPosition.xyz, axis = uLight.lightAxis.xyz;
        vec3 c = normalize(P - S), cx = normalize(P + fp[0] - S), cy = normalize(P + fp[1] - S);
        vec2 uv = cookieCoord(c, max(dot(c, axis), 1e-6));
        float spacing = inversesqrt(float(SHADE_FOOTPRINT_TAPS));
        gx = (cookieCoord(cx, max(dot(cx, axis), 1e-6)) - uv) * spacing;
        gy = (cookieCoord(cy, max(dot(cy, axis), 1e-6)) - uv) * spacing;
    }
    vec3 sum = vec3(0.0);
    float visSum = 0.0;
    reach = 0.0;
    for (int k = 0; k < SHADE_FOOTPRINT_TAPS; ++k) {
        vec3 q = P + footprintTap(fp, k);
        vec3 m = vec3(1.0);
        float dist = 1.0;
        vec3 L = -uLight.lightAxis.xyz;
        if (SHADE_KIND != KIND_DIRECTIONAL) {
            vec3 toLight = uLight.lightPosition.xyz - q;
            dist = max(length(toLight), 1e-6);
            L = toLight / dist;
            if (SHADE_KIND != KIND_POINT) {
                m = vec3(spotCone(uLight.lightCone.xy, L, uLight.lightAxis.xyz));
                if ((SHADE_DOORS || SHADE_COOKIE) && m.x > 0.0) m *= spotMaskGrad(-L, gx, gy);
            }
        }
        float v = SHADE_SHADOWED ? shadowVisibility(t, q, Ng, highest, L, dist) : 1.0;
        sum += m * v;
        visSum += v;
        reach = max(reach, max(m.x, max(m.y, m.z)));
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
    vec3 N = normalize(texelAt(gN, t).xyz);
    vec3 L;
    float dist2, dist;
    vec3 spot = vec3(1.0);
    if (SHADE_KIND == KIND_DIRECTIONAL) {
        // Directional (KHR_lights_punctual): parallel light, intensity in lux, no falloff.
        L = -uLight.lightAxis.xyz;
        dist2 = 1.0;
        dist = 1.0;
    } else {
        vec3 toLight = uLight.lightPosition.xyz - P;
        dist2 = max(dot(toLight, toLight), 1e-12);
        dist = sqrt(dist2);
        L = toLight / dist;
        if (SHADE_KIND != KIND_POINT && SHADE_FOOTPRINT_TAPS == 1) {
            // Cone falloff: smooth between the outer and inner cosines; then doors and cookie.
            spot = vec3(spotCone(uLight.lightCone.xy, L, uLight.lightAxis.xyz));
            if ((SHADE_DOORS || SHADE_COOKIE) && spot.x > 0.0) spot *= spotMask(-L);
        }
    }
    if (max(spot.x, max(spot.y, spot.z)) <= 0.0 || dot(N, L) <= 0.0) return vec3(0.0);
    float vis = 1.0;
    if (SHADE_FOOTPRINT_TAPS > 1) {
        // Edges inside the pixel: cone, doors, cookie and visibility over the footprint's taps.
        float reach;
        vec4 ng = texelAt(gNg, t);
        spot = footprintLight(t, P, normalize(ng.xyz), ng.w, pA.w, vis, reach);
        if (reach <= 0.0) return vec3(0.0);
        if (SHADE_OUTPUT == 1) return vec3(vis * pA.w, pA.w, 0.0);
        vis = 1.0; // in spot
    } else if (SHADE_SHADOWED) {
        vec4 ng = texelAt(gNg, t);
        vis = shadowVisibility(t, P, normalize(ng.xyz), ng.w, L, dist);
        if (vis <= 0.0 && SHADE_OUTPUT == 0) return vec3(0.0);
    }
    if (SHADE_OUTPUT == 1) return vec3(vis * pA.w, pA.w, 0.0);
    vec3 f = evaluateLayeredBrdfCos(N, L, viewVector(P), texelAt(gAlbedo, t).rgb, texelAt(gBrdf, t),
                                    texelAt(gSheen, t), texelAt(gCoat, t).xy);
    return f * spot * (vis * inverseSquare(dist2)) * pA.w;
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
