#include <dfb/gbuffer/Scene.h>

#include <tiny_gltf.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

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
bool fileExists(const std::string& path, void* allowed) {
    std::error_code ec;
    return allowed && std::filesystem::is_regular_file(path, ec);
}

std::string expandPath(const std::string& path, void*) { return path; }

bool readWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* allowed) {
    std::error_code ec;
    if (!allowed || !std::filesystem::is_regular_file(path, ec)) {
        if (err) *err += "external file '" + path + "' is not available\n";
        return false;
    }
    const auto size = std::filesystem::file_size(path, ec);
    if (ec || size > 0xFFFFFFF0ull) {
        if (err) *err += "external file '" + path + "' is unreadable or larger than 4 GiB\n";
        return false;
    }
    out->resize(size_t(size));
    FILE* f = std::fopen(path.c_str(), "rb");
    const bool ok = f && (size == 0 || std::fread(out->data(), 1, out->size(), f) == out->size());
    if (f) std::fclose(f);
    if (!ok && err) *err += "cannot read external file '" + path + "'\n";
    return ok;
}

bool refuseWrite(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
    if (err) *err += "writing is not supported\n";
    return false;
}

struct ImageDecodeState {
    bool decode = true;
    std::string error;
};

// tinygltf image callback: decodes PNG/JPEG (any format OpenImageIO reads) to 8-bit RGBA.
bool decodeImage(tinygltf::Image* image, const int index, std::string* err, std::string*, int, int,
                 const unsigned char* bytes, int size, void* user) {
    auto* state = static_cast<ImageDecodeState*>(user);
    if (!state->decode) return true;
    std::string ext = ".png";
    if (image->mimeType == "image/jpeg" || (size >= 2 && bytes[0] == 0xFF && bytes[1] == 0xD8)) ext = ".jpg";
    else if (image->mimeType == "image/webp") ext = ".webp";
    OIIO::Filesystem::IOMemReader proxy(const_cast<unsigned char*>(bytes), size_t(size));
    // No config spec: with one, OpenImageIO 2.4 ignores the proxy and looks for a real file.
    auto in = OIIO::ImageInput::open("image" + ext, nullptr, &proxy);
    if (!in) {
        state->error = "image " + std::to_string(index) + " ('" + image->name + "') cannot be decoded: " + OIIO::geterror();
        if (err) *err = state->error;
        return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    // Refuse absurd sizes before allocating (a corrupt header must not exhaust memory).
    if (spec.width <= 0 || spec.height <= 0 || spec.width > 32768 || spec.height > 32768) {
        state->error = "image " + std::to_string(index) + " has an absurd size";
        return false;
    }
    const int nc = spec.nchannels;
    std::vector<uint8_t> pixels(size_t(spec.width) * size_t(spec.height) * size_t(nc));
    if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::UINT8, pixels.data())) {
        state->error = "image " + std::to_string(index) + " ('" + image->name + "') is corrupt: " + in->geterror();
        return false;
    }
    image->width = spec.width;
    image->height = spec.height;
    image->component = 4;
    image->bits = 8;
    image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    image->image.resize(size_t(spec.width) * size_t(spec.height) * 4);
    for (size_t i = 0; i < size_t(spec.width) * size_t(spec.height); ++i) {
        const uint8_t* p = &pixels[i * size_t(nc)];
        uint8_t* q = &image->image[i * 4];
        if (nc >= 3) { q[0] = p[0]; q[1] = p[1]; q[2] = p[2]; }
        else { q[0] = q[1] = q[2] = p[0]; }
        q[3] = nc == 4 ? p[3] : nc == 2 ? p[1] : 255;
    }
    return true;
}

// Per-vertex tangents from UV gradients, accumulated over the triangles and orthogonalised
// against the normal (Lengyel's method). glTF asks for MikkTSpace; Debian packages no MikkTSpace
// library, and this gives the same frame on well-parameterised meshes (it differs on UV seams and
// degenerate triangles, where MikkTSpace splits vertices). Without UVs, any frame orthogonal to
// the normal is used (w = 1).
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

