// CPU/GPU parity of the BRDF lobes and the punctual falloff: the GLSL (server/shaders/common_brdf.glsl
// and common_falloff.glsl, as embedded for the
// relight shaders) runs in a compute shader through headless EGL on a grid of directions and
// materials, and must agree per sample with dfb/lightmath/Brdf.h.
//
// Tolerance per value: 1e-4 relative + 1e-6 absolute + 4 |C++ float - C++ double|. The last term
// is the sample's own float conditioning: at roughness 0.05 (alpha 0.0025) D changes by ~4/alpha^2
// relative per unit of N.H, so one float rounding of N.H near the peak moves it by several percent
// whichever implementation rounds; the GPU may round differently from C++ float but not by more
// than a few times what float itself costs there.

#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>
#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Falloff.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

namespace dfb::shaders {
std::string_view serverShader(std::string_view name);
}

using namespace dfb;
using namespace dfb::lightmath;

namespace {

// One sample: N, L, V, albedo, brdf (metallic, roughness, specular, occlusion), sheen (rgb,
// roughness), coat (weight, roughness, -, -): 7 vec4 in, 3 vec4 out.
const char* KERNEL = R"(
layout(local_size_x = 64) in;
struct Sample { vec4 N, L, V, albedo, brdf, sheen, coat; };
layout(std430, binding = 0) readonly buffer Samples { Sample samples[]; };
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(samples.length())) return;
    Sample s = samples[i];
    vec3 N = s.N.xyz, L = s.L.xyz, V = s.V.xyz;
    vec3 layered = evaluateLayeredBrdfCos(N, L, V, s.albedo.rgb, s.brdf, s.sheen, s.coat.xy);
    vec3 base = evaluateBrdfCos(N, L, V, s.albedo.rgb, s.brdf.x, s.brdf.y, s.brdf.z);
    vec3 H = normalize(L + V);
    float NdotH = max(dot(N, H), 0.0);
    float NdotL = max(dot(N, L), 0.0), NdotV = max(dot(N, V), 1e-4);
    float alpha = max(s.brdf.y * s.brdf.y, 1e-3), sheenAlpha = max(s.sheen.a * s.sheen.a, 1e-3);
    results[3u * i + 0u] = vec4(layered, 0.0);
    results[3u * i + 1u] = vec4(base, 0.0);
    results[3u * i + 2u] = vec4(distributionGGX(NdotH, alpha), visibilitySmithGGX(NdotL, NdotV, alpha),
                                distributionCharlie(NdotH, sheenAlpha), visibilityNeubelt(NdotL, NdotV));
}
)";

struct Sample {
    glm::vec4 N, L, V, albedo, brdf, sheen, coat;
};
static_assert(sizeof(Sample) == 7 * 16, "std430 array stride of struct Sample");

template <typename T> std::array<double, 10> cpu(const Sample& s) {
    using v3 = vec3<T>;
    const v3 N(s.N), L(s.L), V(s.V), albedo(s.albedo);
    const vec4<T> brdf(s.brdf), sheen(s.sheen);
    const vec2<T> coat(s.coat);
    const v3 layered = evaluateLayeredBrdfCos(N, L, V, albedo, brdf, sheen, coat);
    const v3 base = evaluateBrdfCos(N, L, V, albedo, brdf.x, brdf.y, brdf.z);
    const v3 H = glm::normalize(L + V);
    const T NdotH = std::max(glm::dot(N, H), T(0));
    const T NdotL = std::max(glm::dot(N, L), T(0)), NdotV = std::max(glm::dot(N, V), T(MIN_NDOTV));
    const T alpha = std::max(brdf.y * brdf.y, T(MIN_ALPHA)), sheenAlpha = std::max(sheen.a * sheen.a, T(MIN_ALPHA));
    return {double(layered.x), double(layered.y), double(layered.z), double(base.x), double(base.y), double(base.z),
            double(distributionGGX(NdotH, alpha)), double(visibilitySmithGGX(NdotL, NdotV, alpha)),
            double(distributionCharlie(NdotH, sheenAlpha)), double(visibilityNeubelt(NdotL, NdotV))};
}

// Runs `program` (local size 64; samples at SSBO 0, results at SSBO 1) over `samples` and reads
// back `perSample` vec4 results per sample.
template <typename S> std::vector<glm::vec4> dispatch(GLuint program, const std::vector<S>& samples, size_t perSample) {
    std::vector<glm::vec4> results(samples.size() * perSample);
    gl::Buffer in = gl::makeBuffer(samples.data(), samples.size() * sizeof(S));
    gl::Buffer out = gl::makeBuffer(nullptr, results.size() * sizeof(glm::vec4), GL_DYNAMIC_STORAGE_BIT);
    glUseProgram(program);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, in.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, out.id());
    glDispatchCompute(GLuint((samples.size() + 63) / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(out.id(), 0, GLsizeiptr(results.size() * sizeof(glm::vec4)), results.data());
    return results;
}

glm::vec3 spherical(float cosTheta, float phi) {
    const float s = std::sqrt(std::max(0.f, 1.f - cosTheta * cosTheta));
    return {s * std::cos(phi), s * std::sin(phi), cosTheta};
}

} // namespace

