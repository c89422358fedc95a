// TriangleBvh on Embree 3. One Embree device for the process (a device owns Embree's thread pool
// and its allocators: a device per hierarchy would start a pool per BendyLight deformation),
// shared by every hierarchy and released with the last one.

#include <dfb/core/Check.h>
#include <dfb/bvh/TriangleBvh.h>

#include <embree3/rtcore.h>

#include <cmath>
#include <cstring>
#include <mutex>

namespace dfb {

namespace {

struct Device {
    RTCDevice device = rtcNewDevice(nullptr);
    ~Device() { rtcReleaseDevice(device); }
};

std::shared_ptr<Device> sharedDevice() {
    static std::mutex mutex;
    static std::weak_ptr<Device> weak;
    std::lock_guard<std::mutex> lock(mutex);
    std::shared_ptr<Device> d = weak.lock();
    if (!d) {
        d = std::make_shared<Device>();
        DFB_CHECK(d->device != nullptr);
        weak = d;
    }
    return d;
}

RTCRay segmentRay(const glm::vec3& from, const glm::vec3& to, float tnear, float tfar) {
    RTCRay ray{};
    const glm::vec3 d = to - from;
    ray.org_x = from.x;
    ray.org_y = from.y;
    ray.org_z = from.z;
    ray.dir_x = d.x;
    ray.dir_y = d.y;
    ray.dir_z = d.z;
    ray.tnear = tnear;
    ray.tfar = tfar;
    ray.mask = ~0u;
    return ray;
}

} // namespace

struct TriangleBvh::Impl {
    std::shared_ptr<Device> device = sharedDevice();
    RTCScene scene = rtcNewScene(device->device);
    size_t triangles = 0;
    unsigned meshes = 0;
    ~Impl() { rtcReleaseScene(scene); }
};

TriangleBvh::TriangleBvh() : mImpl(std::make_unique<Impl>()) {}
TriangleBvh::~TriangleBvh() = default;

void TriangleBvh::addMesh(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices) {
    const size_t n = indices.size() / 3;
    RTCGeometry g = rtcNewGeometry(mImpl->device->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), positions.size()));
    if (!positions.empty()) std::memcpy(vb, positions.data(), positions.size() * sizeof(glm::vec3));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(unsigned), n));
    if (n) std::memcpy(ib, indices.data(), n * 3 * sizeof(unsigned));
    rtcCommitGeometry(g);
    // Geometry ids are given in order from 0, so that BvhHit::mesh is the addMesh() call.
    rtcAttachGeometryByID(mImpl->scene, g, mImpl->meshes++);
    rtcReleaseGeometry(g);
    mImpl->triangles += n;
}

void TriangleBvh::commit() { rtcCommitScene(mImpl->scene); }

bool TriangleBvh::occluded(const glm::vec3& from, const glm::vec3& to, float eps) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay ray = segmentRay(from, to, eps, 1.f - eps);
    rtcOccluded1(mImpl->scene, &ctx, &ray);
    return ray.tfar == -INFINITY;
}

std::optional<BvhHit> TriangleBvh::intersect(const glm::vec3& from, const glm::vec3& to, float tnear, float tfar) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray = segmentRay(from, to, tnear, tfar);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(mImpl->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    BvhHit h;
    h.t = rh.ray.tfar;
    h.mesh = rh.hit.geomID;
    h.triangle = rh.hit.primID;
    h.u = rh.hit.u;
    h.v = rh.hit.v;
    return h;
}

size_t TriangleBvh::triangleCount() const { return mImpl->triangles; }

} // namespace dfb
