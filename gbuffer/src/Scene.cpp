#include <dfb/gbuffer/Scene.h>

#include "SceneLoad.h"

#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

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

// A glTF extras value as JSON (extras.dfb_light, docs/gbuffer-format.md "Lights in glTF"): the
// exporter's numbers come back as written (integers as integers, doubles exactly). Deeper than a
// rig light's JSON can be is refused before the recursion could matter.
static Result<nlohmann::json> valueToJson(const tinygltf::Value& v, int depth) {
    if (depth > 16) return makeError(ErrorCode::InvalidFile, "is nested too deeply for a light");
    switch (v.Type()) {
    case tinygltf::NULL_TYPE: return nlohmann::json(nullptr);
    case tinygltf::BOOL_TYPE: return nlohmann::json(v.Get<bool>());
    case tinygltf::INT_TYPE: return nlohmann::json(v.Get<int>());
    case tinygltf::REAL_TYPE: return nlohmann::json(v.Get<double>());
    case tinygltf::STRING_TYPE: return nlohmann::json(v.Get<std::string>());
    case tinygltf::ARRAY_TYPE: {
        nlohmann::json a = nlohmann::json::array();
        for (size_t i = 0; i < v.ArrayLen(); ++i) {
            auto x = valueToJson(v.Get(int(i)), depth + 1);
            if (!x) return x.error();
            a.push_back(std::move(x.value()));
        }
        return a;
    }
    case tinygltf::OBJECT_TYPE: {
        nlohmann::json o = nlohmann::json::object();
        for (const auto& [key, x] : v.Get<tinygltf::Value::Object>()) {
            auto y = valueToJson(x, depth + 1);
            if (!y) return y.error();
            o[key] = std::move(y.value());
        }
        return o;
    }
    default: return makeError(ErrorCode::InvalidFile, "holds a value JSON cannot (binary)");
    }
}

