#pragma once
// An environment light's map on the CPU (docs/lighting.md, "Environment light"): the source
// resampled to a fixed base size and prefiltered per GGX roughness level for the split-sum
// specular (Karis, "Real Shading in Unreal Engine 4", 2013), with the level the spherical
// harmonics are projected from. GL-free, so that tests and the reference can use it.

#include <dfb/server/Engine.h>

#include <vector>

namespace dfb::engine {

/// Level k is widths[k] x widths[k] / 2 texels of RGBA floats, row 0 at the top (+Y),
/// prefiltered for GGX roughness k / (levels - 1) (level 0: the map itself, resampled); or, as a
/// cube map (prefilterEnvironment's cubeSize), level k is six faces of sizes[k]^2 texels, faces in
/// OpenGL's order +X, -X, +Y, -Y, +Z, -Z, texel (i, j) of a face at lightmath::cubeDirection(face,
/// (i + 0.5) / size, (j + 0.5) / size), widths holding the face sizes.
struct EnvLevels {
    bool cube = false;
    std::vector<int> widths;
    std::vector<std::vector<float>> rgba;
    /// The copy envProjectSh reads: the base box-filtered to at most 128 texels wide (an order-3
    /// expansion needs no more; 8k texels project in well under a millisecond per rotation).
    int shWidth = 0, shHeight = 0;
    std::vector<float> sh;
};

/// A map's sun (docs/lighting.md, "Environment light"): a small region far brighter than the
/// rest, taken out of the map and shaded as a directional light with a sharp shadow map, since
/// order-3 visibility cannot hold its shadow.
struct EnvSun {
    bool found = false;
    glm::vec3 direction{0.f, 1.f, 0.f}; ///< towards the sun, map space, unit
    glm::vec3 irradiance{0.f};          ///< its irradiance at normal incidence, integral of (L - fill) dw, RGB
};

/// Finds the sun of `map` (RGBA float lat-long) and replaces its texels by the radiance around it:
/// the brightest texel, when its luminance is over SUN_PEAK_OVER_MEAN times the map's mean; its
/// region the texels within SUN_RADIUS_DEG of it brighter than SUN_REGION_SHARE of the peak (and
/// than 20 times the mean); the fill the mean of the ring out to twice that radius below that.
/// Not found, and the map left as it was, when its irradiance's luminance is under minLuminance.
constexpr float SUN_PEAK_OVER_MEAN = 500.f, SUN_RADIUS_DEG = 6.f, SUN_REGION_SHARE = 0.01f;
EnvSun extractSun(ImageF& map, float minLuminance = 0.f);

/// The lights of `map` taken out one after another, each by extractSun on what the ones before
/// left (the brightest first), at most ENV_MAX_SUNS; `map` is left without them. One is not
/// enough indoors: interior.exr's brightest texel is a small lamp (irradiance 1.6), while its
/// window, found next, brings 3.1 and another lamp 0.6; with the window and the second lamp left
/// to the order-3 visibility, the diffuse error against the ray-traced reference was 14.0 % on
/// FlightHelmet and 6.1 % on the tabletop, with them taken out 5.0 % and 2.3 % (dfb-env-bench
/// --transfer-bands, 2026-12-06). Each costs a directional shadow map (re-rendered when the map
/// turns; dfb/protocol/Rig.h ENV_MAX_SUNS, ENV_LAMP_MAP_SIZE), so a light after the first is
/// taken only when it brings LAMP_SHARE_OF_SUN of the first's irradiance (luminance): the
/// window and the second lamp bring 196 % and 41 % of interior.exr's lamp; sunrise.exr's second,
/// 3.8 % of its sun, would cost a rotation at 960x540 about 25 ms (its map and its pass) for 0.7
/// points of diffuse error (7.0 -> 6.3 % on the tabletop, CPU model at 1,024 rays).
constexpr float LAMP_SHARE_OF_SUN = 0.1f;
std::vector<EnvSun> extractSuns(ImageF& map);

/// The levels of `src`, a latitude-longitude RGBA float image of any size: `levels` levels from
/// `baseWidth` texels wide (a power of two, >= 2^levels). Level k > 0 averages the map over the
/// GGX lobe of roughness k / (levels - 1) about each texel's direction with N = v = r,
/// importance-sampled (64 samples) from a box-filtered pyramid of the base at the lod of each
/// sample's solid angle (Colbert and Krivanek, "GPU-Based Importance Sampling", GPU Gems 3, 2007,
/// ch. 20). A constant map is filled without sampling.
/// With `cubeSize` > 0 the levels are a cube map's instead, faces of cubeSize >> k texels (at least
/// 1), each texel prefiltered the same way about its own direction (the engine's layout:
/// relight_env.frag reads it with a direction; at 960x540 on llvmpipe the rotation's frame took
/// 2-2.5 ms less than reading a lat-long map, whose latitude and longitude cost an atan and an acos
/// per read).
EnvLevels prefilterEnvironment(const ImageF& src, int levels, int baseWidth, int cubeSize = 0);

} // namespace dfb::engine
