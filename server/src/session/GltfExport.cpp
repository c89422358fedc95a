// The rig written into the session's scene as glTF (docs/gbuffer-format.md, "Lights in glTF").
//
// The scene is read with tinygltf without decoding its images (their encoded bytes are kept as
// they are), its own lights are taken out, one node per rig light is added at the root of the
// default scene, and the model is written as one self-contained GLB: every buffer is packed into
// the binary chunk and every image that came from a file or a data URI into a buffer view of it.

#include <dfb/server/GltfExport.h>

#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Codec.h>
#include <dfb/server/AreaPattern.h>

#include <tiny_gltf.h>

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>

namespace dfb {
namespace {

using json = nlohmann::json;
using Value = tinygltf::Value;

// A rig light's JSON as a tinygltf value. Numbers keep their JSON kind: integers stay integers
// (tinygltf holds 32-bit ones; a larger one becomes a double, exact up to 2^53) and doubles are
// written by the same shortest round-trip formatter nlohmann uses, so the float a rig holds comes
// back bit for bit. Rig JSON nests three levels; the depth bound only guards the recursion.
Value toValue(const json& j, int depth = 0) {
    if (depth > 64) return Value();
    switch (j.type()) {
    case json::value_t::boolean: return Value(j.get<bool>());
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: {
        const auto fits = j.is_number_unsigned() ? j.get<uint64_t>() <= uint64_t(std::numeric_limits<int>::max())
                                                 : j.get<int64_t>() >= std::numeric_limits<int>::min() &&
                                                       j.get<int64_t>() <= std::numeric_limits<int>::max();
        return fits ? Value(int(j.get<int64_t>())) : Value(j.get<double>());
    }
    case json::value_t::number_float: return Value(j.get<double>());
    case json::value_t::string: return Value(j.get<std::string>());
    case json::value_t::array: {
        Value::Array a;
        for (const json& x : j) a.push_back(toValue(x, depth + 1));
        return Value(std::move(a));
    }
    case json::value_t::object: {
        Value::Object o;
        for (auto it = j.begin(); it != j.end(); ++it) o[it.key()] = toValue(it.value(), depth + 1);
        return Value(std::move(o));
    }
    default: return Value();
    }
}

Value numbers(std::initializer_list<double> xs) {
    Value::Array a;
    for (double x : xs) a.push_back(Value(x));
    return Value(std::move(a));
}

// The encoded bytes of images that do not live in a buffer view (external files, data URIs), by
// image index: tinygltf hands every image to this callback, which decodes nothing.
struct ImageBytes {
    std::map<int, std::vector<unsigned char>> byIndex;
};

bool keepImageBytes(tinygltf::Image* image, const int index, std::string*, std::string*, int, int, const unsigned char* bytes,
                    int size, void* user) {
    if (image->bufferView < 0 && bytes && size > 0) static_cast<ImageBytes*>(user)->byIndex[index].assign(bytes, bytes + size);
    return true;
}

// Nothing is written beside the GLB: images go into its binary chunk (packImages).
bool writeNoImage(const std::string*, const std::string*, const tinygltf::Image*, bool, std::string*, void*) { return false; }

std::string mimeTypeOf(const std::vector<unsigned char>& b, const std::string& declared) {
    if (!declared.empty()) return declared;
    if (b.size() >= 4 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "image/png";
    if (b.size() >= 2 && b[0] == 0xFF && b[1] == 0xD8) return "image/jpeg";
    if (b.size() >= 12 && std::memcmp(b.data(), "RIFF", 4) == 0 && std::memcmp(b.data() + 8, "WEBP", 4) == 0) return "image/webp";
    if (b.size() >= 12 && std::memcmp(b.data() + 4, "ftypavif", 8) == 0) return "image/avif";
    return "application/octet-stream";
}

// One buffer (GLB has one binary chunk): the source's buffers end to end, each at an 8-byte
// boundary (accessors need their component size, 4 at most, to divide their offset), then the
// images that had none.
Status packBuffers(tinygltf::Model& model, ImageBytes& images, const std::string& where) {
    std::vector<unsigned char> bin;
    auto align = [&] { bin.resize((bin.size() + 7) & ~size_t(7), 0); };
    std::vector<size_t> start(model.buffers.size());
    for (size_t i = 0; i < model.buffers.size(); ++i) {
        align();
        start[i] = bin.size();
        bin.insert(bin.end(), model.buffers[i].data.begin(), model.buffers[i].data.end());
    }
    for (tinygltf::BufferView& v : model.bufferViews) {
        if (v.buffer < 0 || size_t(v.buffer) >= model.buffers.size()) {
            return makeError(ErrorCode::InvalidFile, where + ": a buffer view names a missing buffer");
        }
        v.byteOffset += start[size_t(v.buffer)];
        v.buffer = 0;
    }
    for (size_t i = 0; i < model.images.size(); ++i) {
        tinygltf::Image& img = model.images[i];
        auto it = images.byIndex.find(int(i));
        // An external image that could not be read keeps its URI, as the source had it.
        if (img.bufferView >= 0 || it == images.byIndex.end()) continue;
        align();
        tinygltf::BufferView v;
        v.buffer = 0;
        v.byteOffset = bin.size();
        v.byteLength = it->second.size();
        bin.insert(bin.end(), it->second.begin(), it->second.end());
        model.bufferViews.push_back(v);
        img.bufferView = int(model.bufferViews.size()) - 1;
        img.mimeType = mimeTypeOf(it->second, img.mimeType);
        img.uri.clear();
    }
    align();
    if (bin.size() > MAX_EXPORT_BYTES) {
        return makeError(ErrorCode::LimitExceeded, where + ": the packed buffers and images are " + std::to_string(bin.size() >> 20) +
                                                       " MiB, over the export limit of " + std::to_string(MAX_EXPORT_BYTES >> 20) + " MiB");
    }
    model.buffers.clear();
    if (!bin.empty()) {
        tinygltf::Buffer b;
        b.data = std::move(bin);
        model.buffers.push_back(std::move(b));
    }
    return okStatus();
}

// Takes the scene's own lights out: the KHR_lights_punctual lights and every node's reference to
// one, and the extras.dfb_area_light / dfb_light of nodes. Nodes that were nothing but a light
// are dropped (with their indices renumbered in scenes, children, skins and animations), so that a
// re-exported file holds each light once; not when an extension may address nodes by index in its
// own data (KHR_animation_pointer, MSFT_lod), which this cannot renumber.
void removeSceneLights(tinygltf::Model& model) {
    model.lights.clear();
    model.extensions.erase("KHR_lights_punctual");
    for (auto* list : {&model.extensionsUsed, &model.extensionsRequired}) {
        list->erase(std::remove(list->begin(), list->end(), "KHR_lights_punctual"), list->end());
    }
    std::vector<bool> drop(model.nodes.size(), false);
    for (size_t i = 0; i < model.nodes.size(); ++i) {
        tinygltf::Node& n = model.nodes[i];
        bool wasLight = n.extensions.erase("KHR_lights_punctual") > 0;
        if (n.extras.IsObject()) {
            Value::Object o = n.extras.Get<Value::Object>();
            wasLight = (o.erase("dfb_area_light") + o.erase("dfb_light")) > 0 || wasLight;
            n.extras = o.empty() ? Value() : Value(std::move(o));
        }
        drop[i] = wasLight && n.mesh < 0 && n.camera < 0 && n.skin < 0 && n.children.empty() && n.extensions.empty() &&
                  n.extras.Type() == tinygltf::NULL_TYPE;
    }
    for (const std::string& e : model.extensionsUsed) {
        if (e == "KHR_animation_pointer" || e == "MSFT_lod") return;
    }
    for (const tinygltf::Skin& s : model.skins) {
        for (int j : s.joints) {
            if (j >= 0 && size_t(j) < drop.size()) drop[size_t(j)] = false;
        }
        if (s.skeleton >= 0 && size_t(s.skeleton) < drop.size()) drop[size_t(s.skeleton)] = false;
    }
    for (const tinygltf::Animation& a : model.animations) {
        for (const tinygltf::AnimationChannel& c : a.channels) {
            if (c.target_node >= 0 && size_t(c.target_node) < drop.size()) drop[size_t(c.target_node)] = false;
        }
    }
    if (std::none_of(drop.begin(), drop.end(), [](bool d) { return d; })) return;
    std::vector<int> renumber(model.nodes.size(), -1);
    std::vector<tinygltf::Node> kept;
    for (size_t i = 0; i < model.nodes.size(); ++i) {
        if (drop[i]) continue;
        renumber[i] = int(kept.size());
        kept.push_back(std::move(model.nodes[i]));
    }
    model.nodes = std::move(kept);
    auto remap = [&](int i) { return i >= 0 && size_t(i) < renumber.size() ? renumber[size_t(i)] : i; };
    auto remapList = [&](std::vector<int>& list) {
        std::vector<int> out;
        for (int i : list) {
            if (remap(i) >= 0) out.push_back(remap(i));
        }
        list = std::move(out);
    };
    for (tinygltf::Scene& s : model.scenes) remapList(s.nodes);
    for (tinygltf::Node& n : model.nodes) remapList(n.children);
    for (tinygltf::Skin& s : model.skins) {
        remapList(s.joints);
        s.skeleton = remap(s.skeleton);
    }
    for (tinygltf::Animation& a : model.animations) {
        for (tinygltf::AnimationChannel& c : a.channels) c.target_node = remap(c.target_node);
    }
}

// The node of one light: placed at its position and turned so that its -Z is where the light
// points and its +X, +Y are the light's frame (spotFrame: right, up), or for area lights the
// emitter's width and height axes after the roll (areaFrame), as the import reads them.
tinygltf::Node lightNode(const Light& raw, const Light& now) {
    tinygltf::Node n;
    n.name = raw.name;
    n.translation = {double(now.position[0]), double(now.position[1]), double(now.position[2])};
    glm::dvec3 x, y, z;
    if (now.type == LightType::Area || now.type == LightType::BentArea) {
        const auto f = areaFrameOf<double>(now);
        x = f.right;
        y = f.up;
        z = -f.normal;
    } else {
        const auto f = lightmath::spotFrame<double>(glm::dvec3(now.direction[0], now.direction[1], now.direction[2]));
        x = f.right;
        y = f.up;
        z = -f.axis;
    }
    const glm::dquat q = glm::normalize(glm::quat_cast(glm::dmat3(x, y, z)));
    n.rotation = {q.x, q.y, q.z, q.w};
    Value::Object extras{{"dfb_light", toValue(protocol::toJson(raw))}};
    if (raw.type == LightType::Area || raw.type == LightType::BentArea) {
        // The documented area-light convention (docs/gbuffer-format.md, "Lights in glTF"),
        // for readers that know it but not dfb_light; a bent area light as its straight emitter.
        Value::Object a{{"shape", Value(std::string(now.areaShape == AreaShape::Disk ? "disk" : "rect"))},
                        {"size", numbers({now.areaSize[0], now.areaSize[1]})},
                        {"intensity", Value(double(now.intensityCd))},
                        {"color", numbers({now.color[0], now.color[1], now.color[2]})},
                        {"shadowGrid", Value(Value::Array{Value(now.shadowGrid[0]), Value(now.shadowGrid[1])})}};
        if (!now.pattern.empty()) a["pattern"] = Value(now.pattern);
        extras["dfb_area_light"] = Value(std::move(a));
    }
    n.extras = Value(std::move(extras));
    return n;
}

Result<std::string> exportModel(const std::string& scenePath, const Rig& rig) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::is_regular_file(scenePath, ec)) return makeError(ErrorCode::FileNotFound, scenePath + ": the session's scene is not there");
    const auto fileSize = fs::file_size(scenePath, ec);
    if (ec) return makeError(ErrorCode::IoError, scenePath + ": cannot read the session's scene (" + ec.message() + ")");
    if (fileSize > MAX_EXPORT_BYTES) {
        return makeError(ErrorCode::LimitExceeded, scenePath + ": the scene is " + std::to_string(fileSize >> 20) +
                                                       " MiB, over the export limit of " + std::to_string(MAX_EXPORT_BYTES >> 20) + " MiB");
    }
    std::vector<unsigned char> bytes(static_cast<size_t>(fileSize));
    FILE* f = std::fopen(scenePath.c_str(), "rb");
    if (!f) return makeError(ErrorCode::FileNotFound, scenePath + ": cannot open the session's scene");
    const size_t got = bytes.empty() ? 0 : std::fread(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    if (got != bytes.size()) return makeError(ErrorCode::IoError, scenePath + ": short read");

    tinygltf::Model model;
    tinygltf::TinyGLTF io;
    ImageBytes images;
    io.SetImageLoader(keepImageBytes, &images);
    io.SetImageWriter(writeNoImage, nullptr);
    std::string err, warn;
    const std::string baseDir = fs::path(scenePath).parent_path().string();
    const bool glb = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    const bool ok = glb ? io.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), unsigned(bytes.size()), baseDir)
                        : io.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()),
                                                 unsigned(bytes.size()), baseDir);
    if (!ok) return makeError(ErrorCode::InvalidFile, scenePath + ": glTF parse error: " + err);
    bytes = {};
    if (model.scenes.empty()) return makeError(ErrorCode::MissingData, scenePath + ": the file has no scene");
    const size_t sceneIndex = model.defaultScene >= 0 ? size_t(model.defaultScene) : 0;
    if (sceneIndex >= model.scenes.size()) return makeError(ErrorCode::InvalidFile, scenePath + ": default scene index out of range");

    if (auto s = packBuffers(model, images, scenePath); !s) return s.error();
    images = {};
    removeSceneLights(model);

    const Rig now = protocol::evaluateRig(rig); // the punctual lights and nodes show the rig at its time
    for (size_t i = 0; i < rig.lights.size(); ++i) {
        const Light& raw = rig.lights[i];
        const Light& cur = now.lights[i];
        tinygltf::Node n = lightNode(raw, cur);
        const PunctualLight p = punctualLight(cur);
        if (!p.type.empty()) {
            tinygltf::Light l;
            l.name = raw.name;
            l.type = p.type;
            l.color = {p.color[0], p.color[1], p.color[2]};
            l.intensity = p.intensity;
            if (p.type == "spot") {
                l.spot.innerConeAngle = p.innerConeAngle;
                l.spot.outerConeAngle = p.outerConeAngle;
            }
            // Informative only: import reads the node's dfb_light and ignores this light.
            if (raw.type == LightType::Bendy) l.extras = Value(Value::Object{{"dfb_standin", Value(std::string("bendy"))}});
            model.lights.push_back(l);
            n.extensions["KHR_lights_punctual"] = Value(Value::Object{{"light", Value(int(model.lights.size()) - 1)}});
        }
        model.nodes.push_back(std::move(n));
        model.scenes[sceneIndex].nodes.push_back(int(model.nodes.size()) - 1);
    }
    // tinygltf adds KHR_lights_punctual to extensionsUsed when there are lights; never required.
    tinygltf::Scene& scene = model.scenes[sceneIndex];
    Value::Object sceneExtras = scene.extras.IsObject() ? scene.extras.Get<Value::Object>() : Value::Object{};
    sceneExtras["dfb_rig"] = Value(Value::Object{{"exposure", Value(double(rig.exposureStops))},
                                                 {"viewTransform", Value(std::string(rig.viewTransform == ViewTransform::Filmic ? "filmic" : "srgb"))},
                                                 {"time", Value(rig.time)}});
    scene.extras = Value(std::move(sceneExtras));
    model.asset.generator = "dfb-server glTF export" + (model.asset.generator.empty() ? "" : " (scene by " + model.asset.generator + ")");

    std::ostringstream out;
    if (!io.WriteGltfSceneToStream(&model, out, false, true)) return makeError(ErrorCode::IoError, scenePath + ": writing the GLB failed");
    std::string glbBytes = std::move(out).str();
    if (glbBytes.size() > MAX_EXPORT_BYTES) {
        return makeError(ErrorCode::LimitExceeded, scenePath + ": the exported file is " + std::to_string(glbBytes.size() >> 20) +
                                                       " MiB, over the export limit of " + std::to_string(MAX_EXPORT_BYTES >> 20) + " MiB");
    }
    return glbBytes;
}

} // namespace

