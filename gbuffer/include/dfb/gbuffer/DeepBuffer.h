#pragma once
// The deep framebuffer in memory: one shot from one fixed camera, with every material input the
// relight loop needs evaluated per sample at bake time (paper 004 section 4.1). The file format is
// specified in docs/gbuffer-format.md; ExrIO.h reads and writes it.

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// Version of the file format written by this build (header attribute `dfb.formatVersion`).
/// Readers accept versions 1 to 7; see docs/gbuffer-format.md (version 3 added the environment
/// transfer, `env.sh0` .. `env.sh8`; version 4 the specular lobe, `env.lobe.u/v/vis`; version 5
/// the five-band transfer, `env.sh0` .. `env.sh24`; version 6 the near-field horizon,
/// `horizon.h0` .. `horizon.h15`; version 7 the specular lobe's rings, `env.ring0.u` ..
/// `env.ring2.roughness`).
constexpr int GBUFFER_FORMAT_VERSION = 7;

/// Spherical-harmonic bands of the environment transfer a bake stores unless told otherwise
/// (dfb-bake --env-bands): five (25 coefficients). The shadowed diffuse's mean error against the
/// ray-traced reference under an outdoor map is 7-9 % at three bands and 3-5 % at five
/// (docs/lighting.md, "Environment light").
constexpr int ENV_TRANSFER_BANDS = 5;
/// Floats per sample of DeepBuffer::envTransfer whatever its band count: room for five bands
/// (the relight engine's lightmath::SH_TRANSFER_COEFFICIENTS, dfb/lightmath/SphericalHarmonics.h).
constexpr int ENV_TRANSFER_COEFFICIENTS = ENV_TRANSFER_BANDS * ENV_TRANSFER_BANDS;
/// The band counts a transfer may have: 3 (9 coefficients, format versions 3 and 4, or
/// dfb-bake --env-bands 3) or 5.
constexpr bool validEnvBands(int bands) { return bands == 3 || bands == ENV_TRANSFER_BANDS; }
/// Floats per sample of the environment light's specular lobe (DeepBuffer::envLobe).
constexpr int ENV_LOBE_COMPONENTS = 3;
/// Rings of the specular lobe (DeepBuffer::envRings; the relight engine's
/// lightmath::ENV_LOBE_RINGS, dfb/lightmath/Environment.h, which says why 3), and floats per
/// sample: per ring its octahedral direction (2), visible share and prefiltered roughness.
constexpr int ENV_LOBE_RINGS = 3;
constexpr int ENV_RING_COMPONENTS = 4 * ENV_LOBE_RINGS;

/// Azimuths per sample of the near-field horizon (DeepBuffer::horizon; the relight engine's
/// lightmath::HORIZON_AZIMUTHS, dfb/lightmath/Horizon.h, which says why 16).
constexpr int HORIZON_AZIMUTHS = 16;
/// The distance a bake traces the near-field horizon over unless told otherwise (dfb-bake
/// --horizon-radius), as a fraction of the scene's bounding radius: about 16 texels of a 2048
/// shadow map across the scene, past the one-texel lift and the grazing receivers' depth slope
/// within which a map cannot tell a receiver from its occluder. Measured on the default scene's
/// sun against ray-traced shadows: 0.004 leaves 37 of 2,125 shadowed pixels lit, 0.016 23, 0.05
/// 19 but shadows 29 lit ones (22 at 0.016): a horizon over a longer reach closes on occluders
/// its 16 azimuths resolve less well.
constexpr float HORIZON_RADIUS_FRACTION = 0.016f;

/// Largest number of rays per sample the bake traces for the environment transfer (dfb-bake
/// --env-rays). A bound on cost: a 960x540 shot at 4096 rays is 2 billion rays (64 times the
/// default's 64), while the estimate's error, at most 0.5 / sqrt(rays) of the ambient visibility
/// for independent rays (0.8 % at 4096; less with the bake's stratified pattern), is already
/// below what a low-frequency (order-3) environment shows.
constexpr int MAX_ENV_RAYS = 4096;

/// Largest number of samples per pixel a bake may take (and a file may hold per pixel).
/// 64 = an 8x8 stratified grid, beyond which box-filtered edges no longer improve visibly.
constexpr int MAX_SAMPLES_PER_PIXEL = 64;

/// The camera the shot was baked from.
/// Conventions (glTF / OpenGL): camera space is right-handed with the camera looking down -Z and
/// +Y up; NDC is the OpenGL cube [-1,1]^3 after the perspective divide, +X right, +Y up.
/// Pixel (x, y), with y = 0 the top row, has its centre at
///   ndc.x = (x + 0.5) / width * 2 - 1,   ndc.y = 1 - (y + 0.5) / height * 2.
struct CameraInfo {
    std::string name;             ///< glTF camera or node name, "auto" or "lookat"
    bool orthographic = false;    ///< projection kind; orthographic views have parallel view rays
    glm::mat4 worldToCamera{1.f}; ///< view matrix (column-vector convention: c = M * w)
    glm::mat4 worldToNDC{1.f};    ///< projection * view; divide by w to get NDC
    float yfovRadians = 0.8f;     ///< vertical field of view, radians, in (0, pi); 0 when orthographic
    float ymag = 0.f;             ///< orthographic half-height, scene units; 0 when perspective
    float aspect = 1.f;           ///< width / height
    float znear = 0.1f;           ///< near plane distance, scene units, > 0
    float zfar = 1000.f;          ///< far plane distance, scene units, > znear

