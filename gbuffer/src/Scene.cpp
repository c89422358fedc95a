#include <dfb/gbuffer/Scene.h>

#include <tiny_gltf.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>

namespace dfb {
namespace {

// Extensions we read or may safely ignore. Anything else listed in extensionsRequired changes
// the meaning of the data (compression, quantization), so we refuse the file by name.
const std::set<std::string> SUPPORTED_REQUIRED = {
    "KHR_materials_emissive_strength", "KHR_lights_punctual", "KHR_materials_specular",
    "KHR_materials_sheen", "KHR_materials_clearcoat", "KHR_texture_transform"};

glm::mat4 nodeLocalMatrix(const tinygltf::Node& n) {
    if (n.matrix.size() == 16) {
        glm::mat4 m;
        for (int i = 0; i < 16; ++i) glm::value_ptr(m)[i] = static_cast<float>(n.matrix[size_t(i)]);
        return m;
    }
    glm::mat4 m(1.f);
    if (n.translation.size() == 3) {
        m = glm::translate(m, glm::vec3(float(n.translation[0]), float(n.translation[1]), float(n.translation[2])));
    }
    if (n.rotation.size() == 4) {
        glm::quat q(float(n.rotation[3]), float(n.rotation[0]), float(n.rotation[1]), float(n.rotation[2]));
        m *= glm::mat4_cast(glm::normalize(q));
    }
    if (n.scale.size() == 3) m = glm::scale(m, glm::vec3(float(n.scale[0]), float(n.scale[1]), float(n.scale[2])));
    return m;
}

float readComponent(const unsigned char* p, int componentType, bool normalized) {
    switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p, 4);
        return f;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.f : float(p[0]);
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const auto v = static_cast<int8_t>(p[0]);
        return normalized ? std::max(v / 127.f, -1.f) : float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? v / 65535.f : float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? std::max(v / 32767.f, -1.f) : float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return float(v);
    }
    default: return 0.f;
    }
}

// Reads `count` elements of `ncomp` floats from an accessor, with bounds checks against the buffer.
Result<std::vector<float>> readFloats(const tinygltf::Model& m, int accessorIndex, int ncomp, const std::string& what) {
    if (accessorIndex < 0 || size_t(accessorIndex) >= m.accessors.size()) {
        return makeError(ErrorCode::InvalidFile, what + ": accessor index out of range");
    }
    const tinygltf::Accessor& a = m.accessors[size_t(accessorIndex)];
    if (a.sparse.isSparse) return makeError(ErrorCode::InvalidFile, what + ": sparse accessors are not supported");
    const int n = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    if (n != ncomp) {
        return makeError(ErrorCode::InvalidFile, what + ": expected " + std::to_string(ncomp) + " components, found " +
                                                     std::to_string(n));
    }
    std::vector<float> out(a.count * size_t(ncomp), 0.f);
    if (a.bufferView < 0) return out; // all zeros per the spec
    const tinygltf::BufferView& bv = m.bufferViews.at(size_t(a.bufferView));
    const tinygltf::Buffer& buf = m.buffers.at(size_t(bv.buffer));
    const int csize = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
    if (csize <= 0) return makeError(ErrorCode::InvalidFile, what + ": bad component type");
    const size_t stride = bv.byteStride ? bv.byteStride : size_t(csize * ncomp);
    const size_t start = bv.byteOffset + a.byteOffset;
    if (a.count > 0) {
        const size_t last = start + stride * (a.count - 1) + size_t(csize * ncomp);
        if (last > buf.data.size() || a.byteOffset + stride * (a.count - 1) + size_t(csize * ncomp) > bv.byteLength) {
            return makeError(ErrorCode::InvalidFile, what + ": accessor runs past the end of its buffer");
        }
    }
    for (size_t i = 0; i < a.count; ++i) {
        const unsigned char* p = buf.data.data() + start + stride * i;
        for (int c = 0; c < ncomp; ++c) {
            out[i * size_t(ncomp) + size_t(c)] = readComponent(p + c * csize, a.componentType, a.normalized);
        }
    }
    return out;
}

