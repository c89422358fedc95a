#pragma once
// The near-field horizon's estimator at one surface point (dfb/gbuffer/NearField.h), shared by the
// bake (each raster pass's exact surface points, gbuffer/src/Baker.cpp) and bakeHorizon (a
// buffer's stored samples). Private to dfb_gbuffer.

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>

#include <glm/glm.hpp>

#include <cstddef>
#include <memory>

namespace dfb {

/// Rays against every triangle of a scene over one reach. Threading: built on one thread; trace()
/// is const and may run on any number of threads at once.
class HorizonTracer {
public:
    /// Casts against `bvh` (sceneBvh of `scene`, EnvTracer.h; built here when null); the reach is
    /// `radiusFraction` x the scene's bounding radius.
    HorizonTracer(const Scene& scene, float radiusFraction, std::shared_ptr<const TriangleBvh> bvh = nullptr);

    /// The horizon at the surface point P with geometric normal Ng (normalised here, after
    /// rounding to half floats as the engine reads it): out[k] for the HORIZON_AZIMUTHS azimuths
    /// of lightmath::horizonDirection (bakeHorizon's definition). Returns the rays traced.
    size_t trace(const glm::vec3& P, const glm::vec3& Ng, float out[HORIZON_AZIMUTHS]) const;

    float reach() const { return mReach; } ///< scene units

private:
    const Scene& mScene;
    std::shared_ptr<const TriangleBvh> mBvh;
    float mReach = 0.f, mHair = 0.f;
};

} // namespace dfb