    /// World-space position of the camera (inverse of worldToCamera applied to the origin).
    glm::vec3 position() const { return glm::vec3(glm::inverse(worldToCamera)[3]); }
    /// Unit direction the camera looks along, world space.
    glm::vec3 forward() const { return -glm::normalize(glm::vec3(glm::inverse(worldToCamera)[2])); }
    /// The unit direction from world point P towards the eye: -forward() for orthographic views
    /// (the relight shaders' viewVector).
    glm::vec3 towardsEye(const glm::vec3& P) const { return orthographic ? -forward() : glm::normalize(position() - P); }
};

/// Per-sample surface data. A pixel holds 0..MAX_SAMPLES_PER_PIXEL samples, each a surface
/// fragment with its own coverage A (the coverages of a pixel add up to at most 1).
///
/// Memory layout: the samples of pixel (x, y) are the indices
///   [sampleOffset[p], sampleOffset[p + 1]) with p = y * width + x (row 0 at the top);
/// every layer is a planar array of `components` floats per sample: element (s, c) of a layer
/// is at index `s * components + c`.
///
/// A flat buffer (one sample per pixel, e.g. read from a flat EXR) stores a sample for every
/// pixel, uncovered pixels having A = 0; then sample index == pixel index.
struct DeepBuffer {
    int width = 0;
    int height = 0;
    int samplesPerPixel = 1;            ///< the bake's sampling rate (header dfb.samplesPerPixel)
    std::vector<uint32_t> sampleOffset; ///< width * height + 1 entries

    std::vector<float> P;        ///< 3: world-space position, scene units
    std::vector<float> N;        ///< 3: shading normal (after normal mapping), world space, unit
    std::vector<float> Ng;       ///< 3: geometric normal, world space, unit (shadow bias)
    std::vector<float> T;        ///< 4: tangent xyz (unit, world space), w = bitangent sign (+-1)
    std::vector<float> Z;        ///< 1: camera depth (distance along the view axis), scene units
    std::vector<float> albedo;   ///< 3: linear base colour, [0,1]
    std::vector<float> brdf;     ///< 4: metallic, roughness, specular, occlusion, each in [0,1]
    std::vector<float> sheen;    ///< 4: sheen colour RGB (linear), sheen roughness
    std::vector<float> coat;     ///< 2: clear-coat weight, clear-coat roughness
    std::vector<float> emission; ///< 3: emitted radiance, linear, >= 0
    /// 25 per sample (ENV_TRANSFER_COEFFICIENTS), empty when not baked: the diffuse shadowed
    /// transfer of the environment light (Sloan, Kautz and Snyder 2002, section 4),
    ///   T_i = (1/pi) * integral over the sphere of V(w) max(0, N.w) Y_i(w) dw,
    /// N the shading normal, V(w) = 1 where a ray from the sample in world direction w escapes the
    /// scene, Y_i the basis of dfb/lightmath/SphericalHarmonics.h (world space, +Y up). The
    /// sample's diffuse radiance under an environment with coefficients L_i is
    /// albedo x sum_i L_i T_i; T_0 x 2 sqrt(pi) is its ambient visibility (1 = unoccluded).
    /// Only the first envBands^2 coefficients of a sample are the transfer; the rest are 0.
    /// Zero on uncovered samples (A = 0). Layers that resize or copy samples keep it empty or
    /// sized sampleCount() * ENV_TRANSFER_COEFFICIENTS, never anything else.
    std::vector<float> envTransfer;
    /// 3 per sample (ENV_LOBE_COMPONENTS), empty when not baked (format version 4; baked with
    /// the transfer): the sample's GGX specular lobe as the shot's camera sees it (the view is
    /// fixed, so is the lobe), against the scene: over the lobe's reflected directions l with
    /// weights w(l) = the BRDF's D Vis N.l without Fresnel (lightmath::ggxLobeWeight), the octahedral
    /// encoding (lightmath::octEncode) of the visible directions' weighted mean direction
    /// (components 0, 1) and the visible share sum w V / sum w (component 2, [0,1]). The
    /// environment light reads its prefiltered map towards that direction and scales by that share
    /// (relight_env.frag; docs/lighting.md, "Environment light"). Zero on uncovered samples.
    std::vector<float> envLobe;
    /// ENV_RING_COMPONENTS per sample, empty when not baked (format version 7; baked with the
    /// lobe): the same lobe's rings (lightmath::lobeRing: its GGX samples split by the half
    /// vector's polar coordinate into ENV_LOBE_RINGS equal shares, the core first), four values
    /// per ring r at 4r: the octahedral encoding of its visible directions' weighted mean
    /// direction (0, 1; the mirror direction where none is visible), its visible weight's share
    /// of the whole lobe's weight (2, [0,1]; the rings' shares add to envLobe's), and the
    /// roughness of the prefiltered map whose kernel is as wide as its visible part
    /// (lightmath::prefilterRoughnessForResultant of |sum w l| / sum w; 3, [0,1]). The
    /// environment light reads the map once per ring (relight_env.frag; docs/lighting.md,
    /// "Environment light"). Zero on uncovered samples.
    std::vector<float> envRings;
    /// HORIZON_AZIMUTHS per sample, empty when not baked (format version 6): the near-field
    /// horizon (dfb/lightmath/Horizon.h). Value k is the sine of the lowest elevation above the
    /// sample's geometric plane at which a ray from P + Ng x (1e-5 x scene radius) towards azimuth
    /// k (lightmath::horizonDirection, in the frame lightmath::horizonFrame gives the geometric
    /// normal as stored in half floats) meets no triangle within horizonRadius; in [0, 1], 0 where
    /// the sample sees the sky down to its plane, 1 where nothing within reach is open. The relight
    /// shaders shadow a straight light's direction below it (docs/lighting.md, "Shadows"). Zero on
    /// uncovered samples.
    std::vector<float> horizon;
    std::vector<float> A;        ///< 1: coverage in [0,1]
    std::vector<uint32_t> objectId;   ///< 1: object id (1-based index into objectNames; 0 = none)
    std::vector<uint32_t> materialId; ///< 1: material id (1-based index into materialNames; 0 = none)

