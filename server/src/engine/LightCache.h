#pragma once
// What the engine keeps per light between frames: its shadow map, its contribution image and the
// parameters both were made with (docs/architecture.md, "The engine").

#include "GpuInterface.h"
#include "LightFrustum.h"
#include "UniformBuffer.h"

#include <dfb/gl/Objects.h>
#include <dfb/lightmath/BendyLight.h>
#include <dfb/protocol/Rig.h>

#include <cstdint>
#include <vector>

namespace dfb::engine {

struct LightCache {
    Light params;
    bool hasShadow = false;
    bool hasContribution = false;
    // What shadowMap is: GL_TEXTURE_2D, a point light's GL_TEXTURE_CUBE_MAP or an area light's
    // GL_TEXTURE_2D_ARRAY. A light whose type changes gets a map of its new kind even at the same size.
    GLenum shadowTarget = GL_NONE;
    bool shadowIsCube() const { return shadowTarget == GL_TEXTURE_CUBE_MAP; }
    bool previewShadow = false;    // rendered at preview size: re-render at full size when refining
    bool previewShading = false;   // contribution shaded at half resolution (top-left quarter)
    glm::vec2 cubeNearFar{0.f};    // the cube faces' projection planes
    int shadowSize = 0;
    gl::Texture shadowMap;
    gl::Framebuffer shadowFb;
    gl::Texture contribution;
    gl::Framebuffer contributionFb;
    glm::mat4 worldToLightClip{1.f};
    BendyUniforms bendyUbo;        // BendyBlock of a BendyLight
    lightmath::Chain<float> chain; // its chain as last uploaded,
    BendyBlock bendy{};            // and as the shaders see it (segments: the variants' BENDY_K)
    int bendySegments() const { return int(bendy.axisV.w + 0.5f); }
    GLsizei casterIndexCount = 0; // Casters::indicesFor when its shadow map was last rendered
    gl::Buffer linkMask; // light linking: one bit per object id
    gl::Buffer areaLayers;  // an area light's shadow layers (UBO_AREA_LAYERS; ShadowMaps::renderArea)
    gl::Buffer envSh;       // an environment light's turned map as SH (UBO_ENV_SH)
    gl::Buffer envSuns;     // and its suns (UBO_ENV_SUNS, EnvSunBlock), shaded in its pass
    // The footprint the contribution was last shaded over when it was the shot's coverage (an
    // environment light's; LightShading's mCoverage index), else -1: outside it the image is zero.
    int coverageWritten = -1;
    int shadowLayers = 0;   // their count (its grid, or 2 x 2 at most in a preview)
    float areaHalfAngle = 0.f; // its shadow frustum's half-angle, radians (areaShadowHalfAngle)
    int subdivisionLimit = 0; // the limit its deformed shadow map was rendered with
    int appliedSubdivision = 0; // the limit the tessellation budget left of it (BendyShadow::draw)
    glm::vec3 scale{1.f};          // colour x intensity: the contribution is shaded at unit radiance
    uint64_t version = 0;          // bumped whenever the contribution or its scale changes
    uint64_t compositedVersion = ~0ull;
    // A bent area light (docs/lighting.md, "Bent area lights"): its interior BendyLights, each
    // with its own deformed shadow map, for the grid `interiorGrid` (its shadowGrid, or a
    // preview's); their contributions are summed into this light's.
    std::vector<LightCache> interior;
    glm::ivec2 interiorGrid{0};
    bool emitterCosine = false; // an interior light: a Lambertian emitter's cell (relight_bendy.frag)
    bool softCasters = false;   // an interior light: its map from the simplified casters (BendyShadow)
    bool sunCasters = false;    // an environment's sun: its map from the suns' simplified casters (Casters::drawSun)
};

/// The directional light standing for environment light l's sun number `index` (extractSuns;
/// towards the sun `toSunMap`, in the map's space; named l.name + ".sun", then ".sun1", ".sun2"):
/// turned by the light's rotation, unit intensity (the sun's irradiance is its pass's weight,
/// LightShading::shade), shadowed when l is, linked as l.
Light environmentSun(const Light& l, const glm::vec3& toSunMap, int index = 0);

/// Colour x intensity: what a contribution (shaded at unit radiance) is multiplied by.
inline glm::vec3 radiance(const Light& l) { return toGlm(l.color) * l.intensityCd; }

/// Sets c.interior to c.params' interior BendyLights for `grid` (bentAreaInterior), keeping the GL
/// objects of those already there.
void syncInterior(LightCache& c, glm::ivec2 grid);

/// Converts c.params' chain (a BendyLight's) into c.chain and c.bendy and binds it at UBO_BENDY.
void uploadBendy(LightCache& c);

} // namespace dfb::engine