TEST(LightmathParity, GlslBrdfAgreesWithCppOnAGrid) {
    auto ctx = gl::Context::create();
    ASSERT_TRUE(ctx.ok()) << ctx.error().toString();
    const std::string_view brdf = shaders::serverShader("common_brdf.glsl");
    ASSERT_FALSE(brdf.empty());
    const std::string src = "#version 450 core\n" + std::string(brdf) + KERNEL;
    auto program = gl::buildProgram({{GL_COMPUTE_SHADER, "brdf_parity.comp", src}});
    ASSERT_TRUE(program.ok()) << program.error().toString();

    // Materials: roughness 0.05..1 x metallic 0, 0.5, 1 x (none, sheen, coat, both); a tilted
    // normal; L on a 7 x 8 grid of the hemisphere (plus below it), V at 4 angles; and L == V
    // (the highlight's centre, where rounding can push V.H above 1).
    std::vector<Sample> samples;
    const glm::vec3 N = glm::normalize(glm::vec3(0.1f, 0.2f, 1.f));
    const glm::vec3 T = glm::normalize(glm::cross(N, glm::vec3(1, 0, 0))), B = glm::cross(N, T);
    auto world = [&](const glm::vec3& d) { return glm::normalize(T * d.x + B * d.y + N * d.z); };
    const float roughness[] = {0.05f, 0.1f, 0.2f, 0.3f, 0.5f, 0.75f, 1.f};
    const float metallic[] = {0.f, 0.5f, 1.f};
    const glm::vec4 sheens[] = {glm::vec4(0.f), glm::vec4(0.9f, 0.6f, 0.3f, 0.3f), glm::vec4(0.f),
                                glm::vec4(0.4f, 0.4f, 0.5f, 0.8f)};
    const glm::vec4 coats[] = {glm::vec4(0.f), glm::vec4(0.f), glm::vec4(1.f, 0.05f, 0, 0), glm::vec4(0.6f, 0.5f, 0, 0)};
    const float viewDeg[] = {0.f, 30.f, 60.f, 85.f};
    int sameDirection = 0;
    for (float r : roughness)
        for (float m : metallic)
            for (int layer = 0; layer < 4; ++layer)
                for (float vd : viewDeg) {
                    const glm::vec3 V = world(spherical(std::cos(glm::radians(vd)), 0.7f));
                    auto add = [&](const glm::vec3& L) {
                        samples.push_back({glm::vec4(N, 0), glm::vec4(L, 0), glm::vec4(V, 0), glm::vec4(0.8f, 0.5f, 0.2f, 0),
                                           glm::vec4(m, r, 0.5f, 1.f), sheens[layer], coats[layer]});
                    };
                    for (int i = 0; i < 8; ++i)
                        for (int j = 0; j < 8; ++j) add(world(spherical(-0.1f + 1.1f * (i + 0.5f) / 8.f, 6.2831853f * j / 8.f)));
                    // The mirror direction and its neighbourhood: the specular peak.
                    const glm::vec3 R = glm::reflect(-V, N);
                    if (glm::dot(R, N) > 0.02f) {
                        add(R);
                        add(glm::normalize(R + T * 0.003f));
                        add(glm::normalize(R + B * 0.02f));
                    }
                    add(V);
                    ++sameDirection;
                }

    const std::vector<glm::vec4> results = dispatch(program->id(), samples, 3);
    ASSERT_TRUE(ctx.value()->check("brdf parity dispatch").ok());

    const char* names[] = {"layered.r", "layered.g", "layered.b", "base.r", "base.g", "base.b",
                           "D_GGX", "V_Smith", "D_Charlie", "V_Neubelt"};
    double worstRel[10] = {}, worstWell[10] = {}, worstRatio = 0;
    long compared = 0, bad = 0, nonFinite = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
        const auto d = cpu<double>(samples[i]);
        const auto f = cpu<float>(samples[i]);
        const float* g = &results[3 * i].x;
        const float gpu[10] = {g[0], g[1], g[2], g[4], g[5], g[6], g[8], g[9], g[10], g[11]};
        for (int k = 0; k < 10; ++k) {
            if (!std::isfinite(gpu[k])) {
                if (++nonFinite <= 5)
                    ADD_FAILURE() << names[k] << " is " << gpu[k] << " on the GPU at sample " << i
                                  << (glm::vec3(samples[i].L) == glm::vec3(samples[i].V) ? " (L == V)" : "");
                continue;
            }
            const double err = std::abs(double(gpu[k]) - d[k]);
            const double tol = 1e-4 * std::abs(d[k]) + 1e-6 + 4 * std::abs(f[k] - d[k]);
            ++compared;
            worstRatio = std::max(worstRatio, err / tol);
            if (std::abs(d[k]) > 1e-6) {
                worstRel[k] = std::max(worstRel[k], err / std::abs(d[k]));
                // Well conditioned: float itself costs under 1e-5 relative there.
                if (std::abs(f[k] - d[k]) < 1e-5 * std::abs(d[k])) worstWell[k] = std::max(worstWell[k], err / std::abs(d[k]));
            }
            if (err > tol && ++bad <= 10)
                ADD_FAILURE() << names[k] << " sample " << i << ": gpu " << gpu[k] << " cpu " << d[k] << " (float " << f[k]
                              << ") roughness " << samples[i].brdf.y << " metallic " << samples[i].brdf.x;
        }
    }
    std::printf("brdf parity: %zu samples (%d with L == V), %ld values, %ld outside tolerance, %ld not finite, "
                "worst error/tolerance %.3f\n",
                samples.size(), sameDirection, compared, bad, nonFinite, worstRatio);
    for (int k = 0; k < 10; ++k)
        std::printf("  %-10s worst relative error vs double %.2e (%.2e where float is within 1e-5)\n", names[k], worstRel[k],
                    worstWell[k]);
    EXPECT_EQ(bad, 0);
    EXPECT_EQ(nonFinite, 0);
}

