// Uniform blocks. Their C++ mirrors are in server/src/engine/GpuInterface.h, which pins every
// offset with static_assert; the texture units, bindings, locations and limits are written there
// once and come here as the #defines of the generated common_gpu_interface.glsl.
#include "common_gpu_interface.glsl"

layout(std430, binding = SSBO_LINK_MASK) readonly buffer LinkMask { uint linkMask[]; };
// uLinked (LOC_RELIGHT_LINKED): 1 when the light has include/exclude lists.
bool objectLinked(uint id) {
    uint word = id >> 5u;
    return word < uint(linkMask.length()) && (linkMask[word] & (1u << (id & 31u))) != 0u;
}

layout(std140, binding = UBO_LIGHT) uniform LightBlock {
    mat4 worldToLightClip;  // spot light's view-projection (shadow map space)
    vec4 lightPosition;     // xyz world position, w = kind: 0 directional, 1 spot, 2 point, 3 area, 4 environment
    vec4 lightAxis;         // xyz unit axis the light points along
    vec4 lightCone;         // x = cos(outer half-angle), y = cos(inner half-angle),
                            // z = 1 if shadowed, w = the receiver's lift towards the light
                            // per unit distance (world; depth only, see shadowLift)
    vec4 lightShadow;       // x = 1 / shadow-map size, y = PCF radius in texels, z = 1 if cube map,
                            // w = normal offset per unit distance (world; shadowBias texels)
    vec4 lightRight;        // xyz the spot's right (axis x up, as its shadow frustum), w = 1 if cookie
    vec4 lightUp;           // xyz the spot's up, w = tan(outer half-angle) (cookie mapping)
    vec4 lightDoors;        // barn doors: left, right, top, bottom half-angles in radians
    vec4 lightCube;         // point lights: x = near, y = far of the cube faces' projections;
                            // z = 1: a Lambertian emitter's cell (a bent area light's interior)
} uLight;

layout(std140, binding = UBO_VIEW) uniform ViewBlock {
    vec4 cameraPosition;    // xyz world position of the shot camera, w = 1 if orthographic
    vec4 cameraForward;     // xyz unit view direction (orthographic views use it as -V)
    vec4 exposure;          // x = 2^stops, y = 1 for the filmic view transform
    ivec4 sampleLayout;     // x = SAMPLE_ROW (width of the sample textures), y = log2 of it (deep buffers),
                            // z = edge taps per sample over its pixel footprint (1 = none)
    vec4 cameraRight;       // xyz unit image right, w = pixel width at unit depth (perspective) or in scene units
    vec4 cameraDown;        // xyz unit direction of increasing rows
    vec4 footprintTaps[FOOTPRINT_MAX_TAPS / 2]; // tap offsets in pixels from the centre, two per element
} uView;

// ---- Specialisation ----
// llvmpipe (Mesa 22) runs every path of a shader under a lane mask, taken or not, even where the
// condition is a uniform: a shader costs the sum of all its paths. So the engine compiles one
// variant of each relight shader per light configuration (LightShading::shadeDefines through
// ShaderVariants), defining these, and the paths the light cannot take are compiled out. Without
// them (tests that build a shader directly) the shaders decide from the uniforms at run time,
// with the same results.
#ifndef SHADE_KIND
#define SHADE_KIND int(uLight.lightPosition.w + 0.5) // 0 directional, 1 spot, 2 point, 3 area, 4 environment
#endif
#ifndef SHADE_SHADOWED
#define SHADE_SHADOWED (uLight.lightCone.z > 0.5)
#endif
#ifndef SHADE_PCF_RADIUS
#define SHADE_PCF_RADIUS int(uLight.lightShadow.y + 0.5)
#endif
#ifndef SHADE_COOKIE
#define SHADE_COOKIE (uLight.lightRight.w > 0.5)
#endif
#ifndef SHADE_DOORS
#define SHADE_DOORS true // a spot with a door under 90 degrees
#endif
#ifndef SHADE_LINKED
#define SHADE_LINKED (uLinked != 0)
#endif
#ifndef SHADE_OUTPUT
#define SHADE_OUTPUT uOutput
#endif

