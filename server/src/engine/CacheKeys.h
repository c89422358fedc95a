#pragma once
// What a light's cached shadow map and contribution image depend on (GlEngine's caches, see
// docs/architecture.md): two lights that compare equal here render the same map or image.

#include <dfb/protocol/Rig.h>

namespace dfb::engine {

/// True when `a` and `b` render the same shadow map; any difference re-renders it.
bool sameShadowInputs(const Light& a, const Light& b);

/// True when `a` and `b` shade the same contribution image, besides their shadow maps. Colour and
/// intensity are not among them: they only rescale the cached image.
bool sameShadingInputs(const Light& a, const Light& b);

} // namespace dfb::engine
