// Picking for indirect editing (issue 17 point 1). The occluder point S of paper 000 eq. 11 is the
// point of the caster that shadows the clicked receiver; the shadow drags (eqs. 11-13, paper 003
// section 4.2) pivot the light about it.
//
// Which occluder: the first caster surface the light's ray meets on its way to the receiver, the
// hit nearest the light, for every light type. That is the surface the shadow map stores (its
// depth is the nearest caster seen from the light), so S is the point whose silhouette the image's
// shadow shows. For a directional light the ray is cast the same way, from outside the scene's
// bounding sphere towards the receiver, rather than from the receiver towards the sun taking the
// hit nearest the receiver: that keeps a far spot light and a sun agreeing on S (a spot moved away
// along its axis tends to the directional light) and matches the directional shadow map, whose
// depth is also the surface nearest the sun.
//
// BendyLights (paper 000 section 4): the shadow map is rendered in the deformed space, every
// caster vertex mapped Q -> Q' = deformedPoint(inverseMap(Q)) (eq. 7), where light travels in
// straight lines from p0. The ray runs from p0 to the receiver's Q' against the deformed casters:
// each caster triangle split into n x n sub-triangles (edges at most h = 1% of the scene's
// bounding radius, n at most 64, the engine's default tessellation limit), each grid point mapped
// in double, sub-triangles with a corner the map cannot place (behind the source) dropped, as the
// engine's deform pass drops them. A sub-triangle keeps its corners' undeformed positions, so the
// hit (barycentrics u, v on the deformed sub-triangle) maps back to S = (1-u-v) Qa + u Qb + v Qc on
// the undeformed caster (the sub-triangle lies in its caster's plane): S is exact on the caster,
// and deformedPoint(inverseMap(S)) lies on the deformed ray within the chord error of the
// subdivision (measured in tests/gpu/picker_test.cpp).
//
// Strategy, measured on the tabletop (scenes/tabletop.glb, 104,622 caster triangles; 2-core
// machine, Release): see docs/lighting.md, "Picking (indirect editing)". One hierarchy of the
// undeformed casters per session, built at create(); per BendyLight one deformed hierarchy,
// rebuilt only when the light's chain (control points, radii, cone, position, direction) changes,
// at most DEFORMED_CACHE_SIZE lights kept. Mapping vertices on demand instead (a ray marched in
// the deformed space, each step mapping the candidate triangles' vertices) needs a hierarchy of
// the deformed geometry anyway to find candidates, so a drag's picks would pay the deformation
// several times over; a pick happens once per drag begin, after a chain that usually has not
// changed since the last frame.

#include <dfb/lightmath/BendyLight.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/Picker.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>

namespace dfb {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Deformed hierarchies kept: a rig's BendyLights being dragged in turn. Each costs about 40 bytes
// per deformed sub-triangle (tens of MB on the tabletop), so not every light of a large rig.
constexpr size_t DEFORMED_CACHE_SIZE = 4;
// The engine's default and largest tessellation level (Engine::setShadowSubdivisionLimit).
constexpr int MAX_SPLIT = 64;
// Sub-triangle edges at most this fraction of the scene's bounding radius.
constexpr double SPLIT_EDGE = 0.01;
// Rays leave the receiver by this fraction of the scene's radius along its geometric normal,
// towards the light (the stored positions are rounded to float): far below a shadow-map texel,
// as tests/support/ShadowAgreement.h's rayHair.
constexpr float HAIR = 1e-5f;
// Ends of a ray excluded, as a fraction of its length.
constexpr float RAY_EPS = 1e-6f;
// A deformed hit whose undeformed point lies this close to the receiver (fraction of the scene's
// radius) is the receiver's own surface: the subdivided chords of a curved deformed surface lie
// off it by up to their chord error, more than the hair.
constexpr float SELF_HIT = 1e-3f;

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }
glm::vec3 toGlm(const Vec3& v) { return {v[0], v[1], v[2]}; }

std::string pixelName(int x, int y) { return "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")"; }

struct Front {
    glm::vec3 P{0.f}, N{0.f}, Ng{0.f};
    uint32_t objectId = 0;
    float coverage = 0.f;
    uint32_t samples = 0;
};

