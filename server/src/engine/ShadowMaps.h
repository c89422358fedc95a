#pragma once
// Shadow maps: depth-only passes of the casters from a light into a 2D map (spot, directional;
// BendyLights through BendyShadow) or a cube map (point lights), kept in the light's cache.

#include "BendyShadow.h"
#include "CasterAnalysis.h"
#include "LightCache.h"
#include "ShaderVariants.h"
#include "UniformBuffer.h"

#include <dfb/core/Result.h>

namespace dfb::engine {

/// The side of the shadow map a light gets now: its own, or a quarter of it (at least 256) while a
/// control is being dragged (progressive refinement, DESIGN section 6). An area light's maps
/// (each of its grid's) keep their size: the preview takes fewer of them instead.
int shadowSizeFor(const Light& l, bool preview);

/// The m x n shadow layers of an area light now (a bent area light's interior lights): its grid,
/// or at most 2 x 2 in a preview (1 x 1 for a bent area light).
glm::ivec2 areaGridFor(const Light& l, bool preview);

/// Where layer (i, j) of an m x n grid looks from, in the emitter's (right, up) coordinates,
/// world units: the centres of an m x n grid of cells, mapped onto a disk by Shirley and Chiu's
/// concentric map ("A Low Distortion Map Between Disk and Square", 1997) for disk emitters.
glm::vec2 areaGridPoint(const Light& l, int i, int j, glm::ivec2 grid);

class ShadowMaps {
public:
    ShadowMaps(ShaderVariants& shaders, const Casters& casters, LightUniforms& light)
        : mShaders(shaders), mCasters(casters), mLight(light), mBendy(shaders, casters) {}

    /// Programs and the BendyLight's buffers. GL thread.
    Status init();

    /// Renders c.params' shadow map into c (allocated, or re-allocated at the size it needs now):
    /// sets c.worldToLightClip (2D maps) or c.cubeNearFar (cube maps), c.casterIndexCount and
    /// c.hasShadow. `preview`: a quarter-size map, remembered in c.previewShadow.
    Status render(LightCache& c, bool preview, int subdivisionLimit);

private:
    Status renderPlanar(LightCache& c, int size, int subdivisionLimit);
    Status renderCube(LightCache& c, int size);
    Status renderArea(LightCache& c, int size, bool preview);
    Status renderBentArea(LightCache& c, bool preview, int subdivisionLimit);

    ShaderVariants& mShaders;
    const Casters& mCasters;
    LightUniforms& mLight;
    BendyShadow mBendy;
    GLuint mDepthProgram = 0; // owned by mShaders
    GLuint mAreaProgram = 0;  // shadow_area.vert: every layer in one instanced pass
};

} // namespace dfb::engine
