#include <dfb/server/BendyChain.h>

namespace dfb {

std::string chainWarning(const Light& light) {
    if (light.type != LightType::Bendy || light.controlPoints.empty()) return {};
    return chainWarning(chainFromLight<double>(light));
}

} // namespace dfb
