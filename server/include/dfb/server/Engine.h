#pragma once
// The relighting engine: relights a deep framebuffer on the GPU through headless EGL
// (DESIGN section 6). Public interface free of GL types; the GL implementation is in src/engine.
//
// Threading: an Engine owns a GL context that is current on the thread that created it. Create,
// use and destroy it on one thread (the server's render thread).

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/protocol/Rig.h>

#include <glm/glm.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <optional>
#include <vector>

namespace dfb {

/// An 8-bit RGBA image, row 0 at the top: pixel (x, y) starts at byte `(y * width + x) * 4`.
struct Image8 {
    int width = 0;
    int height = 0;
    std::vector<uint8_t> rgba;
};

/// A linear float RGBA image, row 0 at the top: pixel (x, y) starts at `(y * width + x) * 4`.
struct ImageF {
    int width = 0;
    int height = 0;
    std::vector<float> rgba;
};

/// A named float image: one layer of a multi-layer output (ImageCodec's encodeExr).
struct NamedImageF {
    std::string name; ///< empty = the beauty (main R, G, B, A channels); otherwise a light's name
    ImageF image;
};

/// Triangles that cast shadows, in world space: 3 indices per triangle into `positions`.
struct ShadowGeometry {
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    /// indices[0, closedIndexCount) are meshes that are closed and consistently wound: their
    /// shadow maps need only the faces turned away from the light (front faces are culled, about
    /// half the rasterisation); the rest is drawn two-sided.
    size_t closedIndexCount = 0;
    /// indices[planarIndexStart, end) are open planar meshes (a ground plane, a wall), the plane of
    /// each in `planes` (xyz unit normal n, w = d: n . x = d). A light on the receivers' side of
    /// all of them leaves them out of its shadow map: they cannot occlude anything (see
    /// docs/lighting.md). Default: none.
    size_t planarIndexStart = ~size_t(0);
    std::vector<glm::vec4> planes;
    /// Runs of up to 2048 triangles of one mesh, with their bounds, in index order: a shadow map
    /// draws only the runs whose box reaches into its frustum's sides (a point light's cube face
    /// sees a sixth of the scene). Empty: one range of everything, never culled.
    struct Part {
        size_t firstIndex = 0, indexCount = 0;
        glm::vec3 min{0.f}, max{0.f};
        uint32_t objectId = 0; ///< the mesh's object id (MeshPart::objectId; 0 = unknown)
    };
    std::vector<Part> parts;
};

/// The plane (n, d) of a mesh whose vertices all lie within 1e-5 of its extent of one plane, or
/// nothing.
std::optional<glm::vec4> meshPlane(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices);

/// True when the triangles (3 indices each into `positions`) form closed surfaces wound
/// consistently: vertices at equal positions are welded, and then every directed edge a->b has
/// exactly one partner b->a. Degenerate triangles (two welded corners alike) are ignored.
bool isClosedMesh(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices);

/// Every triangle of a scene as one shadow-casting mesh, the closed mesh parts first.
ShadowGeometry shadowCasters(const Scene& scene);

/// Makes the C library keep freed heap memory for reuse instead of handing it back to the
/// system after every frame. llvmpipe allocates and frees its per-frame memory (binning, vertex
/// data); by default glibc trims the heap's top and unmaps large blocks, and where those blocks
/// end up at the top every frame page-faults fresh pages in again (measured: a 4-spp shot's spot
/// position edit 65 -> 36 ms, the shadow map 37 -> 14 ms). Process-wide; call once at start
/// (dfb-server and the benchmarks do).
void keepFreedMemoryForFrames();
/// Hands the heap's free memory back to the system (malloc_trim): after a session closes, whose
/// textures (on llvmpipe) and buffers the tuning above would otherwise keep in the process.
void releaseFreedMemory();

/// Where the time of one render went, in milliseconds of wall time (GPU work is waited for at
/// each stage boundary, so the split is honest on llvmpipe and on discrete GPUs).
struct FrameStats {
    double shadowMs = 0;
    double shadeMs = 0;
    double compositeMs = 0;
    double readbackMs = 0;
    int shadowMapsRendered = 0;
    /// Caster triangles those maps were rendered from, summed over the maps (open planar meshes
    /// that cannot occlude a light are left out of its map; a BendyLight's sort on the GPU may
    /// drop more).
    long shadowCasterTriangles = 0;
    /// BendyLight maps whose tessellation limit the work bound lowered (a sharply narrowing
    /// chain asks the highest level of most triangles: millions of triangles a frame otherwise).
    int subdivisionLowered = 0;
    int lightsShaded = 0;
};

/// Most cells per side of an area light's reference (Engine::renderAreaReference): 64 x 64 = 4096
/// BRDF evaluations per sample.
constexpr int MAX_AREA_REFERENCE_CELLS = 64;

class Engine {
public:
    /// Uploads the G-buffer and the shadow casters once. Fails with GpuError when no GL 4.5 core
    /// context can be created or a shader fails to build, InvalidValue for an empty buffer.
    static Result<std::unique_ptr<Engine>> create(const DeepBuffer& gbuffer, const ShadowGeometry& casters);
    virtual ~Engine() = default;