// Deep buffers' sample textures are a power of two wide (GBufferTextures): a mask and a shift, as integer
// division costs llvmpipe a loop over the lanes. (Flat buffers read samples at their pixels.)
ivec2 sampleTexel(uint s) { return ivec2(int(s) & (uView.sampleLayout.x - 1), int(s) >> uView.sampleLayout.y); }

// The texel of a contribution shaded with pixel step `step` (1, or 2 for a half-size preview)
// that covers `pixel`: a shift, not a division (see sampleTexel).
ivec2 previewTexel(ivec2 pixel, int step) { return pixel >> (step >> 1); }

// Texel p of a nearest-filtered texture (gl::makeTexture2D, makeTexture2DArray: the G-buffer's and
// the contributions' textures) read at its centre: texelFetch's value, which llvmpipe (Mesa 22.3)
// returns more slowly. At 960x540 the fused view transform's two RGBA32F reads took 1.2 ms less
// this way, and the environment's pass about 1 ms (docs/operations.md).
vec4 texelAt(sampler2D s, ivec2 p) { return textureLod(s, (vec2(p) + 0.5) / vec2(textureSize(s, 0)), 0.0); }
vec4 texelAt(sampler2DArray s, ivec3 p) {
    return textureLod(s, vec3((vec2(p.xy) + 0.5) / vec2(textureSize(s, 0).xy), float(p.z)), 0.0);
}

// A cached contribution (shaded at unit radiance) times its light's colour x intensity, capped at
// RADIANCE_LIMIT so that no sum or exposure of them overflows (composite_add.frag, the fused
// composite_tonemap.frag; Compositor::readFloat does the same on the CPU).
vec3 scaledContribution(vec3 unitRadiance, vec3 colourTimesIntensity) {
    return min(unitRadiance * colourTimesIntensity, vec3(RADIANCE_LIMIT));
}

vec3 viewVector(vec3 P) {
    return uView.cameraPosition.w > 0.5 ? -uView.cameraForward.xyz : normalize(uView.cameraPosition.xyz - P);
}

// The receiver's offset along its geometric normal Ng for the shadow lookup, world units, at
// distance `dist` from the light (1 for directional lights): shadowBias texels at every angle
// (the receiver plane's depth bias needs no more; why any: LightShading.cpp, lightBlock).
float shadowNormalOffset(float dist) { return dist * uLight.lightShadow.w; }

// The receiver's lift towards the light along the light ray (depth only), world units.
float shadowLift(float dist) { return dist * uLight.lightCone.w; }

// ---- Receiver-plane depth bias (Isidoro, "Shadow Mapping: GPU-based Tips and Techniques", GDC
// 2006) ----
// The G-buffer stores each sample's geometric normal, so the receiver's plane is known exactly
// instead of from screen-space derivatives: every texel the filter compares is compared with the
// plane's own depth at that texel's centre, not with the receiver's depth at its lookup point.
// A planar receiver then never shadows itself at any angle, and shadows are not pushed off their
// contacts by an offset (issue 16; docs/lighting.md, Shadows).
struct ShadowLookup {
    vec2 st;     // map coordinates in texels (texel centres at integer + 0.5)
    float ref;   // window depth of the receiver point
    vec2 slope;  // the receiver plane's window depth per texel along s and t
};

