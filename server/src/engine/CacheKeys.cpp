#include "CacheKeys.h"

#include <dfb/protocol/Schema.h>

namespace dfb::engine {

// Both keys are derived from the rig schema's rows (protocol/Schema.h: each row says what a
// change of it invalidates and which light types it applies to), so a new property cannot be
// forgotten here.
bool sameShadowInputs(const Light& a, const Light& b) { return protocol::sameInputs(a, b, protocol::Invalidates::Shadow); }

bool sameShadingInputs(const Light& a, const Light& b) { return protocol::sameInputs(a, b, protocol::Invalidates::Shade); }

} // namespace dfb::engine