Result<std::vector<uint32_t>> readIndices(const tinygltf::Model& m, int accessorIndex, const std::string& what) {
    const tinygltf::Accessor& a = m.accessors.at(size_t(accessorIndex));
    if (a.type != TINYGLTF_TYPE_SCALAR) return makeError(ErrorCode::InvalidFile, what + ": indices are not scalar");
    if (a.bufferView < 0) return makeError(ErrorCode::InvalidFile, what + ": indices without a buffer view");
    const tinygltf::BufferView& bv = m.bufferViews.at(size_t(a.bufferView));
    const tinygltf::Buffer& buf = m.buffers.at(size_t(bv.buffer));
    const int csize = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
    if (csize != 1 && csize != 2 && csize != 4) return makeError(ErrorCode::InvalidFile, what + ": bad index type");
    const size_t stride = bv.byteStride ? bv.byteStride : size_t(csize);
    const size_t start = bv.byteOffset + a.byteOffset;
    if (a.count > 0 && start + stride * (a.count - 1) + size_t(csize) > buf.data.size()) {
        return makeError(ErrorCode::InvalidFile, what + ": indices run past the end of their buffer");
    }
    std::vector<uint32_t> out(a.count);
    for (size_t i = 0; i < a.count; ++i) {
        const unsigned char* p = buf.data.data() + start + stride * i;
        uint32_t v = 0;
        if (csize == 1) v = p[0];
        else if (csize == 2) { uint16_t s; std::memcpy(&s, p, 2); v = s; }
        else std::memcpy(&v, p, 4);
        out[i] = v;
    }
    return out;
}

} // namespace

size_t Scene::triangleCount() const {
    size_t n = 0;
    for (const MeshPart& p : parts) n += p.indices.size() / 3;
    return n;
}

