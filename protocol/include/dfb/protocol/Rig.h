#pragma once
// The light rig: the shared vocabulary of the server and every client (docs/protocol.md).
// Plain data; JSON conversion and property-path edits are in Codec.h.

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace dfb {

using Vec3 = std::array<float, 3>;

/// Light types: a spot light, or a BendyLight (paper 000: a spot light whose light travels along a
/// chain of quadratic Bezier segments; docs/lighting.md).
/// Directional: parallel light along `direction` (the sun), intensity in lux, no cone.
/// Point: light in every direction from `position` (candela), omnidirectional (cube) shadows.
/// Area: a one-sided planar rectangle or disk centred at `position` emitting towards `direction`,
/// intensity = the emitter's radiance (cd/m^2, nits), optionally patterned (docs/lighting.md,
/// "Area lights"; one-shot shading, Wang et al. 2008).
/// BentArea: a rectangular area light whose light travels along four corner BendyLight chains
/// (paper 003 section 4.1): an m x n grid of interior BendyLights blended from the corners, each
/// with its deformed shadow map (docs/lighting.md, "Bent area lights").
enum class LightType { Spot, Bendy, Directional, Point, Area, BentArea, Environment };

/// A bent area light's corners: 0 = (-w/2, -h/2), 1 = (+w/2, -h/2), 2 = (-w/2, +h/2), 3 = (+w/2, +h/2)
/// in the emitter's (right, up) coordinates.
constexpr int BENT_AREA_CORNERS = 4;

/// An area light's outline: a rectangle `size[0]` x `size[1]`, or a disk of diameter `size[0]`.
enum class AreaShape { Rect, Disk };

/// How an area light is shaded (docs/lighting.md): one-shot approximate local shading (Wang et al.
/// 2008: any pattern, two lobes' point lights), or linearly transformed cosines (Heitz et al. 2016,
/// 2017: exact integration of a uniform emitter under the fitted GGX lobe; a pattern contributes
/// its mean colour). Auto: one-shot when the light has a pattern, LTC otherwise.
enum class AreaShading { Auto, OneShot, Ltc };

/// Most rows or columns of an area light's grid of shadow maps.
constexpr int MAX_AREA_SHADOW_GRID = 16;

/// The largest environment map a light may name, texels (a 32-bit float RGBA copy is 512 MiB).
constexpr int MAX_ENV_MAP_WIDTH = 8192, MAX_ENV_MAP_HEIGHT = 4096;
/// The prefiltered environment's lat-long base, texels wide (twice its height), from which it is
/// prefiltered into a cube map of ENV_PREFILTER_WIDTH / 4 texels a face, RGBA32F with its mip
/// chain: what an environment light holds on the GPU besides its contribution.
constexpr int ENV_PREFILTER_WIDTH = 512;
/// The shadow map's side of an environment map's sun (shaded as a directional light). 1024, not
/// 2048 as before 2026-12-06: the map is re-rendered at every turn of the environment, and at
/// 960x540 the tabletop's errors against the reference moved by under 0.1 point with it
/// (docs/operations.md) while a rotation's frame got 5-7 ms faster.
constexpr int ENV_SUN_MAP_SIZE = 1024;
/// Most lights taken out of one environment map (engine extractSuns: the sun, then lamps and
/// windows), and the shadow map's side of each after the first: they are dimmer than the first
/// (on the bundled maps 4-200 % of it) and extended, their shadows soft (each map is re-rendered
/// when the map turns).
constexpr int ENV_MAX_SUNS = 3;
constexpr int ENV_LAMP_MAP_SIZE = 1024;

/// Most Bezier segments a BendyLight chain may have (lightmath::MAX_SEGMENTS).
constexpr int MAX_BENDY_SEGMENTS = 8;

/// Interpolation from a key to the next one: straight lines, or a smooth Catmull-Rom curve through
/// the neighbouring keys (C1; the ends use their nearest neighbour as the missing one).
enum class Interp { Linear, Smooth };

/// A keyframe of one property: its value from `time` on, blended towards the next key.
struct Key {
    double time = 0.0;     ///< seconds on the session clock
    nlohmann::json value;  ///< a number or an array of numbers, as the property takes
    Interp interp = Interp::Linear;
};

/// One light. Intensities follow glTF KHR_lights_punctual units (candela for spot lights).
struct Light {
    std::string name;                 ///< unique in the rig; [A-Za-z0-9_-]{1,64}
    LightType type = LightType::Spot;
    bool enabled = true;
    Vec3 position{0.f, 3.f, 3.f};     ///< world space, scene units
    Vec3 direction{0.f, -0.70710678f, -0.70710678f}; ///< world space, towards where the light points; normalised on set
    Vec3 color{1.f, 1.f, 1.f};        ///< linear RGB, each >= 0
    float intensityCd = 50.f;         ///< candela (spot, BendyLight) or lux (directional), >= 0
    float coneAngleDeg = 35.f;        ///< outer half-angle of the cone, (0, 85] degrees
    float penumbraDeg = 8.f;          ///< width of the soft edge inside the cone, [0, coneAngleDeg]
    bool shadow = true;               ///< casts shadows
    int shadowMapSize = 2048;         ///< shadow-map side in texels, power of two in [64, 8192]
    float shadowBias = 0.15f;         ///< receiver offset along the normal, in shadow-map texels, [0, 16]
    /// Soft-shadow filter: radius of the percentage-closer filter in shadow-map texels, [0, 4]
    /// (0 = one bilinear comparison, 1 = 3x3 taps, r = (2r+1)^2 taps).
    int shadowFilter = 1;
    /// Spot lights: an image projected from the light across its cone (a "cookie" or gobo),
    /// multiplying its colour. A file name relative to the server's asset folder (PNG, JPEG, EXR,
    /// anything OpenImageIO reads); empty = none.
    std::string cookie;
    /// Spot lights: barn doors, the four flaps' half-angles from the axis in degrees,
    /// (left, right, top, bottom) in the light's frame (right = direction x up); 90 = open.
    /// Each in [0, 90]; light beyond a flap is cut with a 0.5-degree soft edge.
    std::array<float, 4> barnDoorsDeg{90.f, 90.f, 90.f, 90.f};
    /// Light linking by object id (1-based ids of the shot's manifest; paper 000 section 6.3
    /// compares BendyLights with linked lights). Non-empty `include`: the light lights only those
    /// objects; `exclude`: never those. Shading only: every object still casts shadows.
    std::vector<uint32_t> include;
    std::vector<uint32_t> exclude;

    // BendyLight chain (type Bendy). Control points are in the light's own frame, so that moving
    // or turning the light moves the whole tube (paper 000 section 5, "Direct Control"):
    // (a, b, c) is the world point position + a uL + b vL + c wL with uL = direction,
    // wL = normalize(cross(uL, up)), vL = cross(wL, uL), up = +Y (or +X when uL is vertical).
    // The source p[0] = (0, 0, 0) is implicit: controlPoints holds p[1..2K].
    std::vector<Vec3> controlPoints;  ///< 2K points, K = 1..MAX_BENDY_SEGMENTS, scene units
    std::vector<float> radii;         ///< 2K + 1 tube radii at p[0..2K], scene units, >= 0 (r[0] may be 0)
    std::vector<Vec3> colors;         ///< 2K + 1 linear RGB multipliers at p[0..2K], each >= 0
    bool exactDirection = false;      ///< exact flow-line tangent instead of paper eq. 9

    // Area light (type Area). Its frame: the normal n = direction (the emitting side), right =
    // normalize(cross(n, up)) and up' = cross(right, n) with up = +Y (+X when n is vertical),
    // both turned by `rollDeg` about n; width along right, height along up'.
    AreaShape areaShape = AreaShape::Rect;
    std::array<float, 2> areaSize{1.f, 1.f}; ///< width, height in scene units (a disk: diameter, unused), > 0
    float rollDeg = 0.f;              ///< turn of the emitter about its normal, degrees, [-360, 360]
    /// An RGB image across the emitter (its top row at the emitter's up edge), multiplying the
    /// colour; a file in the asset folder like `cookie`; empty = uniform.
    std::string pattern;
    std::array<int, 2> shadowGrid{4, 4}; ///< m x n shadow maps over the emitter, each in [1, MAX_AREA_SHADOW_GRID]
    AreaShading areaShading = AreaShading::Auto; ///< see AreaShading; shadesWithLtc decides Auto
    /// Set by the server: the one-shot radius factors (alpha, beta) fitted for the shape and
    /// pattern (Wang et al. 2008, section 3); (0.30, 0.57) before a fit.
    std::array<float, 2> alphaBeta{0.30f, 0.57f};

    // Bent area light (type BentArea): the emitter as an area light's rectangle (areaSize, rollDeg;
    // intensity its radiance), and four corner chains in the emitter's frame: corner c's point
    // (a, b, c') is its corner + a n + b up' + c' right. All four have K segments:
    // cornerPoints[c * 2K + i - 1] is corner c's p[i] (i = 1..2K), cornerRadii[c * (2K + 1) + i]
    // its r[i] (i = 0..2K). shadowGrid is the m x n grid of interior BendyLights, coneAngle and
    // penumbra each one's cone.
    std::vector<Vec3> cornerPoints;   ///< 4 x 2K points, scene units
    std::vector<float> cornerRadii;   ///< 4 x (2K + 1) radii, scene units, >= 0

    // Environment light (type Environment): radiance arriving from every direction around the
    // scene, from an HDR latitude-longitude image (its values are radiance in cd/m² per unit
    // `intensity`) or, without one, the constant `color`. Intensity is a unitless multiplier.
    /// An EXR or Radiance HDR file in the asset folder like `cookie` (float data only); empty =
    /// the constant colour.
    std::string envMap;
    /// The map's turn, degrees, each in [-360, 360]: yaw about +Y, then pitch about +X, then roll
    /// about +Z (docs/lighting.md, "Environment light"). The unrotated map's centre column looks
    /// along -Z, its top row at +Y.
    std::array<float, 3> envRotationDeg{0.f, 0.f, 0.f};
    /// Keyframes by property path relative to the light ("intensity", "position", "cp[2]", "r[1]",
    /// ...): every numeric property can be animated. Keys are kept sorted by time.
    std::map<std::string, std::vector<Key>> keys;

    /// Set by the server, not by clients: why the chain is doubtful (e.g. a self-intersecting
    /// tube, paper section 7); empty when fine.
    std::string warning;

    int segments() const { return int(controlPoints.size() / 2); }
    int cornerSegments() const { return int(cornerPoints.size() / (2 * BENT_AREA_CORNERS)); }
};

/// Whether an area light shades with linearly transformed cosines: `shading` "ltc", or "auto"
/// without a pattern.
inline bool shadesWithLtc(const Light& l) {
    return l.areaShading == AreaShading::Ltc || (l.areaShading == AreaShading::Auto && l.pattern.empty());
}

/// Makes `light` a BendyLight whose chain is straight along its axis, `length` long, in
/// `segments` segments, with radii matching its cone: it renders exactly like the spot light.
void makeStraightChain(Light& light, float length, int segments = 2);

/// Gives `light` four straight corner chains along its normal, `length` long, in `segments`
/// segments, radii matching its cone (a bent area light that renders as the straight one).
void makeStraightCorners(Light& light, float length, int segments = 2);

/// How linear radiance becomes display values (after exposure): the sRGB transfer function alone,
/// or a filmic curve (the ACES fitted curve of Narkowicz 2016, shoulder and toe) then sRGB.
enum class ViewTransform { Srgb, Filmic };

/// The whole rig plus the view settings that apply to the beauty image.
/// A named set of lights (docs/protocol.md "Light groups"): what the page mutes, solos and
/// scales in one edit. Membership follows renames; a light deleted with the rig replaced leaves.
struct LightGroup {
    std::string name;
    std::vector<std::string> lights;
    bool operator==(const LightGroup&) const = default;
};
inline constexpr size_t MAX_LIGHT_GROUPS = 64;

struct Rig {
    uint64_t version = 0;             ///< bumped by the server on every accepted change
    float exposureStops = 0.f;        ///< exposure in stops (image * 2^exposure), [-20, 20]
    ViewTransform viewTransform = ViewTransform::Srgb;
    double time = 0.0;                ///< session clock, seconds: where keyframes are evaluated
    std::vector<Light> lights;
    std::vector<LightGroup> groups;   ///< named sets of lights, at most MAX_LIGHT_GROUPS

    Light* find(const std::string& name);
    const Light* find(const std::string& name) const;
};

/// A rig suited to a scene whose bounding box is [bmin, bmax]: a key spot light above, in front
/// and to the left casting shadows, and a soft fill from the right without shadows.
Rig defaultRig(const Vec3& bmin, const Vec3& bmax);

} // namespace dfb
