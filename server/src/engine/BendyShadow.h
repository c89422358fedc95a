#pragma once
// A BendyLight's deformed shadow map (paper 000 section 4, "Real-Time on the GPU"): a compute
// pass deforms every caster vertex once (bendy_deform.comp), another sorts the triangles into
// plain and tessellated draws (bendy_classify.comp), and those draw into the bound depth target.

#include "CasterAnalysis.h"
#include "LightCache.h"
#include "ShaderVariants.h"

#include <dfb/core/Result.h>
#include <dfb/gl/Objects.h>

namespace dfb::engine {

/// Most triangles the tessellator may make for one deformed map (estimated as the sum of the
/// tessellated triangles' levels squared); over it the subdivision limit is lowered to fit.
constexpr uint32_t MAX_TESS_TRIANGLES = 1u << 18;

class BendyShadow {
public:
    BendyShadow(ShaderVariants& shaders, const Casters& casters) : mShaders(shaders), mCasters(casters) {}

    /// Buffers sized for the casters and the programs that do not depend on the chain. GL thread.
    Status init();

    /// Draws c.params' deformed casters into the bound depth target (c.shadowSize square, the
    /// depth pass state set, c.worldToLightClip at UBO_LIGHT); uploads its chain (c.chain, c.bendy)
    /// and sets c.casterIndexCount and c.subdivisionLimit.
    Status draw(LightCache& c, int subdivisionLimit);

private:
    ShaderVariants& mShaders;
    const Casters& mCasters;
    GLuint mClassifyProgram = 0, mFlatProgram = 0; // owned by mShaders
    gl::Buffer mFlatIndices, mTessIndices, mIndirect; // triangle lists sorted by bendy_classify.comp
    gl::VertexArray mFlatVao, mTessVao, mSoftTessVao; // the last: tessellated simplified casters
    gl::Buffer mDeformed; // 2 vec4 per caster vertex (bendy_deform.comp)
    gl::Texture mDeformedTexture, mCasterIndexTexture; // buffer textures of mDeformed and the casters' indices
    gl::Texture mSoftIndexTexture;                     // and of the simplified casters' indices
};

} // namespace dfb::engine