// An area light under a node's extras.dfb_area_light (KHR_lights_punctual has none;
// docs/gbuffer-format.md, "Area lights in glTF"): placed and turned by the node, its -Z the
// emitting side and +X the width axis. A bad field is an error naming the node and the field,
// not a silent default.
static Result<SceneLight> readAreaLight(const tinygltf::Value& a, const glm::mat4& world, const std::string& nodeName) {
    const std::string where = "node '" + nodeName + "': extras.dfb_area_light";
    auto bad = [&](const std::string& what) { return makeError(ErrorCode::InvalidFile, where + what); };
    if (!a.IsObject()) return bad(" must be an object");
    SceneLight l;
    l.name = nodeName;
    l.type = "area";
    l.position = glm::vec3(world[3]);
    l.direction = glm::normalize(-glm::vec3(world[2]));
    l.right = glm::normalize(glm::vec3(world[0]));
    // `count` numbers in [lo, hi] (count 0: one number, not an array) into out.
    auto numbers = [&](const char* key, int count, double lo, double hi, const char* shape, float* out) -> Status {
        if (!a.Has(key)) return okStatus();
        const tinygltf::Value& v = a.Get(key);
        if (count > 0 && (!v.IsArray() || v.ArrayLen() != size_t(count))) return bad(std::string(".") + key + " must be " + shape);
        for (int i = 0; i < std::max(count, 1); ++i) {
            const tinygltf::Value& x = count > 0 ? v.Get(i) : v;
            if (!x.IsNumber() || !(x.GetNumberAsDouble() >= lo && x.GetNumberAsDouble() <= hi)) {
                return bad(std::string(".") + key + (count > 0 ? "[" + std::to_string(i) + "]" : "") + " must be a number in [" +
                           std::to_string(lo) + ", " + std::to_string(hi) + "]");
            }
            out[i] = float(x.GetNumberAsDouble());
        }
        return okStatus();
    };
    if (a.Has("shape")) {
        const std::string shape = a.Get("shape").IsString() ? a.Get("shape").Get<std::string>() : "";
        if (shape != "rect" && shape != "disk") return bad(".shape must be \"rect\" or \"disk\"");
        l.disk = shape == "disk";
    }
    float grid[2] = {float(l.shadowGrid.x), float(l.shadowGrid.y)};
    for (const Status& st : {numbers("size", 2, 1e-4, 1e7, "[width, height]", &l.size.x),
                             numbers("intensity", 0, 0.0, 1e12, "a number", &l.intensity),
                             numbers("color", 3, 0.0, 1e6, "[r, g, b]", &l.color.x),
                             numbers("shadowGrid", 2, 1, 16, "[m, n]", grid)}) {
        if (!st) return st.error();
    }
    l.shadowGrid = glm::ivec2(int(grid[0]), int(grid[1]));
    if (a.Has("pattern")) {
        if (!a.Get("pattern").IsString()) return bad(".pattern must be a file name");
        l.pattern = a.Get("pattern").Get<std::string>();
    }
    return l;
}

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
    if (auto st = sceneload::readMaterials(model, options, path, scene); !st) return st.error();
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

        // A node written by dfb's export carries its light's rig JSON (extras.dfb_light); its
        // KHR light or dfb_area_light is then a stand-in for other tools, read into the same
        // SceneLight (the import prefers the JSON) instead of a second light.
        const size_t lightsBefore = scene.lights.size();
        std::string rigJson;
        if (node.extras.IsObject() && node.extras.Has("dfb_light")) {
            auto j = valueToJson(node.extras.Get("dfb_light"), 0);
            if (!j) {
                failure = "node '" + nodeName + "': extras.dfb_light " + j.error().message;
                return;
            }
            rigJson = j->dump();
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

        if (node.extras.IsObject() && node.extras.Has("dfb_area_light") && (rigJson.empty() || scene.lights.size() == lightsBefore)) {
            auto area = readAreaLight(node.extras.Get("dfb_area_light"), world, nodeName);
            if (!area) {
                failure = area.error().message;
                return;
            }
            scene.lights.push_back(area.value());
        }
        if (!rigJson.empty()) {
            if (scene.lights.size() == lightsBefore) {
                SceneLight l; // no stand-in: the placement only
                l.name = nodeName;
                l.type.clear();
                l.position = glm::vec3(world[3]);
                l.direction = glm::normalize(-glm::vec3(world[2]));
                scene.lights.push_back(l);
            }
            scene.lights.resize(lightsBefore + 1); // one light per node
            scene.lights.back().rigJson = std::move(rigJson);
        }

        if (node.mesh >= 0) {
            if (size_t(node.mesh) >= model.meshes.size()) {
                failure = "node '" + nodeName + "' references a missing mesh";
                return;
            }
            scene.objectNames.push_back(nodeName);
            const auto objectId = static_cast<uint32_t>(scene.objectNames.size());
            const tinygltf::Mesh& mesh = model.meshes[size_t(node.mesh)];
            for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
                const std::string what = path + ": mesh '" + mesh.name + "' primitive " + std::to_string(pi);
                if (auto st = sceneload::readPrimitive(model, mesh.primitives[pi], world, objectId, what, scene, defaultMaterial); !st) {
                    failure = st.error().message;
                    return;
                }
            }
        }
        for (int child : node.children) visit(child, world);
        visiting.pop_back();
    };
    if (const tinygltf::Value& extras = model.scenes[size_t(sceneIndex)].extras; extras.IsObject() && extras.Has("dfb_rig")) {
        auto j = valueToJson(extras.Get("dfb_rig"), 0);
        if (!j) return makeError(ErrorCode::InvalidFile, path + ": scene extras.dfb_rig " + j.error().message);
        scene.rigSettingsJson = j->dump();
    }
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