namespace {

// One falloff sample: the light's frame and cone, its doors, a direction from the light and a
// squared distance; out: spotCone, barnDoors, inverseSquare.
const char* FALLOFF_KERNEL = R"(
layout(local_size_x = 64) in;
struct Sample { vec4 axis, right, up, doors, fromLight, cone; };
layout(std430, binding = 0) readonly buffer Samples { Sample samples[]; };
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(samples.length())) return;
    Sample s = samples[i];
    results[i] = vec4(spotCone(s.cone.xy, -s.fromLight.xyz, s.axis.xyz),
                      barnDoors(s.axis.xyz, s.right.xyz, s.up.xyz, s.doors, s.fromLight.xyz), inverseSquare(s.cone.z), 0.0);
}
)";

struct FalloffSample {
    glm::vec4 axis, right, up, doors, fromLight, cone;
};
static_assert(sizeof(FalloffSample) == 6 * 16, "std430 array stride of struct FalloffSample");

template <typename T> std::array<double, 3> cpuFalloff(const FalloffSample& s) {
    SpotFrame<T> f;
    f.axis = vec3<T>(s.axis);
    f.right = vec3<T>(s.right);
    f.up = vec3<T>(s.up);
    const vec3<T> d(s.fromLight);
    return {double(spotCone(vec2<T>(s.cone), -d, f.axis)), double(barnDoors(f, vec4<T>(s.doors), d)),
            double(inverseSquare(T(s.cone.z)))};
}

} // namespace

