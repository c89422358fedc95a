// CPU/GPU parity of the BendyLight math: the GLSL mirror (server/shaders/common_bendy.glsl) runs
// in a compute shader through headless EGL on random points of random chains, and must agree with
// the C++ model (server/include/dfb/lightmath/BendyLight.h) evaluated in double.

#include "engine/GpuInterface.h"

#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>
#include <dfb/lightmath/BendyLight.h>

#include <gtest/gtest.h>

#include <random>

namespace dfb::shaders {
std::string_view serverShader(std::string_view name);
}

using namespace dfb;
using namespace dfb::lightmath;

namespace {

const char* KERNEL = R"(
// Points in and results out where the deform pass has its caster vertices and their images.
layout(local_size_x = COMPUTE_GROUP_SIZE) in;
layout(std430, binding = SSBO_CASTER_POSITIONS) readonly buffer Points { vec4 points[]; };
layout(std430, binding = SSBO_DEFORMED) writeonly buffer Results { vec4 results[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(points.length())) return;
    vec3 Q = points[i].xyz;
    TubeCoords c = inverseMap(Q);
    vec3 qd = c.valid ? deformedPoint(c) : vec3(0.0);
    vec3 li9 = c.valid ? lightDirection(c, Q, false) : vec3(0.0);
    vec3 lix = c.valid ? lightDirection(c, Q, true) : vec3(0.0);
    results[4u * i + 0u] = vec4(qd, c.valid ? (c.inside ? 2.0 : 1.0) : 0.0);
    results[4u * i + 1u] = vec4(li9, float(c.segment));
    results[4u * i + 2u] = vec4(lix, c.t);
    results[4u * i + 3u] = vec4(c.v, c.w, 0.0, 0.0);
}
)";

template <typename T> Chain<T> randomChain(std::mt19937_64& rng, int K) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Chain<T> ch;
    ch.segments = K;
    ch.tanTheta = T(std::tan(0.45));
    ch.axisU = vec3<T>(1, 0, 0);
    ch.axisV = vec3<T>(0, 1, 0);
    ch.axisW = vec3<T>(0, 0, 1);
    glm::dvec3 dir(1, 0, 0), p(2, 1, -1);
    ch.p[0] = vec3<T>(p);
    for (int i = 1; i <= 2 * K; ++i) {
        dir = glm::normalize(dir + glm::dvec3(u(rng), u(rng), u(rng)) * 0.7);
        if (dir.x < -0.2) dir.x = -dir.x;
        p += dir * (1.0 + 0.4 * u(rng));
        ch.p[i] = vec3<T>(p);
    }
    for (int i = 0; i <= 2 * K; ++i) {
        ch.r[i] = T(0.1 + 0.35 * (1.0 + u(rng)) + 0.25 * i);
        ch.c[i] = vec3<T>(T(0.5 + 0.5 * u(rng)), T(1), T(0.5));
    }
    prepareChain(ch);
    return ch;
}

template <typename To, typename From> Chain<To> convert(const Chain<From>& a) {
    Chain<To> b;
    b.segments = a.segments;
    for (int i = 0; i < MAX_CONTROL_POINTS; ++i) {
        b.p[i] = vec3<To>(a.p[i]);
        b.r[i] = To(a.r[i]);
        b.c[i] = vec3<To>(a.c[i]);
    }
    b.axisU = vec3<To>(a.axisU);
    b.axisV = vec3<To>(a.axisV);
    b.axisW = vec3<To>(a.axisW);
    b.tanTheta = To(a.tanTheta);
    prepareChain(b);
    return b;
}

