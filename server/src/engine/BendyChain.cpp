#include <dfb/server/BendyChain.h>

#include <dfb/lightmath/Falloff.h>

#include <cstdio>
#include <vector>

namespace dfb {

std::string chainWarning(const Light& light) {
    if (light.type != LightType::Bendy || light.controlPoints.empty()) return {};
    using namespace lightmath;
    const Chain<double> ch = chainFromLight<double>(light);
    char buf[256];
    // Samples along the chain: position, radius, arc length.
    struct S {
        glm::dvec3 p;
        double r, s;
    };
    std::vector<S> samples;
    const int PER_SEGMENT = 32;
    for (int k = 0; k < ch.segments; ++k) {
        const double len = arcLength(ch, k, 1.0) - arcLength(ch, k, 0.0);
        if (!(len > 1e-9)) {
            std::snprintf(buf, sizeof buf, "segment %d has zero length (control points %d-%d coincide)", k, 2 * k, 2 * k + 2);
            return buf;
        }
        for (int i = 0; i <= PER_SEGMENT; ++i) {
            const double t = double(i) / PER_SEGMENT;
            const glm::dvec3 d = chainDerivative(ch, k, t);
            if (glm::length(d) < 1e-6 * len) {
                std::snprintf(buf, sizeof buf, "segment %d has a cusp at u = %.2f (its direction reverses)", k, k + t);
                return buf;
            }
            const double kappa = glm::length(glm::cross(d, chainSecondDerivative(ch, k))) / std::pow(glm::length(d), 3.0);
            const double R = chainRadius(ch, k, t);
            if (R * kappa >= 1.0) {
                std::snprintf(buf, sizeof buf,
                              "the tube folds over itself inside the bend near u = %.2f (radius %.3g exceeds the "
                              "bend's radius of curvature %.3g): self-intersecting tube",
                              k + t, R, 1.0 / kappa);
                return buf;
            }
            samples.push_back({chainPoint(ch, k, t), R, arcLength(ch, k, t)});
        }
    }
    // Parts of the chain far apart along it but close in space.
    for (size_t i = 0; i < samples.size(); ++i)
        for (size_t j = i + 1; j < samples.size(); ++j) {
            const double along = samples[j].s - samples[i].s;
            const double reach = samples[i].r + samples[j].r;
            if (along <= 2.0 * reach) continue; // neighbours along the chain always overlap
            const double apart = glm::length(samples[j].p - samples[i].p);
            if (apart < reach) {
                std::snprintf(buf, sizeof buf,
                              "the tube intersects itself: the chain at arc length %.3g comes within %.3g of itself at "
                              "%.3g (radii %.3g + %.3g)",
                              samples[i].s, apart, samples[j].s, samples[i].r, samples[j].r);
                return buf;
            }
        }
    return {};
}

} // namespace dfb