Result<Scene> loadScene(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return makeError(ErrorCode::FileNotFound, path + ": no such file");

    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    // Images are not needed by the v0 bake or by shadow casting; skip decoding them.
    loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int,
                             const unsigned char*, int, void*) { return true; },
                          nullptr);
    std::string err, warn;
    bool ok = false;
    {
        // Sniff the magic rather than trusting the extension.
        FILE* f = std::fopen(path.c_str(), "rb");
        char magic[4] = {};
        const size_t got = f ? std::fread(magic, 1, 4, f) : 0;
        if (f) std::fclose(f);
        if (got == 4 && std::memcmp(magic, "glTF", 4) == 0) {
            ok = loader.LoadBinaryFromFile(&model, &err, &warn, path);
        } else if (got >= 1 && (magic[0] == '{' || std::isspace(static_cast<unsigned char>(magic[0])))) {
            ok = loader.LoadASCIIFromFile(&model, &err, &warn, path);
        } else {
            return makeError(ErrorCode::InvalidFile, path + ": not a glTF file (neither GLB magic nor JSON)");
        }
    }
    if (!ok) return makeError(ErrorCode::InvalidFile, path + ": glTF parse error: " + err);
    for (const std::string& ext : model.extensionsRequired) {
        if (!SUPPORTED_REQUIRED.count(ext)) {
            return makeError(ErrorCode::InvalidFile, path + ": requires unsupported glTF extension " + ext);
        }
    }

    Scene scene;
    scene.path = path;
    for (const tinygltf::Material& gm : model.materials) {
        Material mat;
        mat.name = gm.name.empty() ? "material" + std::to_string(scene.materials.size()) : gm.name;
        const auto& pbr = gm.pbrMetallicRoughness;
        for (int i = 0; i < 4 && size_t(i) < pbr.baseColorFactor.size(); ++i) mat.baseColor[i] = float(pbr.baseColorFactor[size_t(i)]);
        mat.metallic = float(pbr.metallicFactor);
        mat.roughness = float(pbr.roughnessFactor);
        for (int i = 0; i < 3 && size_t(i) < gm.emissiveFactor.size(); ++i) mat.emissive[i] = float(gm.emissiveFactor[size_t(i)]);
        auto es = gm.extensions.find("KHR_materials_emissive_strength");
        if (es != gm.extensions.end() && es->second.Has("emissiveStrength")) {
            mat.emissive *= float(es->second.Get("emissiveStrength").GetNumberAsDouble());
        }
        mat.doubleSided = gm.doubleSided;
        scene.materials.push_back(mat);
    }
    uint32_t defaultMaterial = 0; // added on first use

    const int sceneIndex = model.defaultScene >= 0 ? model.defaultScene : 0;
    if (model.scenes.empty()) return makeError(ErrorCode::MissingData, path + ": the file has no scene");
    if (size_t(sceneIndex) >= model.scenes.size()) return makeError(ErrorCode::InvalidFile, path + ": default scene index out of range");

    std::string failure;
    std::vector<int> visiting;
    std::function<void(int, const glm::mat4&)> visit = [&](int nodeIndex, const glm::mat4& parent) {
        if (!failure.empty()) return;
        if (nodeIndex < 0 || size_t(nodeIndex) >= model.nodes.size() ||
            std::find(visiting.begin(), visiting.end(), nodeIndex) != visiting.end()) {
            failure = "node hierarchy has a bad index or a cycle at node " + std::to_string(nodeIndex);
            return;
        }
        visiting.push_back(nodeIndex);
        const tinygltf::Node& node = model.nodes[size_t(nodeIndex)];
        const glm::mat4 world = parent * nodeLocalMatrix(node);
        const std::string nodeName = node.name.empty() ? "node" + std::to_string(nodeIndex) : node.name;

        if (node.camera >= 0 && size_t(node.camera) < model.cameras.size()) {
            const tinygltf::Camera& gc = model.cameras[size_t(node.camera)];
            SceneCamera cam;
            cam.name = !node.name.empty() ? node.name : (!gc.name.empty() ? gc.name : "camera" + std::to_string(node.camera));
            // The camera's world matrix may carry scale; only its rigid part defines the view.
            glm::mat4 rigid = world;
            for (int c = 0; c < 3; ++c) rigid[c] = glm::vec4(glm::normalize(glm::vec3(world[c])), 0.f);
            cam.worldToCamera = glm::inverse(rigid);
            if (gc.type == "perspective") {
                cam.yfovRadians = float(gc.perspective.yfov);
                cam.aspect = float(gc.perspective.aspectRatio);
                cam.znear = float(gc.perspective.znear);
                cam.zfar = float(gc.perspective.zfar);
            } else {
                cam.orthographic = true;
                cam.znear = float(gc.orthographic.znear);
                cam.zfar = float(gc.orthographic.zfar);
            }
            scene.cameras.push_back(cam);
        }

        if (node.mesh >= 0) {
            if (size_t(node.mesh) >= model.meshes.size()) {
                failure = "node '" + nodeName + "' references a missing mesh";
                return;
            }
            scene.objectNames.push_back(nodeName);
            const auto objectId = static_cast<uint32_t>(scene.objectNames.size());
            const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(world)));
            const bool mirrored = glm::determinant(glm::mat3(world)) < 0.f;
            const tinygltf::Mesh& mesh = model.meshes[size_t(node.mesh)];
            for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
                const tinygltf::Primitive& prim = mesh.primitives[pi];
                const std::string what = path + ": mesh '" + mesh.name + "' primitive " + std::to_string(pi);
                if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
                    prim.mode != TINYGLTF_MODE_TRIANGLE_FAN && prim.mode != -1) {
                    continue; // points and lines cast no shadow and cover no pixel area
                }
                auto posIt = prim.attributes.find("POSITION");
                if (posIt == prim.attributes.end()) continue;
                auto pos = readFloats(model, posIt->second, 3, what + " POSITION");
                if (!pos) { failure = pos.error().message; return; }
                MeshPart part;
                part.objectId = objectId;
                const size_t nv = pos->size() / 3;
                part.positions.resize(nv);
                for (size_t i = 0; i < nv; ++i) {
                    glm::vec3 p((*pos)[i * 3], (*pos)[i * 3 + 1], (*pos)[i * 3 + 2]);
                    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
                        failure = what + ": non-finite vertex position " + std::to_string(i);
                        return;
                    }
                    part.positions[i] = glm::vec3(world * glm::vec4(p, 1.f));
                    scene.bounds.extend(part.positions[i]);
                }
                std::vector<uint32_t> idx;
                if (prim.indices >= 0) {
                    auto r = readIndices(model, prim.indices, what + " indices");
                    if (!r) { failure = r.error().message; return; }
                    idx = std::move(r.value());
                } else {
                    idx.resize(nv);
                    for (size_t i = 0; i < nv; ++i) idx[i] = uint32_t(i);
                }
                for (uint32_t i : idx) {
                    if (i >= nv) { failure = what + ": index " + std::to_string(i) + " out of range"; return; }
                }
                // Convert strips and fans to lists.
                if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
                    std::vector<uint32_t> l;
                    for (size_t i = 2; i < idx.size(); ++i) {
                        if (i % 2 == 0) l.insert(l.end(), {idx[i - 2], idx[i - 1], idx[i]});
                        else l.insert(l.end(), {idx[i - 1], idx[i - 2], idx[i]});
                    }
                    idx = std::move(l);
                } else if (prim.mode == TINYGLTF_MODE_TRIANGLE_FAN) {
                    std::vector<uint32_t> l;
                    for (size_t i = 2; i < idx.size(); ++i) l.insert(l.end(), {idx[0], idx[i - 1], idx[i]});
                    idx = std::move(l);
                }
                idx.resize(idx.size() / 3 * 3);
                if (mirrored) {
                    for (size_t t = 0; t < idx.size(); t += 3) std::swap(idx[t + 1], idx[t + 2]);
                }
                part.indices = std::move(idx);

                auto nIt = prim.attributes.find("NORMAL");
                if (nIt != prim.attributes.end()) {
                    auto nr = readFloats(model, nIt->second, 3, what + " NORMAL");
                    if (!nr) { failure = nr.error().message; return; }
                    if (nr->size() != pos->size()) { failure = what + ": NORMAL count differs from POSITION"; return; }
                    part.normals.resize(nv);
                    for (size_t i = 0; i < nv; ++i) {
                        glm::vec3 n = normalMatrix * glm::vec3((*nr)[i * 3], (*nr)[i * 3 + 1], (*nr)[i * 3 + 2]);
                        const float len = glm::length(n);
                        part.normals[i] = (len > 1e-20f && std::isfinite(len)) ? n / len : glm::vec3(0, 1, 0);
                    }
                } else {
                    // No normals: flat shading, as the glTF spec asks. Unshare vertices first.
                    std::vector<glm::vec3> p2;
                    std::vector<glm::vec3> n2;
                    std::vector<uint32_t> i2;
                    for (size_t t = 0; t < part.indices.size(); t += 3) {
                        const glm::vec3 a = part.positions[part.indices[t]], b = part.positions[part.indices[t + 1]],
                                        c = part.positions[part.indices[t + 2]];
                        glm::vec3 n = glm::cross(b - a, c - a);
                        const float len = glm::length(n);
                        n = len > 0.f ? n / len : glm::vec3(0, 1, 0);
                        for (const glm::vec3& v : {a, b, c}) {
                            i2.push_back(uint32_t(p2.size()));
                            p2.push_back(v);
                            n2.push_back(n);
                        }
                    }
                    part.positions = std::move(p2);
                    part.normals = std::move(n2);
                    part.indices = std::move(i2);
                }

                if (prim.material >= 0 && size_t(prim.material) < scene.materials.size()) {
                    part.materialId = uint32_t(prim.material) + 1;
                } else {
                    if (defaultMaterial == 0) {
                        Material def;
                        def.name = "default";
                        def.baseColor = glm::vec4(0.8f, 0.8f, 0.8f, 1.f);
                        def.metallic = 0.f;
                        def.roughness = 0.5f;
                        scene.materials.push_back(def);
                        defaultMaterial = uint32_t(scene.materials.size());
                    }
                    part.materialId = defaultMaterial;
                }
                if (!part.indices.empty()) scene.parts.push_back(std::move(part));
            }
        }
        for (int child : node.children) visit(child, world);
        visiting.pop_back();
    };
    for (int root : model.scenes[size_t(sceneIndex)].nodes) visit(root, glm::mat4(1.f));
    if (!failure.empty()) return makeError(ErrorCode::InvalidFile, failure.rfind(path, 0) == 0 ? failure : path + ": " + failure);
    if (scene.parts.empty()) return makeError(ErrorCode::MissingData, path + ": the scene has no triangles");
    return scene;
}

