#pragma once
// Picking for indirect editing (issue 17 point 1; paper 000 section 5, "Indirect Control"): what
// a pixel of the shot shows (its front G-buffer sample), and for shadow drags the occluder point
// S, the first surface the light's ray meets on its way to that sample, on the geometry the
// shadow maps are rendered from (the session's ShadowGeometry). For a BendyLight that geometry is
// deformed (paper 000 eq. 7, Q -> Q'): the ray runs from the source p0 to the receiver's Q' in
// the deformed space, and the hit is mapped back to the undeformed caster surface
// (docs/lighting.md, "Picking (indirect editing)").
//
// Threading: every member may be called from any thread, concurrently; the per-light deformed
// hierarchies are cached behind a mutex (a query for a light whose chain changed rebuilds its
// hierarchy while holding it).

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/Engine.h>
#include <dfb/bvh/TriangleBvh.h>

#include <glm/glm.hpp>

#include <cstdint>
#include <memory>
#include <string>

namespace dfb {

/// What a pixel shows: its front (nearest) G-buffer sample.
struct PickResult {
    bool hit = false;      ///< the pixel is covered (always true in a successful pick())
    int x = 0, y = 0;      ///< the pixel, row 0 at the top
    glm::vec3 P{0.f};      ///< world-space position, scene units
    glm::vec3 N{0.f};      ///< shading normal, unit
    glm::vec3 Ng{0.f};     ///< geometric normal, unit
    uint32_t objectId = 0; ///< 1-based object id of the shot's manifest (0 = none)
    float coverage = 0.f;  ///< the front sample's coverage A, (0, 1]
    uint32_t samples = 0;  ///< samples the pixel holds (the front one is reported)
};

/// The occluder of a receiver point for one light.
struct OccluderResult {
    bool found = false;      ///< false: nothing lies between the light and the receiver (lit)
    glm::vec3 S{0.f};        ///< the occluder point on the undeformed caster surface, world space
    /// For a BendyLight the hit in the deformed space (S maps to it: deformedPoint(inverseMap(S)));
    /// for the other lights equal to S.
    glm::vec3 Sdeformed{0.f};
    /// Distance from the light to the occluder along the ray that found it, scene units (the
    /// deformed ray's for a BendyLight); for a directional light from the ray's start, outside
    /// the scene's bounding sphere.
    float distance = 0.f;
    uint32_t objectId = 0;   ///< the occluder's object id (ShadowGeometry::Part::objectId; 0 unknown)
    glm::vec3 rayFrom{0.f};  ///< where the ray started: the light (p0 for a BendyLight)
    glm::vec3 rayTo{0.f};    ///< where it ended: the receiver (Q' for a BendyLight), lifted off its surface
};

/// Build and query costs, in milliseconds of wall time.
struct PickerStats {
    double bvhBuildMs = 0;          ///< the undeformed casters' hierarchy (once, at create())
    size_t casterTriangles = 0;
    double lastDeformedBuildMs = 0; ///< the last BendyLight hierarchy built (0: none yet)
    size_t lastDeformedTriangles = 0;
    int deformedBuilds = 0;         ///< BendyLight hierarchies built so far (cache misses)
};

class Picker {
public:
    /// Keeps a copy of the shot's front samples and builds the casters' hierarchy (the geometry
    /// Engine::create is given). Fails with InvalidValue for an empty shot.
    static Result<std::unique_ptr<Picker>> create(const DeepBuffer& shot, const ShadowGeometry& casters);
    ~Picker();
    Picker(const Picker&) = delete;
    Picker& operator=(const Picker&) = delete;

    /// The front sample of pixel (x, y). Fails with InvalidValue for a pixel outside the image and
    /// MissingData for one without samples (the background).
    Result<PickResult> pick(int x, int y) const;

    /// The occluder of pixel (x, y)'s front sample for the rig's light `lightName`: the first
    /// caster the light's ray meets on its way to the sample (found = false when it meets none).
    /// Fails with InvalidValue for a pixel outside the image or a light with a non-finite
    /// position, direction or chain, MissingData for a pixel without samples or an unknown light,
    /// and InvalidValue when a BendyLight's inverse map has no foot for the sample (it lies
    /// behind the source: the light never reaches it).
    Result<OccluderResult> occluder(const Rig& rig, const std::string& lightName, int x, int y) const;

    /// The same for any receiver point P with geometric normal Ng (unit) and any light.
    Result<OccluderResult> occluder(const Light& light, const glm::vec3& P, const glm::vec3& Ng) const;

    /// The casters' hierarchy (undeformed), for other ray queries.
    const TriangleBvh& casters() const;

    PickerStats stats() const;

private:
    Picker();
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

} // namespace dfb