SceneCamera autoFrameCamera(const Scene& scene, float yfovRadians, float aspect) {
    SceneCamera sphere = autoFrameCamera(scene.bounds, yfovRadians, aspect);
    const glm::dvec3 c(scene.bounds.center());
    const glm::dvec3 back = glm::normalize(glm::dvec3(0.0, 0.35, 1.0)); // from the target to the eye
    const glm::dvec3 right = glm::normalize(glm::cross(-back, glm::dvec3(0, 1, 0)));
    const glm::dvec3 up = glm::cross(right, -back);
    const double ty = std::tan(0.5 * double(yfovRadians)) * (1.0 - AUTO_FRAME_MARGIN);
    const double tx = std::tan(0.5 * double(yfovRadians)) * double(aspect) * (1.0 - AUTO_FRAME_MARGIN);
    // Each vertex q (relative to the centre) in the camera's axes: x, y across and s towards the
    // eye. An eye at c + a right + b up + d back sees it at depth z = d - s, inside the frame
    // when |x - a| <= tx z and |y - b| <= ty z: for a given d, a must lie in the intersection
    // over all vertices of [x - tx z, x + tx z] (likewise b), which is non-empty from some d on.
    struct Q {
        double x, y, s;
    };
    std::vector<Q> qs;
    for (const MeshPart& p : scene.parts)
        for (const glm::vec3& v : p.positions) {
            const glm::dvec3 q = glm::dvec3(v) - c;
            qs.push_back({glm::dot(q, right), glm::dot(q, up), glm::dot(q, back)});
        }
    if (qs.empty()) return sphere;
    double sMax = -1e300;
    for (const Q& q : qs) sMax = std::max(sMax, q.s);
    struct Fit {
        bool ok;
        double a, b;
        double xLo, xHi, yLo, yHi; ///< the eye offsets at which everything fits
    };
    auto fit = [&](double d) {
        double xLo = -1e300, xHi = 1e300, yLo = -1e300, yHi = 1e300;
        for (const Q& q : qs) {
            const double z = d - q.s;
            xLo = std::max(xLo, q.x - tx * z);
            xHi = std::min(xHi, q.x + tx * z);
            yLo = std::max(yLo, q.y - ty * z);
            yHi = std::min(yHi, q.y + ty * z);
        }
        return Fit{xLo <= xHi && yLo <= yHi, 0.5 * (xLo + xHi), 0.5 * (yLo + yHi), xLo, xHi, yLo, yHi};
    };
    // Centres the projection along one axis: the eye offset a (within [lo, hi], where everything
    // fits) at which the leftmost and rightmost image coordinates (u - a) / z are opposite; their
    // sum falls as a grows.
    auto centre = [&](double d, double lo, double hi, double Q::*u) {
        for (int i = 0; i < 50; ++i) {
            const double a = 0.5 * (lo + hi);
            double mn = 1e300, mx = -1e300;
            for (const Q& q : qs) {
                const double v = (q.*u - a) / (d - q.s);
                mn = std::min(mn, v), mx = std::max(mx, v);
            }
            (mn + mx > 0 ? lo : hi) = a;
        }
        return 0.5 * (lo + hi);
    };
    const double r = std::max(double(scene.bounds.radius()), 1e-6);
    double lo = sMax, hi = sMax + 4.0 * r / std::min(tx, ty) + r; // every vertex in front; surely fits
    if (!fit(hi).ok) return sphere;
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (fit(mid).ok ? hi : lo) = mid;
    }
    const Fit f = fit(hi);
    const double a = centre(hi, f.xLo, f.xHi, &Q::x), b = centre(hi, f.yLo, f.yHi, &Q::y);
    const glm::dvec3 eye = c + right * a + up * b + back * hi;
    SceneCamera cam = lookAtCamera(glm::vec3(eye), glm::vec3(eye - back), yfovRadians);
    cam.name = "auto";
    cam.aspect = aspect;
    double zMin = 1e300, zMax = 0;
    for (const Q& q : qs) {
        zMin = std::min(zMin, hi - q.s);
        zMax = std::max(zMax, hi - q.s);
    }
    cam.znear = float(std::max(1e-5 * r, 0.5 * zMin));
    cam.zfar = float(zMax * 1.5 + r * 1e-3);
    return cam;
}

} // namespace dfb
