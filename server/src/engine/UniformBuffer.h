#pragma once
// A std140 block's GL buffer (GpuInterface.h), bound to the block's binding point whenever it is
// written, so a pass that uploads its block has it bound.

#include "GpuInterface.h"

#include <dfb/gl/Objects.h>

namespace dfb::engine {

template <typename Block, GLuint BINDING> class UniformBuffer {
public:
    /// Writes `block` (allocating the buffer on first use) and binds it at BINDING. GL thread.
    void upload(const Block& block) {
        if (!mBuffer) mBuffer = gl::makeBuffer(nullptr, sizeof(Block), GL_DYNAMIC_STORAGE_BIT);
        glNamedBufferSubData(mBuffer.id(), 0, sizeof block, &block);
        glBindBufferBase(GL_UNIFORM_BUFFER, BINDING, mBuffer.id());
    }

private:
    gl::Buffer mBuffer;
};

using LightUniforms = UniformBuffer<LightBlock, UBO_LIGHT>;
using ViewUniforms = UniformBuffer<ViewBlock, UBO_VIEW>;
using BendyUniforms = UniformBuffer<BendyBlock, UBO_BENDY>;

} // namespace dfb::engine
