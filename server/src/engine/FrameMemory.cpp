// keepFreedMemoryForFrames (Engine.h): the allocator tuning that keeps llvmpipe's per-frame memory
// in the process between frames.

#include <dfb/server/Engine.h>

#include <malloc.h> // mallopt, malloc_trim (glibc)

namespace dfb {

void keepFreedMemoryForFrames() {
    mallopt(M_TRIM_THRESHOLD, 256 << 20); // keep up to 256 MB freed at the heap's top
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // blocks under 32 MB (frames, bins) from the heap
}

void releaseFreedMemory() { malloc_trim(0); }

} // namespace dfb
