#include <dfb/gbuffer/DeepBuffer.h>

namespace dfb {

void DeepBuffer::allocate(int w, int h) {
    width = w;
    height = h;
    const size_t n = pixelCount();
    P.assign(n * 3, 0.f);
    N.assign(n * 3, 0.f);
    Ng.assign(n * 3, 0.f);
    Z.assign(n, 0.f);
    albedo.assign(n * 3, 0.f);
    brdf.assign(n * 4, 0.f);
    emission.assign(n * 3, 0.f);
    A.assign(n, 0.f);
    objectId.assign(n, 0);
    materialId.assign(n, 0);
}

glm::vec3 DeepBuffer::position(int x, int y) const {
    const size_t i = (static_cast<size_t>(y) * width + x) * 3;
    return {P[i], P[i + 1], P[i + 2]};
}

glm::vec3 DeepBuffer::normal(int x, int y) const {
    const size_t i = (static_cast<size_t>(y) * width + x) * 3;
    return {N[i], N[i + 1], N[i + 2]};
}

} // namespace dfb
