#pragma once
// A glTF 2.0 scene flattened to world space: what the bake rasterises and what the relight server
// casts shadows with. Loaded through tinygltf; nothing here exposes tinygltf types.

#include <dfb/core/Result.h>

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// glTF metallic-roughness material, factors only (textures come with the full bake, issue 3).
struct Material {
    std::string name;
    glm::vec4 baseColor{1.f}; ///< linear RGBA
    float metallic = 1.f;     ///< [0,1]
    float roughness = 1.f;    ///< [0,1]
    glm::vec3 emissive{0.f};  ///< linear, already multiplied by KHR_materials_emissive_strength
    bool doubleSided = false;
};

/// One glTF primitive instanced by one node, transformed to world space.
/// Triangles are counter-clockwise seen from their front side (winding flipped for mirrored nodes).
struct MeshPart {
    uint32_t objectId = 0;   ///< 1-based index into Scene::objectNames (one object per mesh node)
    uint32_t materialId = 0; ///< 1-based index into Scene::materials
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals; ///< per vertex, unit; generated (flat) when the file has none
    std::vector<uint32_t> indices;  ///< 3 per triangle
};

/// A camera of the scene (a node carrying a glTF camera), or one framed automatically.
struct SceneCamera {
    std::string name;
    glm::mat4 worldToCamera{1.f};
    float yfovRadians = 0.8f;
    float aspect = 0.f; ///< 0 when the file does not fix it (the bake's width/height decides)
    float znear = 0.01f;
    float zfar = 0.f;   ///< 0 = infinite in glTF; the bake picks a far plane from the bounds
    bool orthographic = false;
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
    std::vector<std::string> objectNames;   ///< objectNames[id - 1]
    std::vector<SceneCamera> cameras;
    Bounds bounds;

    size_t triangleCount() const;
};

/// Loads the default scene (or scene 0) of a .glb or .gltf file. Fails with FileNotFound,
/// InvalidFile (not glTF, parse errors, bad accessors), MissingData (no triangles) or
/// InvalidValue (non-finite positions), naming the file and the offending mesh or node.
Result<Scene> loadScene(const std::string& path);

/// A camera that frames the scene's bounds: looking from the front (+Z), a little above, with the
/// given vertical field of view and aspect.
SceneCamera autoFrameCamera(const Bounds& bounds, float yfovRadians, float aspect);

/// A look-at camera.
SceneCamera lookAtCamera(const glm::vec3& from, const glm::vec3& at, float yfovRadians);

} // namespace dfb
