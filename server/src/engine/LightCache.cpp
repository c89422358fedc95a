#include "LightCache.h"

#include <dfb/server/BendyChain.h>
#include <dfb/server/BentArea.h>

namespace dfb::engine {

void uploadBendy(LightCache& c) {
    c.chain = chainFromLight<float>(c.params);
    c.bendy = toBendyBlock(c.chain, c.params.exactDirection);
    c.bendyUbo.upload(c.bendy);
}

void syncInterior(LightCache& c, glm::ivec2 grid) {
    std::vector<Light> lights = bentAreaInterior(c.params, grid);
    c.interior.resize(lights.size());
    for (size_t k = 0; k < lights.size(); ++k) {
        c.interior[k].params = std::move(lights[k]);
        c.interior[k].emitterCosine = true;
        c.interior[k].softCasters = true;
    }
    c.interiorGrid = grid;
}

} // namespace dfb::engine
