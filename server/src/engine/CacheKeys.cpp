#include "CacheKeys.h"

#include "LightFrustum.h"

namespace dfb::engine {

bool sameShadowInputs(const Light& a, const Light& b) {
    if (a.type == LightType::Point || b.type == LightType::Point) {
        // Omnidirectional: direction and cone play no part in a cube map.
        return a.type == b.type && a.position == b.position && a.shadow == b.shadow && a.shadowMapSize == b.shadowMapSize;
    }
    return a.position == b.position && a.direction == b.direction && shadowHalfAngleDeg(a) == shadowHalfAngleDeg(b) &&
           (a.type != LightType::Bendy || a.coneAngleDeg == b.coneAngleDeg) &&
           a.shadow == b.shadow && a.shadowMapSize == b.shadowMapSize && a.type == b.type &&
           (a.type != LightType::Bendy || (a.controlPoints == b.controlPoints && a.radii == b.radii));
}

bool sameShadingInputs(const Light& a, const Light& b) {
    return sameShadowInputs(a, b) && a.coneAngleDeg == b.coneAngleDeg && a.penumbraDeg == b.penumbraDeg && a.shadowBias == b.shadowBias && a.type == b.type &&
           a.include == b.include && a.exclude == b.exclude && a.shadowFilter == b.shadowFilter &&
           a.cookie == b.cookie && a.barnDoorsDeg == b.barnDoorsDeg &&
           (a.type != LightType::Bendy || (a.colors == b.colors && a.exactDirection == b.exactDirection));
}

} // namespace dfb::engine
