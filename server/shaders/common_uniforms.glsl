// Uniform blocks and binding points. Mirror: server/src/engine/UniformBlocks.h (keep in sync;
// the C++ side pins every offset with static_assert).

// Texture units of the G-buffer and the per-pass inputs.
#define TEX_GBUFFER_P 0       // RGBA32F: world position xyz, coverage A in w
#define TEX_GBUFFER_N 1       // RGBA16F: shading normal xyz
#define TEX_GBUFFER_NG 2      // RGBA16F: geometric normal xyz
#define TEX_GBUFFER_ALBEDO 3  // RGBA16F: albedo rgb
#define TEX_GBUFFER_BRDF 4    // RGBA16F: metallic, roughness, specular, occlusion
#define TEX_GBUFFER_EMISSION 5 // RGBA16F: emission rgb
#define TEX_SHADOW_MAP 6      // DEPTH32F with compare mode
#define TEX_INPUT 7           // generic input of composite passes

#define UBO_LIGHT 0
#define UBO_VIEW 1

layout(std140, binding = UBO_LIGHT) uniform LightBlock {
    mat4 worldToLightClip;  // spot light's view-projection (shadow map space)
    vec4 lightPosition;     // xyz world position
    vec4 lightAxis;         // xyz unit axis the light points along
    vec4 lightRadiance;     // rgb = colour * intensity (candela)
    vec4 lightCone;         // x = cos(outer half-angle), y = cos(inner half-angle),
                            // z = 1 if shadowed, w = normal offset per unit distance (world)
    vec4 lightShadow;       // x = 1 / shadow-map size, yzw unused
} uLight;

layout(std140, binding = UBO_VIEW) uniform ViewBlock {
    vec4 cameraPosition;    // xyz world position of the shot camera
    vec4 exposure;          // x = 2^stops
} uView;