// The lookup of point q (world, or a BendyLight's straight space) on the receiver plane spanned by
// the tangents t1, t2 (the same space) in the 2D map M (of `size` texels a side): the projection's
// Jacobian (d ndc = (M_i - ndc_i M_w) dq / w) carries the tangents into the map, and the plane's
// depth gradient per texel solves the 2x2 system. `lift`: the receiver's lift towards the light
// (the same space), depth only. False where q is behind the projection.
bool receiverPlaneLookupIn(mat4 M, float size, vec3 q, vec3 t1, vec3 t2, vec3 lift, out ShadowLookup o) {
    vec4 clip = M * vec4(q, 1.0);
    o.st = vec2(0.0);
    o.ref = 1.0;
    o.slope = vec2(0.0);
    if (clip.w <= 0.0) return false;
    vec3 ndc = clip.xyz / clip.w;
    o.st = (ndc.xy * 0.5 + 0.5) * size;
    o.ref = ndc.z * 0.5 + 0.5;
    // Rows of M (GLSL matrices are column-major: row i is (M[0][i], M[1][i], M[2][i])).
    vec3 rw = vec3(M[0][3], M[1][3], M[2][3]);
    vec3 jx = (vec3(M[0][0], M[1][0], M[2][0]) - ndc.x * rw) * (0.5 * size / clip.w);
    vec3 jy = (vec3(M[0][1], M[1][1], M[2][1]) - ndc.y * rw) * (0.5 * size / clip.w);
    vec3 jz = (vec3(M[0][2], M[1][2], M[2][2]) - ndc.z * rw) * (0.5 / clip.w);
    o.ref += dot(jz, lift);
    vec2 a = vec2(dot(jx, t1), dot(jy, t1)), b = vec2(dot(jx, t2), dot(jy, t2));
    float za = dot(jz, t1), zb = dot(jz, t2);
    float det = a.x * b.y - a.y * b.x;
    // Edge-on to the light (det -> 0) the plane's depth per texel has no bound: clamp it, the
    // filter's far taps then decide by the plane's direction only.
    if (abs(det) > 1e-20) o.slope = clamp(vec2(za * b.y - zb * a.y, zb * a.x - za * b.x) / det, vec2(-1.0), vec2(1.0));
    return true;
}

// receiverPlaneLookupIn in the light's own map (uLight.worldToLightClip).
bool receiverPlaneLookup(vec3 q, vec3 t1, vec3 t2, vec3 lift, out ShadowLookup o) {
    return receiverPlaneLookupIn(uLight.worldToLightClip, 1.0 / uLight.lightShadow.x, q, t1, t2, lift, o);
}

// Two unit tangents of the plane with normal n.
mat2x3 tangentFrame(vec3 n) {
    vec3 t1 = normalize(cross(n, abs(n.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    return mat2x3(t1, cross(n, t1));
}

// Percentage-closer filter of radius r texels (the light's soft-shadow filter size,
// uLight.lightShadow.y) in `map` of `size` texels a side: the mean of the (2r+1)^2 bilinear
// comparisons at offsets -r..r texels. Those taps weigh the 2r+2 texels per axis from base - r to
// base + r + 1 by (1 - f, 1, ..., 1, f) (f the bilinear fraction), so the same sum comes from (r+1)^2 gathers of four texels with these
// weights: 4 texture reads instead of 9 at r = 1. Each texel is compared with the receiver
// plane's depth at its centre; `map` holds raw depths (no comparison mode), as one gather reads
// four depths where a comparison gather would read four results.
float filteredShadowPlaneIn(sampler2D map, float size, int r, ShadowLookup l) {
    vec2 st = l.st - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    float sum = 0.0;
    for (int y = -r; y <= r; y += 2) {
        float wy0 = y == -r ? 1.0 - f.y : 1.0, wy1 = y == r ? f.y : 1.0;
        for (int x = -r; x <= r; x += 2) {
            float wx0 = x == -r ? 1.0 - f.x : 1.0, wx1 = x == r ? f.x : 1.0;
            // Texels base + (x, y) .. base + (x + 1, y + 1); gather order (x0 y1, x1 y1, x1 y0, x0 y0).
            vec4 d = textureGather(map, (base + vec2(x, y) + 1.0) / size, 0);
            float r00 = l.ref + dot(l.slope, base + vec2(x, y) - st);
            vec4 refs = r00 + vec4(l.slope.y, l.slope.x + l.slope.y, l.slope.x, 0.0);
            sum += dot(step(refs, d), vec4(wx0 * wy1, wx1 * wy1, wx1 * wy0, wx0 * wy0));
        }
    }
    return sum / float((2 * r + 1) * (2 * r + 1));
}

// filteredShadowPlaneIn in the light's own map at its own filter radius.
float filteredShadowPlane(sampler2D map, ShadowLookup l) {
    return filteredShadowPlaneIn(map, 1.0 / uLight.lightShadow.x, SHADE_PCF_RADIUS, l);
}
