#version 450 core
// Sorts shadow-casting triangles for the deformed shadow map (after bendy_deform.comp): those the
// deformation bends by less than the tolerance at every edge go to a plain indexed draw of their
// deformed vertices; the others to the tessellation pipeline. llvmpipe's tessellation stage costs
// about a microsecond per patch even when it subdivides nothing, so most triangles skip it.
// Triangles without any mapped vertex are dropped, and plain ones with any unmapped vertex. Closed meshes' triangles (the first
// uClosedTriangles) and the others go to separate halves of each list, drawn with and without
// front-face culling (Casters::draw); the four draws are indirect commands whose index
// counts this pass accumulates and whose first indices the engine sets.
#include "common_uniforms.glsl"
#include "common_bendy.glsl"

layout(local_size_x = COMPUTE_GROUP_SIZE) in;
layout(std430, binding = SSBO_FLAT_INDICES) writeonly buffer FlatIndices { uint flatIndices[]; };
layout(std430, binding = SSBO_TESS_INDICES) writeonly buffer TessIndices { uint tessIndices[]; };
// BendyDrawCommands (GpuInterface.h): four DrawElementsIndirectCommand {count, instanceCount,
// firstIndex, baseVertex, baseInstance}: plain closed, plain open, tessellated closed, tessellated open.
layout(std430, binding = SSBO_DRAW_COMMANDS) coherent buffer Commands { uint commands[BENDY_DRAW_COMMAND_WORDS]; };

// Read as buffer textures (one gather per read on llvmpipe; a storage-buffer read at a per-lane
// index loops over the lanes).
layout(binding = TEX_DEFORMED) uniform samplerBuffer tDeformed;
layout(binding = TEX_CASTER_INDICES) uniform usamplerBuffer tIndices;
layout(location = LOC_CLASSIFY_TRIANGLE_COUNT) uniform uint uTriangleCount;
layout(location = LOC_CLASSIFY_MAX_LEVEL) uniform float uMaxLevel;
layout(location = LOC_CLASSIFY_TEXEL_PER_DISTANCE) uniform float uTexelPerDistance;
layout(location = LOC_CLASSIFY_CLOSED_TRIANGLES) uniform uint uClosedTriangles;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= uTriangleCount) return;
    int b = int(3u * t);
    uint i0 = texelFetch(tIndices, b).x, i1 = texelFetch(tIndices, b + 1).x, i2 = texelFetch(tIndices, b + 2).x;
    vec4 d0 = texelFetch(tDeformed, int(2u * i0)), d1 = texelFetch(tDeformed, int(2u * i1)), d2 = texelFetch(tDeformed, int(2u * i2));
    if (d0.w + d1.w + d2.w < 0.5) return; // nothing mapped: cannot occlude
    bool closed = t < uClosedTriangles;
    if (closed && d0.w * d1.w * d2.w > 0.5) {
        // A closed mesh's face turned towards the light is culled by the draw anyway
        // (Casters::draw): dropping it here spares the draw its vertices and setup.
        vec4 c0 = uLight.worldToLightClip * vec4(d0.xyz, 1.0), c1 = uLight.worldToLightClip * vec4(d1.xyz, 1.0),
             c2 = uLight.worldToLightClip * vec4(d2.xyz, 1.0);
        if (c0.w > 0.0 && c1.w > 0.0 && c2.w > 0.0) {
            vec2 a = c0.xy / c0.w, b = c1.xy / c1.w, e = c2.xy / c2.w;
            if ((b.x - a.x) * (e.y - a.y) - (e.x - a.x) * (b.y - a.y) > 0.0) return; // counter-clockwise: front
        }
    }
    vec4 k0 = texelFetch(tDeformed, int(2u * i0 + 1u)), k1 = texelFetch(tDeformed, int(2u * i1 + 1u)), k2 = texelFetch(tDeformed, int(2u * i2 + 1u));
    float level = max(bendyEdgeLevel(d1, d2, k1, k2, uTexelPerDistance, uMaxLevel),
                      max(bendyEdgeLevel(d2, d0, k2, k0, uTexelPerDistance, uMaxLevel),
                          bendyEdgeLevel(d0, d1, k0, k1, uTexelPerDistance, uMaxLevel)));
    uint open = closed ? 0u : 1u;
    if (level <= 1.0) {
        // The plain draw has no fragment stage (llvmpipe then skips the per-pixel shader): a
        // triangle with an unmapped vertex, whose fragments shadow_bendy.frag would discard all
        // but within 1e-4 of its mapped corners, is dropped here instead.
        if (d0.w * d1.w * d2.w < 0.5) return;
        uint at = commands[5u * open + 2u] + atomicAdd(commands[5u * open], 3u);
        flatIndices[at] = i0; flatIndices[at + 1u] = i1; flatIndices[at + 2u] = i2;
    } else {
        atomicAdd(commands[BENDY_TESS_WORK_WORD], uint(level * level));
        uint at = commands[5u * open + 12u] + atomicAdd(commands[5u * open + 10u], 3u);
        tessIndices[at] = i0; tessIndices[at + 1u] = i1; tessIndices[at + 2u] = i2;
    }
}
