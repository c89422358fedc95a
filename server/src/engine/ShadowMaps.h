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
/// control is being dragged (progressive refinement, DESIGN section 6).
int shadowSizeFor(const Light& l, bool preview);

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

    ShaderVariants& mShaders;
    const Casters& mCasters;
    LightUniforms& mLight;
    BendyShadow mBendy;
    GLuint mDepthProgram = 0; // owned by mShaders
};

} // namespace dfb::engine