// Runs a kernel over `points` (SSBO_CASTER_POSITIONS) with `block` as the BendyBlock; returns its
// `perPoint` results of type R per point (SSBO_DEFORMED).
template <typename R>
std::vector<R> runKernel(GLuint program, const gl::Buffer& ubo, const engine::BendyBlock& block,
                         const std::vector<glm::vec4>& points, size_t perPoint) {
    glNamedBufferSubData(ubo.id(), 0, sizeof block, &block);
    gl::Buffer in = gl::makeBuffer(points.data(), points.size() * sizeof(glm::vec4));
    std::vector<R> results(points.size() * perPoint);
    gl::Buffer out = gl::makeBuffer(nullptr, results.size() * sizeof(R), GL_DYNAMIC_STORAGE_BIT);
    glUseProgram(program);
    glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_BENDY, ubo.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_CASTER_POSITIONS, in.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_DEFORMED, out.id());
    glDispatchCompute(GLuint((points.size() + engine::COMPUTE_GROUP_SIZE - 1) / engine::COMPUTE_GROUP_SIZE), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(out.id(), 0, GLsizeiptr(results.size() * sizeof(R)), results.data());
    return results;
}

// The box around a chain's control points grown by their radii.
void chainBox(const Chain<double>& ch, glm::dvec3& lo, glm::dvec3& hi) {
    lo = glm::dvec3(1e30);
    hi = glm::dvec3(-1e30);
    for (int i = 0; i <= 2 * ch.segments; ++i) {
        lo = glm::min(lo, ch.p[i] - glm::dvec3(ch.r[i]));
        hi = glm::max(hi, ch.p[i] + glm::dvec3(ch.r[i]));
    }
}

double angleDeg(const glm::dvec3& a, const glm::dvec3& b) {
    return glm::degrees(std::acos(glm::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)));
}

} // namespace

