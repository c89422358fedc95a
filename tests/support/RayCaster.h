#pragma once
// Test support: reference visibility by ray casting with Embree on the CPU, to check what the
// GPU shadow maps say.

#include <embree3/rtcore.h>
#include <glm/glm.hpp>

#include <cmath>
#include <cstring>
#include <vector>

namespace dfb::test {

class RayCaster {
public:
    RayCaster() : mDevice(rtcNewDevice(nullptr)), mScene(rtcNewScene(mDevice)) {}
    ~RayCaster() {
        rtcReleaseScene(mScene);
        rtcReleaseDevice(mDevice);
    }
    RayCaster(const RayCaster&) = delete;
    RayCaster& operator=(const RayCaster&) = delete;

    /// Adds world-space triangles (3 indices each). Call commit() after the last one.
    void addMesh(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices) {
        RTCGeometry g = rtcNewGeometry(mDevice, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), positions.size()));
        std::memcpy(vb, positions.data(), positions.size() * sizeof(glm::vec3));
        auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                  3 * sizeof(unsigned), indices.size() / 3));
        std::memcpy(ib, indices.data(), indices.size() / 3 * 3 * sizeof(unsigned));
        rtcCommitGeometry(g);
        rtcAttachGeometry(mScene, g);
        rtcReleaseGeometry(g);
    }
    void commit() { rtcCommitScene(mScene); }

    /// True when something lies on the open segment from `from` to `to` (ends excluded by `eps`,
    /// a fraction of the segment's length).
    bool occluded(const glm::vec3& from, const glm::vec3& to, float eps = 1e-4f) const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRay ray{};
        const glm::vec3 d = to - from;
        ray.org_x = from.x;
        ray.org_y = from.y;
        ray.org_z = from.z;
        ray.dir_x = d.x;
        ray.dir_y = d.y;
        ray.dir_z = d.z;
        ray.tnear = eps;
        ray.tfar = 1.f - eps;
        ray.mask = ~0u;
        rtcOccluded1(mScene, &ctx, &ray);
        return ray.tfar == -INFINITY;
    }

private:
    RTCDevice mDevice;
    RTCScene mScene;
};

} // namespace dfb::test
