#pragma once
// A glTF 2.0 scene flattened to world space: what the bake rasterises and what the relight server
// casts shadows with. Loaded through tinygltf; nothing here exposes tinygltf types.

#include <dfb/core/Result.h>

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// A decoded image: 8-bit RGBA, row 0 at the top (as glTF images are stored).
struct SceneImage {
    std::string name;
    int width = 0;
    int height = 0;
    std::vector<uint8_t> rgba; ///< width * height * 4 bytes
};

/// glTF texture = image + sampler. Wrap and filter values are the GL enums glTF uses.
struct SceneTexture {
    int image = -1;             ///< index into Scene::images
    int wrapS = 10497;          ///< GL_REPEAT (default), GL_CLAMP_TO_EDGE 33071, GL_MIRRORED_REPEAT 33648
    int wrapT = 10497;
    int magFilter = 9729;       ///< GL_LINEAR unless the sampler says GL_NEAREST (9728)
    int minFilter = 9987;       ///< GL_LINEAR_MIPMAP_LINEAR unless the sampler says otherwise
};

/// A material's reference to a texture: which texture, which UV set, and the UV transform of
/// KHR_texture_transform (uv' = transform * (u, v, 1)).
struct TextureRef {
    int texture = -1;       ///< index into Scene::textures; -1 = none
    int texCoord = 0;       ///< 0 or 1
    glm::mat3 transform{1.f};
    float scale = 1.f;      ///< normalTexture.scale or occlusionTexture.strength
    bool valid() const { return texture >= 0; }
};

enum class AlphaMode { Opaque, Mask, Blend };

/// glTF 2.0 metallic-roughness material with the extensions the bake evaluates
/// (docs/gbuffer-format.md lists how each maps to the G-buffer).
struct Material {
    std::string name;
    glm::vec4 baseColor{1.f}; ///< linear RGBA
    float metallic = 1.f;     ///< [0,1]
    float roughness = 1.f;    ///< [0,1]
    glm::vec3 emissive{0.f};  ///< linear, already multiplied by KHR_materials_emissive_strength
    bool doubleSided = false;
    AlphaMode alphaMode = AlphaMode::Opaque;
    float alphaCutoff = 0.5f;
    TextureRef baseColorTexture, metallicRoughnessTexture, normalTexture, occlusionTexture, emissiveTexture;
    // KHR_materials_specular: dielectric F0 = 0.04 * specularColor * specularFactor (ior 1.5).
    float specularFactor = 1.f;
    glm::vec3 specularColor{1.f};
    TextureRef specularTexture, specularColorTexture;
    // KHR_materials_sheen
    glm::vec3 sheenColor{0.f};
    float sheenRoughness = 0.f;
    TextureRef sheenColorTexture, sheenRoughnessTexture;
    // KHR_materials_clearcoat
    float clearcoat = 0.f;
    float clearcoatRoughness = 0.f;
    TextureRef clearcoatTexture, clearcoatRoughnessTexture;
};

/// One glTF primitive instanced by one node, transformed to world space.
/// Triangles are counter-clockwise seen from their front side (winding flipped for mirrored nodes).
struct MeshPart {
    uint32_t objectId = 0;   ///< 1-based index into Scene::objectNames (one object per mesh node)
    uint32_t materialId = 0; ///< 1-based index into Scene::materials
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;  ///< per vertex, unit; generated (flat) when the file has none
    std::vector<glm::vec4> tangents; ///< xyz unit, w = bitangent sign; from the file or generated
    std::vector<glm::vec2> uv0, uv1; ///< empty when the primitive has none
    std::vector<glm::vec4> colors;   ///< COLOR_0 (linear RGBA); empty when absent
    std::vector<uint32_t> indices;   ///< 3 per triangle
};

/// A camera of the scene (a node carrying a glTF camera), or one framed automatically.
struct SceneCamera {
    std::string name;
    glm::mat4 worldToCamera{1.f};
    float yfovRadians = 0.8f;
    float xmag = 1.f, ymag = 1.f; ///< orthographic half-extents (glTF orthographic.xmag/ymag)
    float aspect = 0.f; ///< 0 when the file does not fix it (the bake's width/height decides)
    float znear = 0.01f;
    float zfar = 0.f;   ///< 0 = infinite in glTF; the bake picks a far plane from the bounds
    bool orthographic = false;
};