TEST(BendyParity, GlslAgreesWithCppOnRandomPointsAndChains) {
    auto ctx = gl::Context::create();
    ASSERT_TRUE(ctx.ok()) << ctx.error().toString();
    const std::string src = "#version 450 core\n" + std::string(shaders::serverShader("common_bendy.glsl")) + KERNEL;
    auto program = gl::buildProgram({{GL_COMPUTE_SHADER, "bendy_parity.comp", src}});
    ASSERT_TRUE(program.ok()) << program.error().toString();

    std::mt19937_64 rng(4242);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int CHAINS = 64, POINTS = 4096;
    long compared = 0, ambiguous = 0, validMismatch = 0, insideMismatch = 0;
    double worstQ = 0, worstLi9 = 0, worstLiX = 0, worstVW = 0, worstFloatQ = 0;
    gl::Buffer ubo = gl::makeBuffer(nullptr, sizeof(engine::BendyBlock), GL_DYNAMIC_STORAGE_BIT);
    for (int c = 0; c < CHAINS; ++c) {
        const Chain<float> chf = randomChain<float>(rng, 1 + c % 4);
        const Chain<double> chd = convert<double>(chf); // the same chain, derived in double
        glm::dvec3 lo, hi;
        chainBox(chd, lo, hi);
        std::vector<glm::vec4> pts(POINTS);
        for (auto& p : pts) p = glm::vec4(glm::vec3(lo + (hi - lo) * glm::dvec3(u(rng), u(rng), u(rng))), 1.f);
        const auto res = runKernel<glm::vec4>(program->id(), ubo, engine::toBendyBlock(chf, false), pts, 4);
        ASSERT_TRUE(ctx.value()->check("parity dispatch").ok());

        const double scale = glm::length(hi - lo);
        for (int i = 0; i < POINTS; ++i) {
            const glm::dvec3 Q(pts[size_t(i)]);
            const TubeCoords<double> d = inverseMap(chd, Q);
            const TubeCoords<float> f = inverseMap(chf, glm::vec3(pts[size_t(i)]));
            const glm::vec4* r = &res[size_t(i) * 4];
            const bool gValid = r[0].w > 0.5f, gInside = r[0].w > 1.5f;
            // Decisions that sit within rounding of a boundary may go either way in float: the
            // tube's surface, a segment's end, a foot near the source, or two feet equally central.
            const double r2 = d.v * d.v + d.w * d.w;
            TubeCoords<double> alt;
            const bool nearSurface = std::abs(r2 - 1.0) < 2e-3;
            const bool nearTie = d.valid && (int(r[1].w + 0.5f) != d.segment || std::abs(double(r[2].w) - d.t) > 1e-3) &&
                                 tubeCoordinates(chd, Q, int(r[1].w + 0.5f), double(r[2].w), alt) &&
                                 std::abs(alt.v * alt.v + alt.w * alt.w - r2) < 1e-3 && alt.inside == d.inside;
            if (nearSurface || nearTie || (d.valid && arcLength(chd, d.segment, d.t) < 1e-3 * scale)) {
                ++ambiguous;
                continue;
            }
            ++compared;
            if (gValid != d.valid) { ++validMismatch; continue; }
            if (!d.valid) continue;
            if (gInside != d.inside) { ++insideMismatch; continue; }
            const glm::dvec3 qd = deformedPoint(chd, d);
            if (std::getenv("DFB_PARITY_DEBUG") && glm::length(glm::dvec3(r[0]) - qd) / scale > 1e-4) {
                std::printf("outlier: d seg %d t %.6f v %.4f w %.4f in %d | gpu seg %d t %.6f v %.4f w %.4f | f seg %d t %.6f v %.4f w %.4f\n",
                            d.segment, d.t, d.v, d.w, int(d.inside), int(r[1].w + 0.5f), r[2].w, r[3].x, r[3].y,
                            f.segment, double(f.t), double(f.v), double(f.w));
            }
            worstQ = std::max(worstQ, glm::length(glm::dvec3(r[0]) - qd) / scale);
            worstLi9 = std::max(worstLi9, angleDeg(glm::dvec3(r[1]), lightDirection(chd, d, Q, false)));
            worstLiX = std::max(worstLiX, angleDeg(glm::dvec3(r[2]), lightDirection(chd, d, Q, true)));
            worstVW = std::max({worstVW, std::abs(double(r[3].x) - d.v), std::abs(double(r[3].y) - d.w)});
            if (f.valid && f.inside == d.inside) {
                worstFloatQ = std::max(worstFloatQ, glm::length(glm::dvec3(deformedPoint(chf, f)) - qd) / scale);
            }
        }
    }
    std::printf("compared %ld points (%ld within rounding of a decision boundary, skipped)\n", compared, ambiguous);
    std::printf("GLSL vs C++ double: valid mismatches %ld, inside mismatches %ld; |Q'| error <= %.3g of the scene size; "
                "eq. 9 direction <= %.4f deg; exact direction <= %.4f deg; (v, w) <= %.3g\n",
                validMismatch, insideMismatch, worstQ, worstLi9, worstLiX, worstVW);
    std::printf("C++ float vs C++ double: |Q'| error <= %.3g of the scene size\n", worstFloatQ);
    EXPECT_GT(compared, CHAINS * POINTS * 9 / 10);
    EXPECT_EQ(validMismatch, 0);
    EXPECT_EQ(insideMismatch, 0);
    // Tolerances: float evaluation of a cubic root and arc-length quadrature; 1e-4 of the scene
    // is a hundredth of a texel of a 2048 shadow map covering it, 0.05 degree is invisible in shading.
    EXPECT_LT(worstQ, 1e-4);
    EXPECT_LT(worstLi9, 0.05);
    EXPECT_LT(worstLiX, 0.05);
    EXPECT_LT(worstVW, 1e-3);
}

namespace {

const char* FOOTPRINT_KERNEL = R"(
layout(local_size_x = COMPUTE_GROUP_SIZE) in;
layout(std430, binding = SSBO_CASTER_POSITIONS) readonly buffer Points { vec4 points[]; };
layout(std430, binding = SSBO_DEFORMED) writeonly buffer Results { uint results[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(points.length())) return;
    uint mask = 0u;
    for (int k = 0; k < bendySegments(); ++k) {
        if (segmentFootprintContains(k, points[i].xyz)) mask |= 1u << uint(k);
    }
    results[i] = mask;
}
)";

} // namespace

