#include <dfb/server/BendyChain.h>
#include <dfb/server/BentArea.h>

#include <glm/glm.hpp>

namespace dfb {

std::string chainWarning(const Light& light) { return chainWarning(light, 1.0, 1.0); }

std::string chainWarning(const Light& light, double foldLimit, double apartLimit) {
    if (light.type == LightType::BentArea) return bentAreaWarning(light, foldLimit, apartLimit);
    if (light.type != LightType::Bendy || light.controlPoints.empty()) return {};
    return chainTrouble(chainFromLight<double>(light), foldLimit, apartLimit);
}

namespace {

float mix(float a, float b, double t) { return a == b ? a : float(double(a) + (double(b) - double(a)) * t); }

Vec3 mix(const Vec3& a, const Vec3& b, double t) { return {mix(a[0], b[0], t), mix(a[1], b[1], t), mix(a[2], b[2], t)}; }

template <typename V> V mixAll(const V& a, const V& b, double t) {
    V out = a;
    for (size_t i = 0; i < out.size(); ++i) out[i] = mix(a[i], b[i], t);
    return out;
}

// `before` moved the fraction t of the way to `after` in every chain property that differs;
// everything else (colour, intensity, ...) is `after`'s.
Light between(const Light& before, const Light& after, double t) {
    Light l = after;
    l.position = mix(before.position, after.position, t);
    if (before.direction != after.direction) {
        const Vec3 d = mix(before.direction, after.direction, t);
        const glm::dvec3 v(d[0], d[1], d[2]);
        const double len = glm::length(v);
        // A direction through zero (a half turn) has no midpoint: keep the start's there.
        l.direction = len > 1e-6 ? Vec3{float(v.x / len), float(v.y / len), float(v.z / len)} : before.direction;
    }
    l.controlPoints = mixAll(before.controlPoints, after.controlPoints, t);
    l.radii = mixAll(before.radii, after.radii, t);
    l.cornerPoints = mixAll(before.cornerPoints, after.cornerPoints, t);
    l.cornerRadii = mixAll(before.cornerRadii, after.cornerRadii, t);
    l.coneAngleDeg = mix(before.coneAngleDeg, after.coneAngleDeg, t);
    l.areaSize = mixAll(before.areaSize, after.areaSize, t);
    l.rollDeg = mix(before.rollDeg, after.rollDeg, t);
    return l;
}

} // namespace

std::optional<ChainLimit> limitChainEdit(const Light& before, const Light& after) {
    if (before.type != after.type || before.name != after.name) return std::nullopt;
    if (after.type != LightType::Bendy && after.type != LightType::BentArea) return std::nullopt;
    if (before.controlPoints.size() != after.controlPoints.size() || before.radii.size() != after.radii.size() ||
        before.cornerPoints.size() != after.cornerPoints.size() || before.cornerRadii.size() != after.cornerRadii.size())
        return std::nullopt;
    std::string why = chainWarning(after);
    if (why.empty() || !chainWarning(before).empty()) return std::nullopt;
    // The stricter margins when the start already keeps them; otherwise the plain limits (a
    // chain that already bends nearly to folding may still be moved as long as it does not fold).
    double fold = LIMIT_FOLD, apart = LIMIT_APART;
    if (!chainWarning(before, fold, apart).empty()) fold = apart = 1.0;
    auto sound = [&](double t) { return chainWarning(between(before, after, t), fold, apart).empty(); };
    // The first unsound step along the way, then bisection between it and the step before.
    constexpr int STEPS = 32, BISECTIONS = 20;
    double lo = 0.0, hi = 1.0;
    for (int i = 1; i <= STEPS; ++i) {
        const double t = double(i) / STEPS;
        if (!sound(t)) {
            hi = t;
            break;
        }
        lo = t;
    }
    for (int i = 0; i < BISECTIONS; ++i) {
        const double mid = 0.5 * (lo + hi);
        (sound(mid) ? lo : hi) = mid;
    }
    return ChainLimit{between(before, after, lo), lo, std::move(why)};
}

} // namespace dfb
