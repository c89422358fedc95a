#pragma once
// The CPU models of the environment light's specular term (SpecularBands.h, SpecularLobes.h): one
// sample of the metal shot as both see it, its GGX lobe's rays and its map's suns, written once.

#include "engine/EnvironmentMap.h"

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Environment.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace dfb::bench {

/// Sample s of shot `g` as the specular models shade it: its point, normals, view, roughness and
/// F0 (the metal shot: F0 = albedo, F90 = 1), and its visibility towards a direction (none below
/// its geometric plane; against `bvh` over 4 scene radii when `shadowed`).
struct LobeSample {
    const TriangleBvh* bvh = nullptr;
    float radius = 1.f;
    bool shadowed = true;
    glm::dvec3 P{0.0}, N{0.0}, Ng{0.0}, V{0.0}, f0{0.0}, t{0.0}, b{0.0};
    double NdotV = 1, roughness = 1, alpha = 1;
    glm::vec3 from{0.f};

    /// False where the sample is uncovered or its normals are not finite.
    bool set(const DeepBuffer& g, size_t s, const glm::dvec3& eye) {
        namespace lm = lightmath;
        if (g.A[s] <= 0.f) return false;
        P = glm::dvec3(g.position(s));
        N = glm::normalize(glm::dvec3(g.N[s * 3], g.N[s * 3 + 1], g.N[s * 3 + 2]));
        Ng = glm::normalize(glm::dvec3(g.Ng[s * 3], g.Ng[s * 3 + 1], g.Ng[s * 3 + 2]));
        if (!std::isfinite(N.x) || !std::isfinite(Ng.x)) return false;
        V = g.camera.orthographic ? -glm::dvec3(g.camera.forward()) : glm::normalize(eye - P);
        NdotV = std::max(glm::dot(N, V), lm::MIN_NDOTV);
        roughness = g.brdf[s * 4 + 1];
        alpha = std::max(roughness * roughness, lm::MIN_ALPHA);
        f0 = glm::dvec3(g.albedo[s * 3], g.albedo[s * 3 + 1], g.albedo[s * 3 + 2]);
        from = glm::vec3(P + Ng * (1e-5 * double(radius)));
        t = glm::normalize(glm::cross(N, std::abs(N.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0)));
        b = glm::cross(N, t);
        return true;
    }

    bool visible(const glm::dvec3& d) const {
        if (glm::dot(Ng, d) <= 0) return false;
        return !shadowed || !bvh->occluded(from, from + glm::vec3(d) * (4.f * radius), 1e-6f);
    }

    /// Calls f(l, weight, VdotH, u, v) for each of `rays` GGX-distributed reflected directions l
    /// above the surface (weight lightmath::ggxLobeWeight; (u, v) the Hammersley point shifted per
    /// sample s, Cranley and Patterson 1976, as ggxHalfVector took it).
    template <typename F> void forEachRay(size_t s, int rays, F&& f) const {
        namespace lm = lightmath;
        const double du = std::fmod(double(s) * 0.7548776662466927, 1.0), dv = std::fmod(double(s) * 0.5698402909980532, 1.0);
        for (int k = 0; k < rays; ++k) {
            const glm::dvec2 xi = lm::hammersley(uint32_t(k), uint32_t(rays));
            const double u = std::fmod(xi.x + du, 1.0), v = std::fmod(xi.y + dv, 1.0);
            const glm::dvec3 hl = lm::ggxHalfVector({u, v}, alpha);
            const glm::dvec3 H = glm::normalize(t * hl.x + b * hl.y + N * hl.z);
            const double VdotH = glm::dot(V, H);
            const glm::dvec3 l = 2.0 * VdotH * H - V;
            const double weight = lm::ggxLobeWeight(glm::dot(N, l), NdotV, hl.z, VdotH, alpha);
            if (weight > 0) f(l, weight, VdotH, u, v);
        }
    }

    /// The suns' specular radiance, exact, each visible by one ray (the engine's shadow maps).
    glm::dvec3 sunsSpecular(const std::vector<engine::EnvSun>& suns) const {
        namespace lm = lightmath;
        glm::dvec3 sum(0.0);
        for (const engine::EnvSun& sun : suns) {
            const glm::dvec3 l = glm::normalize(glm::dvec3(sun.direction));
            const double NdotL = glm::dot(N, l);
            if (NdotL <= 0 || !visible(l)) continue;
            const glm::dvec3 H = glm::normalize(l + V);
            const double D = lm::distributionGGX(glm::dot(N, H), alpha);
            const double vis = lm::visibilitySmithGGX(NdotL, NdotV, alpha);
            sum += glm::dvec3(sun.irradiance) * lm::fresnelSchlick(f0, 1.0, glm::dot(V, H)) * (D * vis * NdotL);
        }
        return sum;
    }
};

} // namespace dfb::bench