PunctualLight punctualLight(const Light& l) {
    PunctualLight p;
    if (!l.enabled) return p; // other renderers would light with it: a disabled light is extras only
    switch (l.type) {
    case LightType::Spot:
    case LightType::Bendy: p.type = "spot"; break;
    case LightType::Point: p.type = "point"; break;
    case LightType::Directional: p.type = "directional"; break;
    case LightType::Area:
    case LightType::BentArea:
    case LightType::Environment: return p;
    }
    // KHR_lights_punctual's colour is in [0, 1] (its schema); ours may exceed 1. The excess goes
    // into the intensity, so colour x intensity is the rig's. The rig's units are the extension's
    // (candela for spot and point lights, lux for directional ones): no other conversion.
    const double m = std::max({double(l.color[0]), double(l.color[1]), double(l.color[2])});
    const double scale = m > 1 ? m : 1;
    for (int c = 0; c < 3; ++c) p.color[c] = double(l.color[size_t(c)]) / scale;
    p.intensity = double(l.intensityCd) * scale;
    constexpr double DEG = 3.14159265358979323846 / 180;
    p.outerConeAngle = double(l.coneAngleDeg) * DEG;
    p.innerConeAngle = std::max(0.0, double(l.coneAngleDeg - l.penumbraDeg) * DEG);
    // The extension wants innerConeAngle < outerConeAngle; a hard-edged cone (penumbra 0) gets an
    // edge of a millionth of its angle, which stays distinct when a reader rounds to 32-bit floats.
    if (!(p.innerConeAngle < p.outerConeAngle)) p.innerConeAngle = p.outerConeAngle * (1 - 1e-6);
    return p;
}

Result<std::string> exportGltf(const std::string& scenePath, const Rig& rig) {
    if (rig.lights.empty()) return makeError(ErrorCode::MissingData, "the rig has no lights: there is nothing to export");
    // No exception may leave (the caller is a server thread): whatever a malformed file makes a
    // library throw becomes an error naming the file.
    try {
        return exportModel(scenePath, rig);
    } catch (const std::bad_alloc&) {
        return makeError(ErrorCode::InvalidFile, scenePath + ": out of memory while exporting");
    } catch (const std::exception& e) {
        return makeError(ErrorCode::InvalidFile, scenePath + ": malformed glTF (" + std::string(e.what()) + ")");
    }
}

} // namespace dfb