size_t Scene::triangleCount() const {
    size_t n = 0;
    for (const MeshPart& p : parts) n += p.indices.size() / 3;
    return n;
}

namespace {

Result<Scene> loadFromBytes(const std::string& path, const std::string& baseDir, const uint8_t* data, size_t size,
                            const LoadOptions& options);

// No exception may leave the loader (the server's threads do not expect them): whatever a
// malformed file makes a library throw becomes an InvalidFile error naming the file.
Result<Scene> loadFromBytesGuarded(const std::string& path, const std::string& baseDir, const uint8_t* data,
                                   size_t size, const LoadOptions& options) {
    try {
        return loadFromBytes(path, baseDir, data, size, options);
    } catch (const std::bad_alloc&) {
        return makeError(ErrorCode::InvalidFile, path + ": out of memory while reading (corrupt sizes?)");
    } catch (const std::exception& e) {
        return makeError(ErrorCode::InvalidFile, path + ": malformed glTF (" + std::string(e.what()) + ")");
    }
}

} // namespace

Result<Scene> loadScene(const std::string& path, const LoadOptions& options) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return makeError(ErrorCode::FileNotFound, path + ": no such file");
    const auto fileSize = fs::file_size(path, ec);
    // tinygltf addresses buffers with 32-bit sizes; glTF itself limits a GLB to 4 GiB.
    if (ec || fileSize > 0xFFFFFFF0ull) return makeError(ErrorCode::InvalidFile, path + ": unreadable or larger than 4 GiB");
    std::vector<uint8_t> bytes(static_cast<size_t>(fileSize));
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return makeError(ErrorCode::FileNotFound, path + ": cannot open");
    const size_t got = bytes.empty() ? 0 : std::fread(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    if (got != bytes.size()) return makeError(ErrorCode::IoError, path + ": short read");
    return loadFromBytesGuarded(path, fs::path(path).parent_path().string(), bytes.data(), bytes.size(), options);
}

Result<Scene> loadSceneFromMemory(const std::string& name, const uint8_t* data, size_t size, const LoadOptions& options) {
    // No base directory: external files are refused (see the URI reader below).
    return loadFromBytesGuarded(name, "", data, size, options);
}

namespace {

Result<Scene> loadFromBytes(const std::string& path, const std::string& baseDir, const uint8_t* data, size_t size,
                            const LoadOptions& options) {
    if (size > 0xFFFFFFF0ull) return makeError(ErrorCode::InvalidFile, path + ": larger than 4 GiB");
    const bool isGlb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    size_t firstNonSpace = 0;
    while (firstNonSpace < size && std::isspace(data[firstNonSpace])) ++firstNonSpace;
    if (!isGlb && (firstNonSpace >= size || data[firstNonSpace] != '{')) {
        return makeError(ErrorCode::InvalidFile, path + ": not a glTF file (neither GLB magic nor JSON)");
    }
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    ImageDecodeState imageState{options.loadImages, {}};
    loader.SetImageLoader(decodeImage, &imageState);
    static int allowFiles = 1;
    loader.SetFsCallbacks({fileExists, expandPath, readWholeFile, refuseWrite, baseDir.empty() ? nullptr : &allowFiles});
    std::string err, warn;
    bool ok = false;
    if (isGlb) {
        ok = loader.LoadBinaryFromMemory(&model, &err, &warn, data, static_cast<unsigned>(size), baseDir);
    } else {
        ok = loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(data),
                                        static_cast<unsigned>(size), baseDir);
    }
    if (!imageState.error.empty()) return makeError(ErrorCode::InvalidFile, path + ": " + imageState.error);
    if (!ok) return makeError(ErrorCode::InvalidFile, path + ": glTF parse error: " + err);
    for (const std::string& ext : model.extensionsRequired) {
        if (!SUPPORTED_REQUIRED.count(ext)) {
            return makeError(ErrorCode::InvalidFile, path + ": requires unsupported glTF extension " + ext);
        }
    }

