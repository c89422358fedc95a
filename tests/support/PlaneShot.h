#pragma once
// Test support: a hand-built flat shot of the plane y = 0 (one sample per pixel, normal +Y,
// coverage 1, object 1), the engine tests' closed-form scene. Values given here are stored as they
// are; the engine reads all but P as half float, so tests that compare with closed forms to better
// than 1e-3 use values half float holds exactly.

#include <dfb/gbuffer/DeepBuffer.h>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace dfb::test {

struct PlaneShot {
    int size = 96;                  ///< pixels a side
    float half = 2.f;               ///< the plane covers x, z in [-half, half]
    glm::vec3 albedo{0.5f};
    float metallic = 0.f;
    float roughness = 1.f;          ///< with specular 0: pure Lambert
    float specular = 0.f;           ///< the G-buffer's specular level (0.5: glTF's default F0 0.04)
    glm::vec3 eye{0.f, 10.f, 0.f};  ///< perspective camera looking at the origin
    glm::vec3 up{0.f, 0.f, -1.f};

    /// The plane point pixel (x, y) sees (row 0 at -half in z).
    glm::vec3 point(int x, int y) const {
        return {-half + 2.f * half * (float(x) + 0.5f) / float(size), 0.f, -half + 2.f * half * (float(y) + 0.5f) / float(size)};
    }

    DeepBuffer shot() const {
        DeepBuffer b;
        b.allocate(size, size);
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const size_t i = size_t(y) * size_t(size) + size_t(x);
                const glm::vec3 p = point(x, y);
                b.P[i * 3 + 0] = p.x;
                b.P[i * 3 + 2] = p.z;
                b.N[i * 3 + 1] = 1.f;
                b.Ng[i * 3 + 1] = 1.f;
                for (int c = 0; c < 3; ++c) b.albedo[i * 3 + size_t(c)] = albedo[c];
                b.brdf[i * 4 + 0] = metallic;
                b.brdf[i * 4 + 1] = roughness;
                b.brdf[i * 4 + 2] = specular;
                b.brdf[i * 4 + 3] = 1.f;
                b.A[i] = 1.f;
                b.objectId[i] = 1;
            }
        b.camera.worldToCamera = glm::lookAt(eye, glm::vec3(0.f), up);
        return b;
    }
};

} // namespace dfb::test