// The values a BendyLight's deformation depends on (not its colours): the cache key.
std::vector<double> chainKey(const lightmath::Chain<double>& ch) {
    std::vector<double> k{double(ch.segments), ch.tanTheta};
    auto add = [&k](const glm::dvec3& v) { k.insert(k.end(), {v.x, v.y, v.z}); };
    for (int i = 0; i <= 2 * ch.segments; ++i) {
        add(ch.p[i]);
        k.push_back(ch.r[i]);
    }
    add(ch.axisU);
    add(ch.axisV);
    add(ch.axisW);
    return k;
}

// A BendyLight's deformed casters: `undeformed[i]` is where deformed vertex i came from.
struct Deformed {
    std::vector<double> key;
    std::unique_ptr<TriangleBvh> bvh;
    std::vector<glm::vec3> undeformed;
    std::vector<uint32_t> indices;
    std::vector<uint32_t> sourceTriangle; // per sub-triangle: the caster triangle it was cut from
    uint64_t lastUse = 0;
};

} // namespace

struct Picker::Impl {
    int width = 0, height = 0;
    std::vector<Front> front; // per pixel, row 0 at the top
    ShadowGeometry casters;
    TriangleBvh bvh;
    glm::vec3 center{0.f};
    float radius = 1.f; // bounding sphere of casters and shot
    PickerStats stats;

    mutable std::mutex mutex; // guards deformed, useCounter and the deformed stats
    mutable std::map<std::string, Deformed> deformed;
    mutable uint64_t useCounter = 0;
    mutable PickerStats deformedStats;

    uint32_t objectOfTriangle(uint32_t tri) const {
        const size_t first = size_t(tri) * 3;
        auto it = std::upper_bound(casters.parts.begin(), casters.parts.end(), first,
                                   [](size_t f, const ShadowGeometry::Part& p) { return f < p.firstIndex; });
        if (it == casters.parts.begin()) return 0;
        --it;
        return first < it->firstIndex + it->indexCount ? it->objectId : 0;
    }

    Deformed build(const lightmath::Chain<double>& ch) const;
    const Deformed& deformedFor(const std::string& name, const lightmath::Chain<double>& ch) const;
};

Deformed Picker::Impl::build(const lightmath::Chain<double>& ch) const {
    const auto t0 = Clock::now();
    Deformed d;
    std::vector<glm::vec3> deformedPos;
    auto map = [&ch](const glm::dvec3& q, glm::dvec3& out) {
        const lightmath::TubeCoords<double> c = lightmath::inverseMap(ch, q);
        if (!c.valid) return false;
        out = lightmath::deformedPoint(ch, c);
        return true;
    };
    // Each caster vertex mapped once (a mesh shares it between about six triangles), then the grid
    // points inside the triangles that need splitting.
    std::vector<glm::dvec3> mappedVertex(casters.positions.size());
    std::vector<uint8_t> vertexOk(casters.positions.size());
    for (size_t i = 0; i < casters.positions.size(); ++i)
        vertexOk[i] = map(glm::dvec3(casters.positions[i]), mappedVertex[i]);
    const double h = SPLIT_EDGE * double(radius);
    std::vector<int32_t> gridIndex; // per grid point of the current triangle: vertex index or -1
    for (size_t t = 0; t + 2 < casters.indices.size(); t += 3) {
        const uint32_t ia = casters.indices[t], ib = casters.indices[t + 1], ic = casters.indices[t + 2];
        const glm::dvec3 a(casters.positions[ia]), b(casters.positions[ib]), c(casters.positions[ic]);
        const double longest = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
        const int n = std::clamp(int(std::ceil(longest / h)), 1, MAX_SPLIT);
        // Grid point (i, j), i + j <= n, at a + (b - a) i/n + (c - a) j/n.
        auto slot = [n](int i, int j) { return size_t(i * (n + 1) + j); };
        gridIndex.assign(size_t((n + 1) * (n + 1)), -1);
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j) {
                glm::dvec3 q, qd;
                bool ok;
                if (i == 0 && j == 0) {
                    q = a, qd = mappedVertex[ia], ok = vertexOk[ia];
                } else if (i == n) {
                    q = b, qd = mappedVertex[ib], ok = vertexOk[ib];
                } else if (j == n) {
                    q = c, qd = mappedVertex[ic], ok = vertexOk[ic];
                } else {
                    q = a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n);
                    ok = map(q, qd);
                }
                if (!ok) continue;
                gridIndex[slot(i, j)] = int32_t(d.undeformed.size());
                d.undeformed.push_back(glm::vec3(q));
                deformedPos.push_back(glm::vec3(qd));
            }
        auto emit = [&](size_t s0, size_t s1, size_t s2) {
            if (gridIndex[s0] < 0 || gridIndex[s1] < 0 || gridIndex[s2] < 0) return;
            d.indices.insert(d.indices.end(), {uint32_t(gridIndex[s0]), uint32_t(gridIndex[s1]), uint32_t(gridIndex[s2])});
            d.sourceTriangle.push_back(uint32_t(t / 3));
        };
        for (int i = 0; i < n; ++i)
            for (int j = 0; i + j < n; ++j) {
                emit(slot(i, j), slot(i + 1, j), slot(i, j + 1));
                if (i + j + 1 < n) emit(slot(i + 1, j), slot(i + 1, j + 1), slot(i, j + 1));
            }
    }
    d.bvh = std::make_unique<TriangleBvh>();
    d.bvh->addMesh(deformedPos, d.indices);
    d.bvh->commit();
    d.key = chainKey(ch);
    deformedStats.lastDeformedBuildMs = msSince(t0);
    deformedStats.lastDeformedTriangles = d.sourceTriangle.size();
    ++deformedStats.deformedBuilds;
    return d;
}

