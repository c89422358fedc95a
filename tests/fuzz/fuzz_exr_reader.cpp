// libFuzzer target: the deep framebuffer EXR reader (readDeepBuffer) on arbitrary bytes. Any
// input must give a value or an Error, never a crash, hang or sanitizer report.
#include <dfb/gbuffer/ExrIO.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // The reader takes a path (OpenEXR reads lazily from the file), so stage the bytes in /dev/shm.
    static const std::string path = "/dev/shm/dfb_fuzz_exr_" + std::to_string(::getpid()) + ".exr";
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data, 1, size, f);
    std::fclose(f);
    auto r = dfb::readDeepBuffer(path);
    (void)r;
    std::remove(path.c_str());
    return 0;
}
