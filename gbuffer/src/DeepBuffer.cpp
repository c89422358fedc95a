#include <dfb/gbuffer/DeepBuffer.h>

namespace dfb {

bool DeepBuffer::isFlat() const {
    if (sampleOffset.size() != pixelCount() + 1) return false;
    for (size_t p = 0; p < pixelCount(); ++p)
        if (sampleOffset[p] != p) return false;
    return sampleOffset.back() == pixelCount();
}

void DeepBuffer::allocate(int w, int h) {
    allocateSamples(w, h, std::vector<uint32_t>(size_t(w) * size_t(h), 1u));
}

void DeepBuffer::allocateSamples(int w, int h, const std::vector<uint32_t>& counts) {
    width = w;
    height = h;
    sampleOffset.assign(size_t(w) * size_t(h) + 1, 0);
    for (size_t p = 0; p < counts.size(); ++p) sampleOffset[p + 1] = sampleOffset[p] + counts[p];
    const size_t n = sampleOffset.back();
    P.assign(n * 3, 0.f);
    N.assign(n * 3, 0.f);
    Ng.assign(n * 3, 0.f);
    T.assign(n * 4, 0.f);
    Z.assign(n, 0.f);
    albedo.assign(n * 3, 0.f);
    brdf.assign(n * 4, 0.f);
    sheen.assign(n * 4, 0.f);
    coat.assign(n * 2, 0.f);
    emission.assign(n * 3, 0.f);
    // Optional: the samples it held are gone, and a stale layer of the old size would be read as
    // this buffer's (copies made with `DeepBuffer d = f; d.allocateSamples(...)`).
    envTransfer.clear();
    envLobe.clear();
    envRings.clear();
    envRays = 0;
    horizon.clear();
    horizonRadius = 0.f;
    A.assign(n, 0.f);
    objectId.assign(n, 0);
    materialId.assign(n, 0);
}

float DeepBuffer::coverage(int x, int y) const {
    float a = 0.f;
    const size_t p = size_t(y) * size_t(width) + size_t(x);
    for (uint32_t s = sampleOffset[p]; s < sampleOffset[p + 1]; ++s) a += A[s];
    return a;
}

} // namespace dfb