SceneCamera lookAtCamera(const glm::vec3& from, const glm::vec3& at, float yfovRadians) {
    SceneCamera cam;
    cam.name = "lookat";
    glm::vec3 dir = at - from;
    glm::vec3 up(0, 1, 0);
    if (glm::length(glm::cross(glm::normalize(dir), up)) < 1e-3f) up = glm::vec3(0, 0, -1);
    cam.worldToCamera = glm::lookAt(from, at, up);
    cam.yfovRadians = yfovRadians;
    cam.znear = std::max(1e-4f, glm::length(dir) * 1e-3f);
    return cam;
}

SceneCamera autoFrameCamera(const Bounds& bounds, float yfovRadians, float aspect) {
    const glm::vec3 c = bounds.center();
    const float r = std::max(bounds.radius(), 1e-6f);
    // Distance so that the bounding sphere fits the narrower field of view.
    const float halfFov = 0.5f * std::min(yfovRadians, 2.f * std::atan(std::tan(0.5f * yfovRadians) * aspect));
    const float dist = r / std::sin(halfFov) * 1.05f;
    const glm::vec3 dir = glm::normalize(glm::vec3(0.f, 0.35f, 1.f));
    SceneCamera cam = lookAtCamera(c + dir * dist, c, yfovRadians);
    cam.name = "auto";
    cam.aspect = aspect;
    cam.znear = std::max(1e-5f, (dist - r) * 0.5f);
    cam.zfar = dist + r * 2.f;
    return cam;
}

} // namespace dfb
