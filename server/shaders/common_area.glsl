// Area lights: the emitter's pattern table and one-shot's representative points, the GLSL mirror
// of server/include/dfb/lightmath/AreaLight.h (docs/lighting.md, "Area lights"; Wang, Lin, Li and
// Guo, "One-Shot Approximate Local Shading", 2008, "paper 001"), and the layers of its grid of
// shadow maps. Include after common_uniforms.glsl. The light block for an area light:
//   lightPosition.xyz = the emitter's centre, lightAxis.xyz = its normal (the emitting side),
//   lightRight = (right, width), lightUp = (up, height), lightDoors = (alpha, beta, 1 if a disk,
//   shadow layers),
//   lightCube.xyz = the pattern's mean (the table holds S - mean u v).

// Per shadow layer k: xy = what the layer's eye, offset in the emitter's plane, subtracts from the
// centre view's clip-space x and y; zw = the eye's place on the emitter along right and up, world
// units (ShadowMaps::renderArea).
// A uniform block: every sample reads the same layers, which llvmpipe loads once per pass instead
// of per lane as from a storage buffer.
layout(std140, binding = UBO_AREA_LAYERS) uniform AreaLayers { vec4 areaLayer[AREA_MAX_LAYERS]; };

// AreaLight.h representativePoint: the point of the emitter's plane maximising cos(pt, n)
// cos^m(pt, A) / |pt|^2 (paper 001 appendices A and B, eqs. 9, 10 and 12).
vec3 representativePoint(vec3 p, vec3 A, float m) {
    vec3 c = uLight.lightPosition.xyz, n = uLight.lightAxis.xyz;
    float h = dot(p - c, n);
    vec3 foot = p - n * h;
    float an = dot(A, n);
    vec3 along = A - n * an;
    float cosEta = length(along);
    if (cosEta < 1e-6) return foot;
    float eta = atan(-an, cosEta);
    float theta = 0.5 * (acos(clamp((m - 3.0) / (m + 3.0) * cosEta, -1.0, 1.0)) - eta);
    float phi = theta + eta;
    float s = sin(phi), co = cos(phi);
    float reach = 1e4 * max(uLight.lightRight.w, uLight.lightUp.w); // AreaLight.h areaReach
    float dist = s > 0.0 ? min(h * co / s, reach) : reach;
    return foot + along * (max(dist, 0.0) / cosEta);
}

// AreaLight.h clampToEmitter: the emitter's point nearest to the plane point t.
vec3 clampToEmitter(vec3 t) {
    vec3 d = t - uLight.lightPosition.xyz;
    vec2 xy = vec2(dot(d, uLight.lightRight.xyz), dot(d, uLight.lightUp.xyz));
    vec2 halfSize = 0.5 * vec2(uLight.lightRight.w, uLight.lightUp.w);
    if (uLight.lightDoors.z > 0.5) {
        float r = length(xy);
        if (r > halfSize.x) xy *= halfSize.x / r;
    } else {
        xy = clamp(xy, -halfSize, halfSize);
    }
    return uLight.lightPosition.xyz + uLight.lightRight.xyz * xy.x + uLight.lightUp.xyz * xy.y;
}

// AreaLight.h radiusLength (OneShotModel's saturating radius): d Re / sqrt(Re^2 + d^2), Re the
// emitter's diagonal.
float radiusLength(float d) {
    float re2 = uLight.lightRight.w * uLight.lightRight.w + uLight.lightUp.w * uLight.lightUp.w;
    return d * sqrt(re2 / (re2 + d * d));
}

// AreaLight.h phongExponent: GGX roughness to the Phong exponent of one-shot's specular radius.
float phongExponent(float roughness) {
    float alpha = max(roughness * roughness, 1e-3);
    return clamp((2.0 / (alpha * alpha) - 2.0) / 4.0, 1.0, 1e4);
}

// S(u, v) - mean u v of the pattern table (AreaLight.h satAt) at table coordinates x = u w,
// y = v h, bilinear in the corners by hand: hardware filtering's 8-bit weights would cost a box
// of a tenth of a texel 4 % of its value.
vec3 satCorner(sampler2D table, vec2 xy, ivec2 size) {
    vec2 c = clamp(xy, vec2(0.0), vec2(size - 1));
    ivec2 i = min(ivec2(c), size - 2);
    vec2 f = c - vec2(i);
    vec3 a = texelFetch(table, i, 0).rgb, b = texelFetch(table, i + ivec2(1, 0), 0).rgb;
    vec3 d = texelFetch(table, i + ivec2(0, 1), 0).rgb, e = texelFetch(table, i + ivec2(1, 1), 0).rgb;
    return mix(mix(a, b, f.x), mix(d, e, f.x), f.y);
}

// The emitter coordinates (u, v) of a point of its plane.
vec2 emitterUv(vec3 t) {
    vec3 d = t - uLight.lightPosition.xyz;
    return vec2(dot(d, uLight.lightRight.xyz) / uLight.lightRight.w, dot(d, uLight.lightUp.xyz) / uLight.lightUp.w) + 0.5;
}

// The pattern's integral over the uv box [lo, hi] clipped to the emitter, in world area units.
vec3 uvBoxIntegral(sampler2D table, vec2 lo, vec2 hi) {
    lo = clamp(lo, 0.0, 1.0);
    hi = clamp(hi, 0.0, 1.0);
    if (hi.x <= lo.x || hi.y <= lo.y) return vec3(0.0);
    ivec2 size = textureSize(table, 0);
    vec2 cells = vec2(size - 1);
    vec3 s = satCorner(table, hi * cells, size) - satCorner(table, vec2(lo.x, hi.y) * cells, size) -
             satCorner(table, vec2(hi.x, lo.y) * cells, size) + satCorner(table, lo * cells, size);
    vec2 span = hi - lo;
    // The mean's share (removed from the table: smaller numbers, finer rounding) comes back here.
    vec3 integral = s + uLight.lightCube.xyz * (span.x * span.y);
    return max(integral, vec3(0.0)) * (uLight.lightRight.w * uLight.lightUp.w);
}

// AreaLight.h boxIntegral: over the square of half-side r (world) around the plane point t.
vec3 boxIntegral(sampler2D table, vec3 t, float r) {
    vec2 uv = emitterUv(t);
    vec2 half_ = vec2(r / uLight.lightRight.w, r / uLight.lightUp.w);
    return uvBoxIntegral(table, uv - half_, uv + half_);
}