    CameraInfo camera;
    std::string sourcePath;                 ///< the glTF scene the shot was baked from
    std::string sourceSha256;               ///< lowercase hex SHA-256 of that file ("" if unknown)
    std::vector<std::string> objectNames;   ///< objectNames[id - 1] is the glTF node name
    std::vector<std::string> materialNames; ///< materialNames[id - 1] is the glTF material name
    /// Rays per sample the environment transfer was estimated with (header dfb.envRays), 1..
    /// MAX_ENV_RAYS; 0 when envTransfer is empty (not baked) or the file does not say.
    int envRays = 0;
    /// Bands of envTransfer (3 or 5: validEnvBands) when it is baked: files write the channels
    /// env.sh0 .. env.sh{envBands^2 - 1}, and the relight shader reads that many.
    int envBands = ENV_TRANSFER_BANDS;
    /// The distance the horizon was traced over, scene units (header dfb.horizonRadius); 0 when
    /// horizon is empty.
    float horizonRadius = 0.f;

    size_t pixelCount() const { return static_cast<size_t>(width) * static_cast<size_t>(height); }
    size_t sampleCount() const { return sampleOffset.empty() ? 0 : sampleOffset.back(); }
    /// True when every pixel holds exactly one sample (a flat image).
    bool isFlat() const;
    uint32_t firstSample(int x, int y) const { return sampleOffset[size_t(y) * size_t(width) + size_t(x)]; }
    uint32_t pixelSamples(int x, int y) const {
        const size_t p = size_t(y) * size_t(width) + size_t(x);
        return sampleOffset[p + 1] - sampleOffset[p];
    }

    /// True when the environment transfer is baked: envTransfer holds 25 floats per sample.
    bool hasEnvTransfer() const { return !envTransfer.empty(); }
    /// True when the specular lobe is baked: envLobe holds 3 floats per sample.
    bool hasEnvLobe() const { return !envLobe.empty(); }
    /// True when the lobe's rings are baked: envRings holds ENV_RING_COMPONENTS floats per sample.
    bool hasEnvRings() const { return !envRings.empty(); }
    /// True when the near-field horizon is baked: horizon holds HORIZON_AZIMUTHS floats per sample.
    bool hasHorizon() const { return !horizon.empty(); }

    /// Allocates a flat buffer: one zero-filled sample per pixel.
    void allocate(int w, int h);
    /// Allocates `counts[p]` zero-filled samples for each pixel p. The optional envTransfer,
    /// envLobe, envRings and horizon are left empty (envRays and horizonRadius 0): a bake or a reader that
    /// has them allocates them after this.
    void allocateSamples(int w, int h, const std::vector<uint32_t>& counts);

    /// Sample accessors.
    glm::vec3 position(size_t s) const { return {P[s * 3], P[s * 3 + 1], P[s * 3 + 2]}; }
    glm::vec3 normal(size_t s) const { return {N[s * 3], N[s * 3 + 1], N[s * 3 + 2]}; }
    /// Pixel accessors for flat buffers (the pixel's first sample).
    glm::vec3 position(int x, int y) const { return position(firstSample(x, y)); }
    glm::vec3 normal(int x, int y) const { return normal(firstSample(x, y)); }
    /// Total coverage of a pixel (sum over its samples).
    float coverage(int x, int y) const;
};

} // namespace dfb