// The footprint pre-pass and the single-segment shading (relight_mask.frag, BENDY_SINGLE) rest on
// segmentFootprintContains: the round cone around segment k's chord must hold every point of the
// tube around segment k (else pixels the light reaches would go dark), and it should hold fewer
// other points than the capsule of the largest radius it replaced (measured, printed).
TEST(BendyParity, SegmentRoundConesHoldTheirTubes) {
    auto ctx = gl::Context::create();
    ASSERT_TRUE(ctx.ok()) << ctx.error().toString();
    const std::string src = "#version 450 core\n" + std::string(shaders::serverShader("common_bendy.glsl")) + FOOTPRINT_KERNEL;
    auto program = gl::buildProgram({{GL_COMPUTE_SHADER, "bendy_footprint.comp", src}});
    ASSERT_TRUE(program.ok()) << program.error().toString();
    std::mt19937_64 rng(977);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int CHAINS = 48, POINTS = 4096;
    long tubePoints = 0, missed = 0, boxPoints = 0, inCone = 0, inCapsule = 0;
    gl::Buffer ubo = gl::makeBuffer(nullptr, sizeof(engine::BendyBlock), GL_DYNAMIC_STORAGE_BIT);
    for (int c = 0; c < CHAINS; ++c) {
        const Chain<float> chf = randomChain<float>(rng, 1 + c % 4);
        const Chain<double> chd = convert<double>(chf);
        glm::dvec3 lo, hi;
        chainBox(chd, lo, hi);
        // Half the points on or in a segment's tube (the rim included), half anywhere in the box.
        std::vector<glm::vec4> pts(POINTS);
        std::vector<int> segment(POINTS, -1);
        for (int i = 0; i < POINTS; ++i) {
            if (i % 2 == 0) {
                const int k = int(u(rng) * chd.segments) % chd.segments;
                const double t = u(rng), a = 6.283185307 * u(rng), r = i % 8 == 0 ? 1.0 : std::sqrt(u(rng));
                glm::dvec3 uh, vh, wh;
                tubeFrame(chd, k, t, uh, vh, wh);
                const glm::dvec3 P = chainPoint(chd, k, t) + chainRadius(chd, k, t) * r * (std::cos(a) * vh + std::sin(a) * wh);
                pts[size_t(i)] = glm::vec4(glm::vec3(P), 1.f);
                segment[size_t(i)] = k;
            } else {
                pts[size_t(i)] = glm::vec4(glm::vec3(lo + (hi - lo) * glm::dvec3(u(rng), u(rng), u(rng))), 1.f);
            }
        }
        const auto mask = runKernel<uint32_t>(program->id(), ubo, engine::toBendyBlock(chf, false), pts, 1);
        ASSERT_TRUE(ctx.value()->check("footprint dispatch").ok());
        for (int i = 0; i < POINTS; ++i) {
            const int k = segment[size_t(i)];
            if (k >= 0) {
                ++tubePoints;
                if (!(mask[size_t(i)] & (1u << k))) ++missed;
                continue;
            }
            // The capsule of the largest radius around the chord (the footprint before the cones).
            const glm::dvec3 P(pts[size_t(i)]);
            for (int s = 0; s < chd.segments; ++s) {
                ++boxPoints;
                inCone += (mask[size_t(i)] >> s) & 1u;
                const glm::dvec3 p0 = chd.p[2 * s], p1 = chd.p[2 * s + 1], p2 = chd.p[2 * s + 2];
                const double reach = (0.25 * glm::length(2.0 * p1 - p0 - p2) + std::max({chd.r[2 * s], chd.r[2 * s + 1], chd.r[2 * s + 2]})) * 1.01 + 1e-3;
                const double h = glm::clamp(glm::dot(P - p0, p2 - p0) / glm::dot(p2 - p0, p2 - p0), 0.0, 1.0);
                inCapsule += glm::length(P - p0 - (p2 - p0) * h) <= reach ? 1 : 0;
            }
        }
    }
    std::printf("%ld tube points, %ld outside their segment's round cone; of %ld (point, segment) pairs in the box, "
                "%ld in the round cone, %ld in the capsule of the largest radius\n",
                tubePoints, missed, boxPoints, inCone, inCapsule);
    EXPECT_EQ(missed, 0);
    EXPECT_GT(tubePoints, CHAINS * POINTS / 2 - 1);
    EXPECT_LT(inCone, inCapsule);
}