TEST(LightmathParity, GlslFalloffAgreesWithCppOnAGrid) {
    // Falloff.h's cone, barn doors and inverse square against server/shaders/common_falloff.glsl
    // (which relight_spot.frag and relight_bendy.frag call): spot directions from the rig's
    // frames (straight down, the |axis.y| = 0.99 switch of the up hint, oblique), cones of 5 to 85
    // degrees with penumbrae 0 .. outer, doors closed to open, directions on a grid across and
    // past the cone, distances 1e-7 .. 1e4.
    auto ctx = gl::Context::create();
    ASSERT_TRUE(ctx.ok()) << ctx.error().toString();
    const std::string_view falloff = shaders::serverShader("common_falloff.glsl");
    ASSERT_FALSE(falloff.empty());
    const std::string src = "#version 450 core\n" + std::string(falloff) + FALLOFF_KERNEL;
    auto program = gl::buildProgram({{GL_COMPUTE_SHADER, "falloff_parity.comp", src}});
    ASSERT_TRUE(program.ok()) << program.error().toString();

    std::vector<FalloffSample> samples;
    const glm::vec3 axes[] = {{0, -1, 0}, glm::normalize(glm::vec3(0.1411f, -0.99f, 0.f)), glm::normalize(glm::vec3(0.3f, -0.5f, -0.8f)),
                              glm::normalize(glm::vec3(-1, 0.2f, 0.1f))};
    const float outers[] = {5.f, 30.f, 60.f, 85.f};
    const float penumbraFractions[] = {0.f, 0.25f, 1.f};
    const glm::vec4 doorSets[] = {glm::vec4(10.f), glm::vec4(glm::radians(10.f), glm::radians(20.f), glm::radians(5.f), 10.f),
                                  glm::vec4(0.f, glm::radians(45.f), glm::radians(1.f), glm::radians(80.f))};
    const float dists[] = {1e-7f, 0.5f, 3.f, 1e4f};
    for (const glm::vec3& axis : axes) {
        const SpotFrame<float> fr = spotFrame(axis);
        for (float outer : outers)
            for (float pf : penumbraFractions)
                for (const glm::vec4& doors : doorSets)
                    for (int i = 0; i < 13; ++i)
                        for (int j = 0; j < 13; ++j) {
                            // Directions across the cone and past it: angles -1.2 .. 1.2 x outer.
                            const float tx = glm::radians(outer) * (-1.2f + 2.4f * float(i) / 12.f);
                            const float ty = glm::radians(outer) * (-1.2f + 2.4f * float(j) / 12.f);
                            const glm::vec3 d = glm::normalize(fr.axis + fr.right * std::tan(tx) + fr.up * std::tan(ty));
                            const vec2<float> cone = spotConeCosines(glm::radians(outer), glm::radians(outer) * pf);
                            samples.push_back({glm::vec4(fr.axis, 0), glm::vec4(fr.right, 0), glm::vec4(fr.up, 0), doors,
                                               glm::vec4(d, 0), glm::vec4(cone, dists[(i + j) % 4] * dists[(i + j) % 4], 0)});
                        }
    }
    // Behind the light: the doors are 0.
    samples.push_back({glm::vec4(0, -1, 0, 0), glm::vec4(0, 0, 1, 0), glm::vec4(1, 0, 0, 0), glm::vec4(10.f), glm::vec4(0, 1, 0, 0),
                       glm::vec4(0.5f, 0.6f, 1.f, 0)});

    const std::vector<glm::vec4> results = dispatch(program->id(), samples, 1);
    ASSERT_TRUE(ctx.value()->check("falloff parity dispatch").ok());

    // Tolerance: 1e-5 relative + 1e-6 absolute + 4 |C++ float - C++ double| (a smoothstep edge
    // amplifies the rounding of its input: the cone's edges are 1e-5 apart for a zero penumbra).
    // The cone adds its input's rounding: the GPU's dot may round differently from C++ float (FMA)
    // by an ulp or two of 1 (2.4e-7), which the smoothstep multiplies by its slope, at most
    // 1.5 / (cos inner - cos outer) (1.5e5 for a zero penumbra, where the edges are 1e-5 apart).
    // The doors add the GPU's atan error: GLSL 4.50 leaves atan's precision to the implementation
    // and llvmpipe's is about 1.5e-6 rad off near 0 (measured), which the door's soft edge
    // (slope up to 1.5 / (2 x BARN_DOOR_EDGE_RAD) = 172 per radian) turns into 2.6e-4; allowed:
    // 2e-6 rad times that slope.
    const double doorAtan = 2e-6 * 1.5 / (2 * BARN_DOOR_EDGE_RAD);
    const char* names[] = {"spotCone", "barnDoors", "inverseSquare"};
    long bad = 0, compared = 0, partial[3] = {};
    double worstRatio = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
        const auto d = cpuFalloff<double>(samples[i]);
        const auto f = cpuFalloff<float>(samples[i]);
        const float gpu[3] = {results[i].x, results[i].y, results[i].z};
        for (int k = 0; k < 3; ++k) {
            ++compared;
            if (d[k] > 1e-3 && d[k] < 1 - 1e-3) ++partial[k];
            const double err = std::abs(double(gpu[k]) - d[k]);
            const double tol = 1e-5 * std::abs(d[k]) + 1e-6 + 4 * std::abs(f[k] - d[k]) + (k == 1 ? doorAtan : 0.0) +
                               (k == 0 ? 2.4e-7 * 1.5 / (double(samples[i].cone.y) - double(samples[i].cone.x)) : 0.0);
            worstRatio = std::max(worstRatio, err / tol);
            if (!(err <= tol) && ++bad <= 10)
                ADD_FAILURE() << names[k] << " sample " << i << ": gpu " << gpu[k] << " cpu " << d[k] << " (float " << f[k]
                              << ") cone cosines " << samples[i].cone.x << " " << samples[i].cone.y << " cos to axis "
                              << glm::dot(glm::dvec3(samples[i].fromLight), glm::dvec3(samples[i].axis));
        }
    }
    std::printf("falloff parity: %zu samples, %ld values, %ld outside tolerance, worst error/tolerance %.3f; samples on a soft "
                "edge: cone %ld, doors %ld\n",
                samples.size(), compared, bad, worstRatio, partial[0], partial[1]);
    EXPECT_EQ(bad, 0);
    // The grid reaches the soft edges (not only 0 and 1), so the curves themselves are compared.
    EXPECT_GT(partial[0], 100);
    EXPECT_GT(partial[1], 20);
    EXPECT_EQ(results.back().y, 0.f);
}
