// Mesh primitives of glTF 2.0 (section 3.7.2) as world-space triangle lists: accessors read and
// checked, strips and fans converted, flat normals where none are given, tangents generated
// (MikkTSpace-like, per triangle) where the file has none.

#include "SceneLoad.h"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstring>

namespace dfb::sceneload {
namespace {

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
    if (size_t(a.bufferView) >= m.bufferViews.size()) return makeError(ErrorCode::InvalidFile, what + ": buffer view out of range");
    const tinygltf::BufferView& bv = m.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size()) return makeError(ErrorCode::InvalidFile, what + ": buffer out of range");
    const tinygltf::Buffer& buf = m.buffers[size_t(bv.buffer)];
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
    if (accessorIndex < 0 || size_t(accessorIndex) >= m.accessors.size()) {
        return makeError(ErrorCode::InvalidFile, what + ": accessor index out of range");
    }
    const tinygltf::Accessor& a = m.accessors[size_t(accessorIndex)];
    if (a.type != TINYGLTF_TYPE_SCALAR) return makeError(ErrorCode::InvalidFile, what + ": indices are not scalar");
    if (a.bufferView < 0 || size_t(a.bufferView) >= m.bufferViews.size()) {
        return makeError(ErrorCode::InvalidFile, what + ": indices without a valid buffer view");
    }
    const tinygltf::BufferView& bv = m.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size()) return makeError(ErrorCode::InvalidFile, what + ": buffer out of range");
    const tinygltf::Buffer& buf = m.buffers[size_t(bv.buffer)];
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

// File access for external buffers and images: regular files only, at most 4 GiB, and none at all
// for scenes loaded from memory (user_data == nullptr). tinygltf's default reader would try to
// allocate a directory's "size" when a URI names one.
void generateTangents(MeshPart& part, const std::vector<glm::vec2>& uv) {
    const size_t nv = part.positions.size();
    part.tangents.assign(nv, glm::vec4(0.f));
    std::vector<glm::vec3> tan(nv, glm::vec3(0.f)), bit(nv, glm::vec3(0.f));
    if (uv.size() == nv) {
        for (size_t t = 0; t + 2 < part.indices.size(); t += 3) {
            const uint32_t i0 = part.indices[t], i1 = part.indices[t + 1], i2 = part.indices[t + 2];
            const glm::vec3 e1 = part.positions[i1] - part.positions[i0], e2 = part.positions[i2] - part.positions[i0];
            const glm::vec2 d1 = uv[i1] - uv[i0], d2 = uv[i2] - uv[i0];
            const float det = d1.x * d2.y - d2.x * d1.y;
            if (std::abs(det) < 1e-20f) continue;
            const float r = 1.f / det;
            const glm::vec3 sdir = (e1 * d2.y - e2 * d1.y) * r, tdir = (e2 * d1.x - e1 * d2.x) * r;
            for (uint32_t i : {i0, i1, i2}) {
                tan[i] += sdir;
                bit[i] += tdir;
            }
        }
    }
    for (size_t v = 0; v < nv; ++v) {
        const glm::vec3 n = part.normals[v];
        glm::vec3 t = tan[v] - n * glm::dot(n, tan[v]);
        if (glm::length(t) < 1e-12f || !std::isfinite(t.x)) {
            // Any direction orthogonal to n.
            const glm::vec3 a = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
            t = glm::cross(a, n);
        }
        t = glm::normalize(t);
        const float w = glm::dot(glm::cross(n, t), bit[v]) < 0.f ? -1.f : 1.f;
        part.tangents[v] = glm::vec4(t, w);
    }
}

} // namespace

