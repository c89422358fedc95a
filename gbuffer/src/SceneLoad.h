#pragma once
// The parts of glTF loading (Scene.cpp drives them): materials with their images and textures,
// and mesh primitives. Internal to dfb_gbuffer.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/Scene.h>

#include <tiny_gltf.h>

#include <glm/glm.hpp>

#include <string>

namespace dfb::sceneload {

/// Decoded images (when options.loadImages), textures with their samplers, and materials, in
/// file order; InvalidFile naming `path` and the item on anything unusable.
Status readMaterials(const tinygltf::Model& model, const LoadOptions& options, const std::string& path, Scene& scene);

/// One primitive of a mesh node placed by `world`, as a MeshPart of object `objectId` appended to
/// scene.parts (points and lines are skipped); `what` names it in errors. A primitive without a
/// material gets the scene's default material, added on first use (`defaultMaterial`, 0 = none yet).
Status readPrimitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const glm::mat4& world, uint32_t objectId,
                     const std::string& what, Scene& scene, uint32_t& defaultMaterial);

} // namespace dfb::sceneload
