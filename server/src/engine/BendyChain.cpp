#include <dfb/server/BendyChain.h>
#include <dfb/server/BentArea.h>

namespace dfb {

std::string chainWarning(const Light& light) {
    if (light.type == LightType::BentArea) return bentAreaWarning(light);
    if (light.type != LightType::Bendy || light.controlPoints.empty()) return {};
    return chainWarning(chainFromLight<double>(light));
}

} // namespace dfb