const Deformed& Picker::Impl::deformedFor(const std::string& name, const lightmath::Chain<double>& ch) const {
    // Called with `mutex` held.
    const std::vector<double> key = chainKey(ch);
    auto it = deformed.find(name);
    if (it == deformed.end() || it->second.key != key) {
        if (it == deformed.end() && deformed.size() >= DEFORMED_CACHE_SIZE) {
            auto oldest = std::min_element(deformed.begin(), deformed.end(), [](const auto& l, const auto& r) {
                return l.second.lastUse < r.second.lastUse;
            });
            deformed.erase(oldest);
        }
        deformed[name] = build(ch);
        it = deformed.find(name);
    }
    it->second.lastUse = ++useCounter;
    return it->second;
}

Picker::Picker() : mImpl(std::make_unique<Impl>()) {}
Picker::~Picker() = default;

Result<std::unique_ptr<Picker>> Picker::create(const DeepBuffer& shot, const ShadowGeometry& casters) {
    if (shot.width <= 0 || shot.height <= 0 || shot.sampleOffset.size() != shot.pixelCount() + 1)
        return makeError(ErrorCode::InvalidValue, "Picker: the shot is empty (" + std::to_string(shot.width) + "x" +
                                                      std::to_string(shot.height) + ")");
    for (uint32_t i : casters.indices)
        if (i >= casters.positions.size())
            return makeError(ErrorCode::InvalidValue, "Picker: a caster index (" + std::to_string(i) +
                                                          ") is past the positions (" +
                                                          std::to_string(casters.positions.size()) + ")");
    std::unique_ptr<Picker> picker(new Picker());
    Impl& m = *picker->mImpl;
    m.width = shot.width;
    m.height = shot.height;
    m.front.resize(shot.pixelCount());
    glm::vec3 lo(1e30f), hi(-1e30f);
    const bool hasNg = shot.Ng.size() >= shot.sampleCount() * 3;
    for (int y = 0; y < shot.height; ++y)
        for (int x = 0; x < shot.width; ++x) {
            Front& f = m.front[size_t(y) * size_t(shot.width) + size_t(x)];
            // Samples are sorted nearest first (docs/gbuffer-format.md): the front one is the first
            // that covers anything (a flat shot's uncovered pixels hold one sample with A = 0: the
            // background).
            size_t s = shot.firstSample(x, y);
            const size_t end = s + shot.pixelSamples(x, y);
            while (s < end && s < shot.A.size() && !(shot.A[s] > 0.f)) ++s;
            f.samples = uint32_t(end - s);
            if (!f.samples) continue;
            f.P = shot.position(s);
            f.N = shot.normal(s);
            f.Ng = hasNg ? glm::vec3(shot.Ng[s * 3], shot.Ng[s * 3 + 1], shot.Ng[s * 3 + 2]) : f.N;
            f.objectId = s < shot.objectId.size() ? shot.objectId[s] : 0;
            f.coverage = s < shot.A.size() ? shot.A[s] : 1.f;
            lo = glm::min(lo, f.P);
            hi = glm::max(hi, f.P);
        }
    for (const glm::vec3& p : casters.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    if (lo.x <= hi.x) {
        m.center = (lo + hi) * 0.5f;
        m.radius = std::max(glm::length(hi - lo) * 0.5f, 1e-6f);
    }
    m.casters = casters;
    const auto t0 = Clock::now();
    m.bvh.addMesh(m.casters.positions, m.casters.indices);
    m.bvh.commit();
    m.stats.bvhBuildMs = msSince(t0);
    m.stats.casterTriangles = m.casters.indices.size() / 3;
    return picker;
}

Result<PickResult> Picker::pick(int x, int y) const {
    if (x < 0 || y < 0 || x >= mImpl->width || y >= mImpl->height)
        return makeError(ErrorCode::InvalidValue, pixelName(x, y) + " is outside the " + std::to_string(mImpl->width) +
                                                      "x" + std::to_string(mImpl->height) + " shot");
    const Front& f = mImpl->front[size_t(y) * size_t(mImpl->width) + size_t(x)];
    if (!f.samples) return makeError(ErrorCode::MissingData, pixelName(x, y) + " has no samples (background)");
    PickResult r;
    r.hit = true;
    r.x = x;
    r.y = y;
    r.P = f.P;
    r.N = f.N;
    r.Ng = f.Ng;
    r.objectId = f.objectId;
    r.coverage = f.coverage;
    r.samples = f.samples;
    return r;
}

Result<OccluderResult> Picker::occluder(const Rig& rig, const std::string& lightName, int x, int y) const {
    auto p = pick(x, y);
    if (!p) return p.error();
    const Light* light = rig.find(lightName);
    if (!light) return makeError(ErrorCode::MissingData, "no light named '" + lightName + "' in the rig");
    auto r = occluder(*light, p->P, p->Ng);
    if (!r) return makeError(r.error().code, pixelName(x, y) + ": " + r.error().message);
    return r;
}

Result<OccluderResult> Picker::occluder(const Light& light, const glm::vec3& P, const glm::vec3& Ng) const {
    const Impl& m = *mImpl;
    const std::string who = "light '" + light.name + "'";
    if (!finite(P) || !finite(Ng))
        return makeError(ErrorCode::InvalidValue, "the receiver point or normal is not finite");
    if (!finite(light.position) || !finite(light.direction))
        return makeError(ErrorCode::InvalidValue, who + ": position or direction is not finite");
    const float hair = HAIR * m.radius;
    // Lift the receiver off its surface on the light's side.
    auto lifted = [&](const glm::vec3& towardsLight) {
        return P + Ng * (glm::dot(Ng, towardsLight) >= 0.f ? hair : -hair);
    };
    OccluderResult r;

    if (light.type != LightType::Bendy) {
        glm::vec3 from, to;
        if (light.type == LightType::Directional) {
            const glm::vec3 dir = toGlm(light.direction);
            if (!(glm::length(dir) > 0.f)) return makeError(ErrorCode::InvalidValue, who + ": zero direction");
            const glm::vec3 towardsSun = -glm::normalize(dir);
            to = lifted(towardsSun);
            from = to + towardsSun * (glm::length(to - m.center) + m.radius) * 1.01f;
        } else {
            from = toGlm(light.position);
            to = lifted(from - P);
        }
        r.rayFrom = from;
        r.rayTo = to;
        const auto hit = m.bvh.intersect(from, to, RAY_EPS, 1.f - RAY_EPS);
        if (!hit) return r;
        const size_t t = size_t(hit->triangle) * 3;
        const glm::vec3 a = m.casters.positions[m.casters.indices[t]], b = m.casters.positions[m.casters.indices[t + 1]],
                        c = m.casters.positions[m.casters.indices[t + 2]];
        r.found = true;
        r.S = a * (1.f - hit->u - hit->v) + b * hit->u + c * hit->v;
        r.Sdeformed = r.S;
        r.distance = hit->t * glm::length(to - from);
        r.objectId = m.objectOfTriangle(hit->triangle);
        return r;
    }

    // BendyLight.
    const size_t cps = light.controlPoints.size();
    const size_t K = cps / 2;
    if (cps == 0 || cps % 2 || K > size_t(lightmath::MAX_SEGMENTS) || light.radii.size() != 2 * K + 1 ||
        light.colors.size() != 2 * K + 1)
        return makeError(ErrorCode::InvalidValue, who + ": not a valid chain (" + std::to_string(cps) +
                                                      " control points, " + std::to_string(light.radii.size()) +
                                                      " radii, " + std::to_string(light.colors.size()) + " colours)");
    for (const Vec3& v : light.controlPoints)
        if (!finite(v)) return makeError(ErrorCode::InvalidValue, who + ": a control point is not finite");
    for (float v : light.radii)
        if (!std::isfinite(v)) return makeError(ErrorCode::InvalidValue, who + ": a radius is not finite");
    if (!std::isfinite(light.coneAngleDeg))
        return makeError(ErrorCode::InvalidValue, who + ": the cone angle is not finite");
    const lightmath::Chain<double> ch = chainFromLight<double>(light);
    const glm::dvec3 Pd(P);
    const lightmath::TubeCoords<double> c0 = lightmath::inverseMap(ch, Pd);
    if (!c0.valid)
        return makeError(ErrorCode::InvalidValue,
                         who + ": the receiver has no foot on the chain (it lies behind the source; the light never reaches it)");
    const glm::vec3 Li(lightmath::lightDirection(ch, c0, Pd, light.exactDirection));
    const glm::dvec3 Q(lifted(Li));
    const lightmath::TubeCoords<double> c = lightmath::inverseMap(ch, Q);
    if (!c.valid)
        return makeError(ErrorCode::InvalidValue, who + ": the receiver has no foot on the chain");
    const glm::vec3 from(ch.p[0]), to(lightmath::deformedPoint(ch, c));
    r.rayFrom = from;
    r.rayTo = to;
    std::lock_guard<std::mutex> lock(m.mutex);
    const Deformed& d = m.deformedFor(light.name, ch);
    const auto hit = d.bvh->intersect(from, to, RAY_EPS, 1.f - RAY_EPS);
    if (!hit) return r;
    const size_t t = size_t(hit->triangle) * 3;
    const glm::vec3 S = d.undeformed[d.indices[t]] * (1.f - hit->u - hit->v) + d.undeformed[d.indices[t + 1]] * hit->u +
                        d.undeformed[d.indices[t + 2]] * hit->v;
    // The nearest hit to the light being the receiver's own surface: nothing in between.
    if (glm::length(S - P) < SELF_HIT * m.radius) return r;
    r.found = true;
    r.S = S;
    r.Sdeformed = from + (to - from) * hit->t;
    r.distance = hit->t * glm::length(to - from);
    r.objectId = m.objectOfTriangle(d.sourceTriangle[hit->triangle]);
    return r;
}

const TriangleBvh& Picker::casters() const { return mImpl->bvh; }

PickerStats Picker::stats() const {
    PickerStats s = mImpl->stats;
    std::lock_guard<std::mutex> lock(mImpl->mutex);
    s.lastDeformedBuildMs = mImpl->deformedStats.lastDeformedBuildMs;
    s.lastDeformedTriangles = mImpl->deformedStats.lastDeformedTriangles;
    s.deformedBuilds = mImpl->deformedStats.deformedBuilds;
    return s;
}

} // namespace dfb