Status readPrimitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const glm::mat4& world, uint32_t objectId,
                     const std::string& what, Scene& scene, uint32_t& defaultMaterial) {
    std::string failure; // set by readAttr below
    const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(world)));
    const bool mirrored = glm::determinant(glm::mat3(world)) < 0.f;
    if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        prim.mode != TINYGLTF_MODE_TRIANGLE_FAN && prim.mode != -1) {
        return okStatus(); // points and lines cast no shadow and cover no pixel area
    }
    auto posIt = prim.attributes.find("POSITION");
    if (posIt == prim.attributes.end()) return okStatus();
    auto pos = readFloats(model, posIt->second, 3, what + " POSITION");
    if (!pos) return makeError(ErrorCode::InvalidFile, pos.error().message);
    MeshPart part;
    part.objectId = objectId;
    const size_t nv = pos->size() / 3;
    part.positions.resize(nv);
    for (size_t i = 0; i < nv; ++i) {
        glm::vec3 p((*pos)[i * 3], (*pos)[i * 3 + 1], (*pos)[i * 3 + 2]);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            return makeError(ErrorCode::InvalidFile, what + ": non-finite vertex position " + std::to_string(i));
        }
        part.positions[i] = glm::vec3(world * glm::vec4(p, 1.f));
        scene.bounds.extend(part.positions[i]);
    }
    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
        auto r = readIndices(model, prim.indices, what + " indices");
        if (!r) return makeError(ErrorCode::InvalidFile, r.error().message);
        idx = std::move(r.value());
    } else {
        idx.resize(nv);
        for (size_t i = 0; i < nv; ++i) idx[i] = uint32_t(i);
    }
    for (uint32_t i : idx) {
        if (i >= nv) return makeError(ErrorCode::InvalidFile, what + ": index " + std::to_string(i) + " out of range");
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

    std::vector<size_t> flatSource; // output vertex -> input vertex, when unshared
    auto nIt = prim.attributes.find("NORMAL");
    if (nIt != prim.attributes.end()) {
        auto nr = readFloats(model, nIt->second, 3, what + " NORMAL");
        if (!nr) return makeError(ErrorCode::InvalidFile, nr.error().message);
        if (nr->size() != pos->size()) return makeError(ErrorCode::InvalidFile, what + ": NORMAL count differs from POSITION");
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
            for (int k = 0; k < 3; ++k) {
                i2.push_back(uint32_t(p2.size()));
                p2.push_back(k == 0 ? a : k == 1 ? b : c);
                n2.push_back(n);
                flatSource.push_back(part.indices[t + size_t(k)]);
            }
        }
        part.positions = std::move(p2);
        part.normals = std::move(n2);
        part.indices = std::move(i2);
    }

    // Attributes indexed like POSITION; the flat-shading path above unshared vertices,
    // so it remaps them through `flatSource`.
    auto readAttr = [&](const char* name, int ncomp, std::vector<float>& out) -> bool {
        auto it = prim.attributes.find(name);
        if (it == prim.attributes.end()) return true;
        auto r = readFloats(model, it->second, ncomp, what + " " + name);
        if (!r) { failure = r.error().message; return false; }
        if (r->size() != nv * size_t(ncomp)) { failure = what + ": " + name + " count differs from POSITION"; return false; }
        out = std::move(r.value());
        return true;
    };
    std::vector<float> uv0, uv1, tan, col3, col4;
    if (!readAttr("TEXCOORD_0", 2, uv0) || !readAttr("TEXCOORD_1", 2, uv1) || !readAttr("TANGENT", 4, tan)) return makeError(ErrorCode::InvalidFile, failure);
    {
        auto it = prim.attributes.find("COLOR_0");
        if (it != prim.attributes.end()) {
            if (it->second < 0 || size_t(it->second) >= model.accessors.size()) {
                return makeError(ErrorCode::InvalidFile, what + ": COLOR_0 accessor out of range");
            }
            const int nc = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(model.accessors[size_t(it->second)].type));
            if (!readAttr("COLOR_0", nc == 3 ? 3 : 4, nc == 3 ? col3 : col4)) return makeError(ErrorCode::InvalidFile, failure);
        }
    }
    const size_t outVerts = part.positions.size();
    auto src = [&](size_t v) { return flatSource.empty() ? v : flatSource[v]; };
    if (!uv0.empty()) {
        part.uv0.resize(outVerts);
        for (size_t v = 0; v < outVerts; ++v) part.uv0[v] = {uv0[src(v) * 2], uv0[src(v) * 2 + 1]};
    }
    if (!uv1.empty()) {
        part.uv1.resize(outVerts);
        for (size_t v = 0; v < outVerts; ++v) part.uv1[v] = {uv1[src(v) * 2], uv1[src(v) * 2 + 1]};
    }
    if (!col3.empty() || !col4.empty()) {
        part.colors.resize(outVerts);
        for (size_t v = 0; v < outVerts; ++v) {
            part.colors[v] = col4.empty() ? glm::vec4(col3[src(v) * 3], col3[src(v) * 3 + 1], col3[src(v) * 3 + 2], 1.f)
                                          : glm::vec4(col4[src(v) * 4], col4[src(v) * 4 + 1], col4[src(v) * 4 + 2], col4[src(v) * 4 + 3]);
        }
    }
    if (!tan.empty()) {
        part.tangents.resize(outVerts);
        const glm::mat3 m3(world);
        for (size_t v = 0; v < outVerts; ++v) {
            glm::vec3 t = m3 * glm::vec3(tan[src(v) * 4], tan[src(v) * 4 + 1], tan[src(v) * 4 + 2]);
            const float len = glm::length(t);
            t = (len > 1e-20f && std::isfinite(len)) ? t / len : glm::vec3(1, 0, 0);
            const float w = tan[src(v) * 4 + 3] < 0.f ? -1.f : 1.f;
            // A mirroring transform flips the frame's handedness.
            part.tangents[v] = glm::vec4(t, mirrored ? -w : w);
        }
    } else {
        const int set = prim.material >= 0 && size_t(prim.material) < scene.materials.size()
                            ? scene.materials[size_t(prim.material)].normalTexture.texCoord : 0;
        generateTangents(part, set == 1 && !part.uv1.empty() ? part.uv1 : part.uv0);
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
    return okStatus();
}

} // namespace dfb::sceneload
