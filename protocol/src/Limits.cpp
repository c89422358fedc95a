// What one session's rig may hold (RigLimits; docs/operations.md "Limits").

#include <dfb/protocol/Codec.h>

namespace dfb::protocol {

uint64_t lightMemoryBytes(const Light& l, const RigLimits& limits) {
    if (!l.enabled) return 0;
    uint64_t bytes = limits.imagePixels * 16; // its contribution image, RGBA32F
    if (l.type == LightType::Environment) {
        // No shadow map (its visibility is baked in the shot): the prefiltered map and its mips,
        // and, shadowed, its suns' maps (engine environmentSun) as many as a map may give.
        const uint64_t w = ENV_PREFILTER_WIDTH;
        const uint64_t suns = uint64_t(ENV_SUN_MAP_SIZE) * ENV_SUN_MAP_SIZE * 4 +
                              uint64_t(ENV_MAX_SUNS - 1) * ENV_LAMP_MAP_SIZE * ENV_LAMP_MAP_SIZE * 4;
        return bytes + w * (w / 2) * 16 * 4 / 3 + (l.shadow ? suns : 0);
    }
    if (l.shadow) {
        const uint64_t side = uint64_t(l.shadowMapSize);
        const uint64_t maps = l.type == LightType::Point ? 6
                              : l.type == LightType::Area || l.type == LightType::BentArea ? uint64_t(l.shadowGrid[0]) * uint64_t(l.shadowGrid[1])
                                                          : 1;
        bytes += side * side * 4 * maps;
    }
    return bytes;
}

Status checkRigLimits(const Rig& rig, const RigLimits& limits) {
    auto over = [](const std::string& what) { return makeError(ErrorCode::LimitExceeded, what); };
    if (rig.lights.size() > limits.maxLights) {
        return over("the rig would have " + std::to_string(rig.lights.size()) + " lights; the limit is " +
                    std::to_string(limits.maxLights) + " lights per rig (--max-lights)");
    }
    uint64_t bytes = 0;
    for (const Light& l : rig.lights) {
        for (const auto& [prop, ks] : l.keys) {
            if (ks.size() > limits.maxKeysPerProperty) {
                return over(l.name + ".keys." + prop + ": " + std::to_string(ks.size()) + " keyframes; the limit is " +
                            std::to_string(limits.maxKeysPerProperty) + " per property (--max-keys)");
            }
        }
        bytes += lightMemoryBytes(l, limits);
    }
    if (bytes > limits.maxLightMemoryBytes) {
        const auto mb = [](uint64_t b) { return std::to_string((b + (1u << 20) - 1) >> 20); };
        return over("the lights' shadow maps and cached images would need " + mb(bytes) + " MB; the limit is " +
                    mb(limits.maxLightMemoryBytes) + " MB per session (--max-light-memory-mb); use smaller shadow maps "
                    "(shadowMapSize), fewer shadowed lights, or disable lights");
    }
    return okStatus();
}

} // namespace dfb::protocol
