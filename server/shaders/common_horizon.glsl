// The near-field horizon (include-only): the mirror of server/include/dfb/lightmath/Horizon.h,
// read line for line the same (tests/gpu/engine_horizon_test.cpp holds the two to one answer).
// A sample's horizon is baked once (DeepBuffer::horizon): per azimuth about its geometric normal,
// the sine of the lowest elevation open to the sky within a short reach. Light arriving below it
// is shadowed by geometry closer than a shadow map resolves (docs/lighting.md, "Shadows").
// NEAR_FIELD_HORIZON is defined when the shot holds one, NEAR_FIELD_REACH its reach in scene
// units (LightShading); without them only the geometric plane is tested.

layout(binding = TEX_GBUFFER_HORIZON) uniform sampler2DArray gHorizon;

// The frame the azimuths are measured in (Duff et al., "Building an Orthonormal Basis,
// Revisited", JCGT 2017), branching on n.z >= 0 as horizonFrame does.
void horizonFrame(vec3 n, out vec3 t, out vec3 b) {
    float sign = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x);
    b = vec3(c, sign + n.y * n.y * a, -n.y);
}

// The horizon's elevation sine towards L at sample texel `texel`: linear in azimuth between the
// two stored azimuths around L's (azimuth k at layer k / 4, component k % 4).
float horizonSine(ivec2 texel, vec3 n, vec3 L) {
    vec3 t, b;
    horizonFrame(n, t, b);
    float x = dot(L, t), y = dot(L, b);
    if (x == 0.0 && y == 0.0) return 0.0; // along the normal: above every horizon
    float u = atan(y, x) * (float(HORIZON_AZIMUTH_COUNT) / 6.283185307179586);
    if (u < 0.0) u += float(HORIZON_AZIMUTH_COUNT);
    int k0 = int(u) % HORIZON_AZIMUTH_COUNT, k1 = (k0 + 1) % HORIZON_AZIMUTH_COUNT;
    float f = u - floor(u);
    float h0 = texelAt(gHorizon, ivec3(texel, k0 / 4))[k0 % 4];
    float h1 = texelAt(gHorizon, ivec3(texel, k1 / 4))[k1 % 4];
    return h0 + f * (h1 - h0);
}

// 1 where light from the unit direction L reaches the sample at `texel` (geometric normal Ng)
// past its near field, else 0 (horizonLit): above its geometric plane (a facet facing away from
// the light is shadowed by itself; the shadow map holds closed meshes' far sides only, which
// cannot say so) and, with NEAR_FIELD_HORIZON, above its horizon. `highest`: the sample's highest
// horizon sine (TEX_GBUFFER_NG's w): a light above it is above the interpolated horizon too, and
// most samples of a shot (open ground, convex surfaces) skip the lookup.
float nearFieldVisibility(ivec2 texel, vec3 Ng, float highest, vec3 L) {
    float e = dot(Ng, L);
    if (e <= 0.0) return 0.0;
#ifdef NEAR_FIELD_HORIZON
    if (e <= highest && e <= horizonSine(texel, Ng, L)) return 0.0;
#endif
    return 1.0;
}

// The receiver's lift towards the light along the light ray (depth only; shadowLift gives the
// one-texel `lift` at the receiver's distance), for a receiver whose geometric normal makes the
// cosine NgL > 0 with the light. With a horizon, occluders within its reach are its to shadow,
// so a grazing receiver is lifted by NEAR_FIELD_LIFT_SLOPE texels / NgL, up to the reach: its
// plane's depth climbs 1 / NgL texels per texel across the map, and its own curved mesh's facets
// within that climb would shadow it falsely. Measured against ray-traced shadows (the Stanford
// dragon alone under a sun, 480x270): false shadows 83 -> 34 pixels at 0.5 texel, with leaks
// 23 -> 24; at 1 texel 30 and 25, but the tabletop's point light leaks 31 -> 41; at 2 the
// tabletop's point light is 2.2 % short.
const float NEAR_FIELD_LIFT_SLOPE = 0.5;
float nearFieldLift(float lift, float NgL) {
#ifdef NEAR_FIELD_HORIZON
    return max(lift, min(NEAR_FIELD_LIFT_SLOPE * lift / NgL, NEAR_FIELD_REACH));
#else
    return lift;
#endif
}

// The receiver for a shadow-map lookup from the sample at `texel` (receiver point q, geometric
// normal Ng, highest horizon sine `highest`) towards the unit direction L: false where its near
// field shadows it (nearFieldVisibility), else q moved along Ng by `normalOffset` (`biased`) and
// its lift towards the light (nearFieldLift of the one-texel `lift`). Spot, point and directional
// lights (relight_spot.frag) and an environment's suns (relight_env.frag).
bool nearFieldReceiver(ivec2 texel, vec3 q, vec3 Ng, float highest, vec3 L, float normalOffset, float lift, out vec3 biased,
                       out float lifted) {
    biased = q + Ng * normalOffset;
    lifted = nearFieldLift(lift, dot(Ng, L));
    return nearFieldVisibility(texel, Ng, highest, L) > 0.0;
}

// The visibility of that receiver in the 2D map M (raw depths in `map`, 1 / its size `invSize`),
// filtered over radius r texels: 1 outside the map, 0 behind its projection
// (receiverPlaneLookupIn, filteredShadowPlaneIn).
float planarShadow(sampler2D map, mat4 M, float invSize, int r, vec3 biased, vec3 Ng, vec3 L, float lifted) {
    mat2x3 tf = tangentFrame(Ng);
    ShadowLookup l;
    if (!receiverPlaneLookupIn(M, 1.0 / invSize, biased, tf[0], tf[1], L * lifted, l)) return 0.0;
    if (any(lessThan(l.st, vec2(0.0))) || any(greaterThan(l.st * invSize, vec2(1.0)))) return 1.0;
    return filteredShadowPlaneIn(map, 1.0 / invSize, r, l);
}
