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
    vec4 lightPosition;     // xyz world position, w = kind: 0 directional, 1 spot, 2 point
    vec4 lightAxis;         // xyz unit axis the light points along
    vec4 lightCone;         // x = cos(outer half-angle), y = cos(inner half-angle),
                            // z = 1 if shadowed, w = normal offset per unit distance at
                            // grazing incidence (world; times sin(theta))
    vec4 lightShadow;       // x = 1 / shadow-map size, y = PCF radius in texels, z = 1 if cube map,
                            // w = constant normal offset per unit distance (world)
    vec4 lightRight;        // xyz the spot's right (axis x up, as its shadow frustum), w = 1 if cookie
    vec4 lightUp;           // xyz the spot's up, w = tan(outer half-angle) (cookie mapping)
    vec4 lightDoors;        // barn doors: left, right, top, bottom half-angles in radians
    vec4 lightCube;         // point lights: x = near, y = far of the cube faces' projections
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
#define SHADE_KIND int(uLight.lightPosition.w + 0.5) // 0 directional, 1 spot, 2 point
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

// A cached contribution (shaded at unit radiance) times its light's colour x intensity, capped at
// RADIANCE_LIMIT so that no sum or exposure of them overflows (composite_add.frag, the fused
// composite_tonemap.frag; Compositor::readFloat does the same on the CPU).
vec3 scaledContribution(vec3 unitRadiance, vec3 colourTimesIntensity) {
    return min(unitRadiance * colourTimesIntensity, vec3(RADIANCE_LIMIT));
}

vec3 viewVector(vec3 P) {
    return uView.cameraPosition.w > 0.5 ? -uView.cameraForward.xyz : normalize(uView.cameraPosition.xyz - P);
}

// The receiver's offset along its geometric normal Ng for the shadow lookup, world units, for the
// unit direction L towards the light at distance `dist` (1 for directional lights): k texels
// times sin(theta), theta between Ng and L (normal offset that follows the receiver), plus a
// constant for deformed maps (why both: LightShading.cpp, lightBlock).
float shadowNormalOffset(vec3 Ng, vec3 L, float dist) {
    float c = clamp(dot(Ng, L), 0.0, 1.0);
    return dist * (uLight.lightCone.w * sqrt(1.0 - c * c) + uLight.lightShadow.w);
}

// Percentage-closer filter of radius uLight.lightShadow.y texels: the mean of the (2r+1)^2
// bilinear comparisons at offsets -r..r texels, the light's soft-shadow filter size. Those taps
// weigh the 2r+2 texels per axis from base - r to base + r + 1 by (1 - f, 1, ..., 1, f) (f the
// bilinear fraction), so the same sum comes from (r+1)^2 four-texel comparison gathers with these
// weights: 4 texture reads instead of 9 at r = 1.
float filteredShadow(sampler2DShadow map, vec2 uv, float ref) {
    int r = SHADE_PCF_RADIUS;
    float size = 1.0 / uLight.lightShadow.x;
    vec2 st = uv * size - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    float sum = 0.0;
    for (int y = -r; y <= r; y += 2) {
        float wy0 = y == -r ? 1.0 - f.y : 1.0, wy1 = y == r ? f.y : 1.0;
        for (int x = -r; x <= r; x += 2) {
            float wx0 = x == -r ? 1.0 - f.x : 1.0, wx1 = x == r ? f.x : 1.0;
            // Texels base + (x, y) .. base + (x + 1, y + 1); gather order (x0 y1, x1 y1, x1 y0, x0 y0).
            vec4 g = textureGather(map, (base + vec2(x, y) + 1.0) / size, ref);
            sum += dot(g, vec4(wx0 * wy1, wx1 * wy1, wx1 * wy0, wx0 * wy0));
        }
    }
    return sum / float((2 * r + 1) * (2 * r + 1));
}