    /// Renders the beauty image for `rig`. Re-renders only what changed since the last call:
    /// a light whose position, direction, cone or shadow settings changed gets a new shadow map;
    /// any other change of a light re-shades only that light; the others come from the cache.
    virtual Result<Image8> render(const Rig& rig, FrameStats* stats = nullptr) = 0;

    /// Renders like render() but returns the linear sum of emission and light contributions,
    /// before exposure and the view transform (for compositing and tests); alpha 1.
    virtual Result<ImageF> renderLinear(const Rig& rig) = 0;

    /// One light's contribution alone (linear radiance, before exposure), from the same cache as
    /// the beauty image. Fails with MissingData for an unknown light.
    virtual Result<ImageF> renderLightLinear(const Rig& rig, const std::string& lightName) = 0;

    /// An area light's reference (docs/lighting.md, "Area lights"): like renderLightLinear, but
    /// shaded by dense stratified sampling of the emitter (cells x cells, each with the pattern's
    /// exact integral over it, at its centre, with the full BRDF) instead of one-shot, with the
    /// same shadow visibility: the difference to renderLightLinear is one-shot's error. Fails with
    /// MissingData for an unknown light, InvalidValue for one that is not an area light or cells
    /// outside 1..MAX_AREA_REFERENCE_CELLS.
    virtual Result<ImageF> renderAreaReference(const Rig& rig, const std::string& lightName, int cells = 32) = 0;

    /// Light groups for compositing: the linear beauty (name "", alpha 1) followed by the linear
    /// contribution of every enabled light (named after it), so that beauty = emission + the sum
    /// of the light layers. Before exposure, like renderLinear().
    virtual Result<std::vector<NamedImageF>> renderLayers(const Rig& rig) = 0;

    /// The shadow mask of one light of the rig: per pixel, r = coverage-weighted visibility (0..1)
    /// of the samples the light reaches (inside its cone, facing it), g = the coverage of those
    /// samples (0 where the light does not reach). Fails with MissingData for an unknown light.
    virtual Result<ImageF> renderShadowMask(const Rig& rig, const std::string& lightName) = 0;

    /// Most pieces one caster edge is cut into for a BendyLight's deformed shadow map (adaptive
    /// tessellation, 1..64; default 64). 1 disables subdivision (for comparisons).
    virtual void setShadowSubdivisionLimit(int maxLevel) = 0;

    /// Where cookie images are read from (Light::cookie names a file in it); default ".".
    virtual void setAssetDirectory(std::string dir) = 0;

    /// Preview mode, for frames rendered while a control is being dragged (progressive
    /// refinement): shadow maps that must be re-rendered are rendered at a quarter of their size
    /// (at least 256), and lights that must be re-shaded are shaded at half resolution (every
    /// second pixel, upsampled). The next render with preview off re-renders both at full quality.
    /// renderLightLinear, renderShadowMask and renderLayers are always full quality.
    virtual void setPreview(bool preview) = 0;

    /// "renderer | GL version | EGL platform".
    virtual std::string deviceDescription() const = 0;
    virtual int width() const = 0;
    virtual int height() const = 0;

protected:
    Engine() = default;
};

} // namespace dfb
