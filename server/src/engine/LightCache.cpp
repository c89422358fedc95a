#include "LightCache.h"

#include <dfb/server/BendyChain.h>

namespace dfb::engine {

void uploadBendy(LightCache& c) {
    c.chain = chainFromLight<float>(c.params);
    c.bendy = toBendyBlock(c.chain, c.params.exactDirection);
    c.bendyUbo.upload(c.bendy);
}

} // namespace dfb::engine
