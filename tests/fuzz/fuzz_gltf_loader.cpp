// libFuzzer target: the glTF loader (loadSceneFromMemory) on arbitrary bytes, GLB or JSON,
// images decoded. Any input must give a Scene or an Error, never a crash.
#include <dfb/gbuffer/Scene.h>

#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    auto r = dfb::loadSceneFromMemory("fuzz.glb", data, size);
    (void)r;
    return 0;
}