    Scene scene;
    scene.path = path;
    // Images were decoded by the loader callback; textures pair them with samplers.
    for (size_t i = 0; i < model.images.size(); ++i) {
        const tinygltf::Image& gi = model.images[i];
        SceneImage img;
        img.name = gi.name.empty() ? (gi.uri.empty() ? "image" + std::to_string(i) : gi.uri) : gi.name;
        if (options.loadImages) {
            if (gi.width <= 0 || gi.height <= 0 || gi.image.size() != size_t(gi.width) * size_t(gi.height) * 4) {
                return makeError(ErrorCode::InvalidFile, path + ": image '" + img.name + "' could not be decoded");
            }
            img.width = gi.width;
            img.height = gi.height;
            img.rgba = gi.image;
        }
        scene.images.push_back(std::move(img));
    }
    for (size_t i = 0; i < model.textures.size(); ++i) {
        const tinygltf::Texture& gt = model.textures[i];
        SceneTexture t;
        t.image = gt.source;
        if (t.image < 0 || size_t(t.image) >= scene.images.size()) {
            // Only extension images (KHR_texture_basisu, EXT_texture_webp) would be valid here.
            std::string ext = gt.extensions.empty() ? "" : gt.extensions.begin()->first;
            return makeError(ErrorCode::InvalidFile, path + ": texture " + std::to_string(i) + " has no usable image" +
                                                         (ext.empty() ? "" : " (its image needs the unsupported extension " + ext + ")"));
        }
        if (gt.sampler >= 0 && size_t(gt.sampler) < model.samplers.size()) {
            const tinygltf::Sampler& gs = model.samplers[size_t(gt.sampler)];
            t.wrapS = gs.wrapS;
            t.wrapT = gs.wrapT;
            if (gs.magFilter > 0) t.magFilter = gs.magFilter;
            if (gs.minFilter > 0) t.minFilter = gs.minFilter;
        }
        scene.textures.push_back(t);
    }
    std::string materialFailure;
    auto textureRef = [&](const auto& info, const std::string& what) {
        TextureRef r;
        if (info.index < 0) return r;
        if (size_t(info.index) >= scene.textures.size()) {
            materialFailure = what + " refers to missing texture " + std::to_string(info.index);
            return r;
        }
        r.texture = info.index;
        r.texCoord = info.texCoord;
        auto tt = info.extensions.find("KHR_texture_transform");
        if (tt != info.extensions.end()) {
            const tinygltf::Value& v = tt->second;
            glm::vec2 offset(0.f), scale(1.f);
            float rotation = 0.f;
            if (v.Has("offset") && v.Get("offset").ArrayLen() == 2) {
                offset = {float(v.Get("offset").Get(0).GetNumberAsDouble()), float(v.Get("offset").Get(1).GetNumberAsDouble())};
            }
            if (v.Has("scale") && v.Get("scale").ArrayLen() == 2) {
                scale = {float(v.Get("scale").Get(0).GetNumberAsDouble()), float(v.Get("scale").Get(1).GetNumberAsDouble())};
            }
            if (v.Has("rotation")) rotation = float(v.Get("rotation").GetNumberAsDouble());
            if (v.Has("texCoord")) r.texCoord = v.Get("texCoord").GetNumberAsInt();
            // KHR_texture_transform: T * R * S, with R rotating counter-clockwise in UV space.
            const glm::mat3 T(1, 0, 0, 0, 1, 0, offset.x, offset.y, 1);
            const float c = std::cos(rotation), sn = std::sin(rotation);
            const glm::mat3 R(c, -sn, 0, sn, c, 0, 0, 0, 1);
            const glm::mat3 S(scale.x, 0, 0, 0, scale.y, 0, 0, 0, 1);
            r.transform = T * R * S;
        }
        if (r.texCoord < 0 || r.texCoord > 1) {
            materialFailure = what + " uses TEXCOORD_" + std::to_string(r.texCoord) + " (sets 0 and 1 are supported)";
            r.texture = -1;
        }
        return r;
    };
    auto number = [](const tinygltf::Value& v, const char* key, float fallback) {
        return v.Has(key) ? float(v.Get(key).GetNumberAsDouble()) : fallback;
    };
    auto color3 = [](const tinygltf::Value& v, const char* key, glm::vec3 fallback) {
        if (!v.Has(key) || v.Get(key).ArrayLen() != 3) return fallback;
        return glm::vec3(float(v.Get(key).Get(0).GetNumberAsDouble()), float(v.Get(key).Get(1).GetNumberAsDouble()),
                         float(v.Get(key).Get(2).GetNumberAsDouble()));
    };
    // Texture infos inside extensions are plain JSON values; read them into a TextureInfo.
    auto extTexture = [&](const tinygltf::Value& v, const char* key, const std::string& what) {
        tinygltf::TextureInfo info;
        if (!v.Has(key)) return TextureRef{};
        const tinygltf::Value& t = v.Get(key);
        info.index = t.Has("index") ? t.Get("index").GetNumberAsInt() : -1;
        info.texCoord = t.Has("texCoord") ? t.Get("texCoord").GetNumberAsInt() : 0;
        if (t.Has("extensions") && t.Get("extensions").Has("KHR_texture_transform")) {
            info.extensions["KHR_texture_transform"] = t.Get("extensions").Get("KHR_texture_transform");
        }
        return textureRef(info, what);
    };
    for (const tinygltf::Material& gm : model.materials) {
        Material mat;
        mat.name = gm.name.empty() ? "material" + std::to_string(scene.materials.size()) : gm.name;
        const std::string what = "material '" + mat.name + "'";
        const auto& pbr = gm.pbrMetallicRoughness;
        for (int i = 0; i < 4 && size_t(i) < pbr.baseColorFactor.size(); ++i) mat.baseColor[i] = float(pbr.baseColorFactor[size_t(i)]);
        mat.metallic = float(pbr.metallicFactor);
        mat.roughness = float(pbr.roughnessFactor);
        for (int i = 0; i < 3 && size_t(i) < gm.emissiveFactor.size(); ++i) mat.emissive[i] = float(gm.emissiveFactor[size_t(i)]);
        auto es = gm.extensions.find("KHR_materials_emissive_strength");
        if (es != gm.extensions.end()) mat.emissive *= number(es->second, "emissiveStrength", 1.f);
        mat.doubleSided = gm.doubleSided;
        mat.alphaMode = gm.alphaMode == "MASK" ? AlphaMode::Mask : gm.alphaMode == "BLEND" ? AlphaMode::Blend : AlphaMode::Opaque;
        mat.alphaCutoff = float(gm.alphaCutoff);
        mat.baseColorTexture = textureRef(pbr.baseColorTexture, what + " baseColorTexture");
        mat.metallicRoughnessTexture = textureRef(pbr.metallicRoughnessTexture, what + " metallicRoughnessTexture");
        mat.normalTexture = textureRef(gm.normalTexture, what + " normalTexture");
        mat.normalTexture.scale = float(gm.normalTexture.scale);
        mat.occlusionTexture = textureRef(gm.occlusionTexture, what + " occlusionTexture");
        mat.occlusionTexture.scale = float(gm.occlusionTexture.strength);
        mat.emissiveTexture = textureRef(gm.emissiveTexture, what + " emissiveTexture");
        if (auto e = gm.extensions.find("KHR_materials_specular"); e != gm.extensions.end()) {
            mat.specularFactor = number(e->second, "specularFactor", 1.f);
            mat.specularColor = color3(e->second, "specularColorFactor", glm::vec3(1.f));
            mat.specularTexture = extTexture(e->second, "specularTexture", what + " specularTexture");
            mat.specularColorTexture = extTexture(e->second, "specularColorTexture", what + " specularColorTexture");
        }
        if (auto e = gm.extensions.find("KHR_materials_sheen"); e != gm.extensions.end()) {
            mat.sheenColor = color3(e->second, "sheenColorFactor", glm::vec3(0.f));
            mat.sheenRoughness = number(e->second, "sheenRoughnessFactor", 0.f);
            mat.sheenColorTexture = extTexture(e->second, "sheenColorTexture", what + " sheenColorTexture");
            mat.sheenRoughnessTexture = extTexture(e->second, "sheenRoughnessTexture", what + " sheenRoughnessTexture");
        }
        if (auto e = gm.extensions.find("KHR_materials_clearcoat"); e != gm.extensions.end()) {
            mat.clearcoat = number(e->second, "clearcoatFactor", 0.f);
            mat.clearcoatRoughness = number(e->second, "clearcoatRoughnessFactor", 0.f);
            mat.clearcoatTexture = extTexture(e->second, "clearcoatTexture", what + " clearcoatTexture");
            mat.clearcoatRoughnessTexture = extTexture(e->second, "clearcoatRoughnessTexture", what + " clearcoatRoughnessTexture");
        }
        if (!materialFailure.empty()) return makeError(ErrorCode::InvalidFile, path + ": " + materialFailure);
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
                cam.xmag = float(gc.orthographic.xmag);
                cam.ymag = float(gc.orthographic.ymag);
                cam.znear = float(gc.orthographic.znear);
                cam.zfar = float(gc.orthographic.zfar);
            }
            scene.cameras.push_back(cam);
        }

        if (auto lit = node.extensions.find("KHR_lights_punctual"); lit != node.extensions.end() && lit->second.Has("light")) {
            const int index = lit->second.Get("light").GetNumberAsInt();
            if (index >= 0 && size_t(index) < model.lights.size()) {
                const tinygltf::Light& gl = model.lights[size_t(index)];
                SceneLight l;
                l.name = !gl.name.empty() ? gl.name : (!node.name.empty() ? node.name : "light" + std::to_string(index));
                l.type = gl.type;
                l.position = glm::vec3(world[3]);
                l.direction = glm::normalize(-glm::vec3(world[2]));
                if (gl.color.size() == 3) l.color = glm::vec3(float(gl.color[0]), float(gl.color[1]), float(gl.color[2]));
                l.intensity = float(gl.intensity);
                l.innerConeRadians = float(gl.spot.innerConeAngle);
                l.outerConeRadians = float(gl.spot.outerConeAngle);
                scene.lights.push_back(l);
            }
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

                std::vector<size_t> flatSource; // output vertex -> input vertex, when unshared
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
                if (!readAttr("TEXCOORD_0", 2, uv0) || !readAttr("TEXCOORD_1", 2, uv1) || !readAttr("TANGENT", 4, tan)) return;
                {
                    auto it = prim.attributes.find("COLOR_0");
                    if (it != prim.attributes.end()) {
                        if (it->second < 0 || size_t(it->second) >= model.accessors.size()) {
                            failure = what + ": COLOR_0 accessor out of range";
                            return;
                        }
                        const int nc = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(model.accessors[size_t(it->second)].type));
                        if (!readAttr("COLOR_0", nc == 3 ? 3 : 4, nc == 3 ? col3 : col4)) return;
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

} // namespace

size_t Scene::memoryBytes() const {
    size_t n = 0;
    for (const MeshPart& p : parts) {
        n += p.positions.size() * sizeof(glm::vec3) + p.normals.size() * sizeof(glm::vec3) +
             p.tangents.size() * sizeof(glm::vec4) + (p.uv0.size() + p.uv1.size()) * sizeof(glm::vec2) +
             p.colors.size() * sizeof(glm::vec4) + p.indices.size() * sizeof(uint32_t);
    }
    for (const SceneImage& i : images) n += i.rgba.size();
    return n;
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