/// A light of the file's KHR_lights_punctual extension, placed by its node.
struct SceneLight {
    std::string name;
    std::string type;               ///< "spot", "directional", "point" or "area"
    glm::vec3 position{0.f};        ///< world space
    glm::vec3 direction{0, 0, -1};  ///< world space, unit: the node's -Z
    glm::vec3 color{1.f};
    float intensity = 1.f;          ///< candela (point, spot) or lux (directional)
    float innerConeRadians = 0.f;
    float outerConeRadians = 0.785398f;
    // Area lights (docs/gbuffer-format.md, "Area lights in glTF": a node's extras.dfb_area_light,
    // KHR_lights_punctual having none): the node's -Z is `direction` (the emitting side), its +X
    // the emitter's width axis; intensity is the emitter's radiance in cd/m^2.
    bool disk = false;
    glm::vec2 size{1.f};             ///< width, height (a disk: diameter, unused), scene units
    glm::vec3 right{1, 0, 0};        ///< world space, unit: the node's +X
    std::string pattern;             ///< an image file relative to the asset folder, or empty
    glm::ivec2 shadowGrid{4, 4};
    /// The node's extras.dfb_light as JSON text (docs/gbuffer-format.md, "Lights in glTF"): the
    /// light's exact rig JSON, written by dfb's export; empty when the node has none. With it, the
    /// fields above are the node's stand-in for other tools (its KHR_lights_punctual light or
    /// dfb_area_light), or only its placement (`type` empty) when it has neither.
    std::string rigJson;
};

struct Bounds {
    glm::vec3 min{1e30f};
    glm::vec3 max{-1e30f};
    bool empty() const { return min.x > max.x; }
    void extend(const glm::vec3& p) {
        min = glm::min(min, p);
        max = glm::max(max, p);
    }
    glm::vec3 center() const { return 0.5f * (min + max); }
    float radius() const { return 0.5f * glm::length(max - min); }
};

struct Scene {
    std::string path;
    std::vector<MeshPart> parts;
    std::vector<Material> materials;        ///< materials[id - 1]; a default grey one is added when needed
    std::vector<SceneImage> images;
    std::vector<SceneTexture> textures;
    std::vector<std::string> objectNames;   ///< objectNames[id - 1]
    std::vector<SceneCamera> cameras;
    std::vector<SceneLight> lights; ///< KHR_lights_punctual, dfb_area_light and dfb_light nodes, in node order
    /// The default scene's extras.dfb_rig as JSON text (the exported rig's exposure, view
    /// transform and time; docs/gbuffer-format.md, "Lights in glTF"), or empty.
    std::string rigSettingsJson;
    Bounds bounds;

    size_t triangleCount() const;
    /// Bytes held by geometry and decoded images (for memory accounting).
    size_t memoryBytes() const;
};

/// Options of loadScene.
struct LoadOptions {
    bool loadImages = true; ///< decode textures (the bake needs them; shadow casting does not)
};

/// Loads the default scene (or scene 0) of a .glb or .gltf file. Fails with FileNotFound,
/// InvalidFile (not glTF, parse errors, bad accessors), MissingData (no triangles) or
/// InvalidValue (non-finite positions), naming the file and the offending mesh or node.
Result<Scene> loadScene(const std::string& path, const LoadOptions& options = {});

/// Loads a glTF from memory (.glb bytes or .gltf JSON text without external files); `name` is used
/// in messages. For the fuzz target and tests.
Result<Scene> loadSceneFromMemory(const std::string& name, const uint8_t* data, size_t size,
                                  const LoadOptions& options = {});

/// A camera that frames the scene's bounds: looking from the front (+Z), a little above, with the
/// given vertical field of view and aspect (the bounding sphere inside the narrower field).
SceneCamera autoFrameCamera(const Bounds& bounds, float yfovRadians, float aspect);

/// Margin of autoFrameCamera(Scene): the geometry fills the limiting axis of the image up to
/// this fraction on each side.
constexpr float AUTO_FRAME_MARGIN = 0.05f;

/// The bake's automatic framing: looking from the front (+Z), a little above, placed and aimed
/// so that the projection of every vertex of the scene fits the image with AUTO_FRAME_MARGIN
/// on the limiting axis and is centred on both (the nearest such eye along the view direction,
/// found by bisection; the bounding sphere fit leaves an object at ~12 % of the pixels).
SceneCamera autoFrameCamera(const Scene& scene, float yfovRadians, float aspect);

/// A look-at camera.
SceneCamera lookAtCamera(const glm::vec3& from, const glm::vec3& at, float yfovRadians);

} // namespace dfb
