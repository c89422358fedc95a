// Images, textures and materials of a glTF 2.0 file (sections 3.8-3.9; KHR_texture_transform,
// KHR_materials_emissive_strength, _specular, _sheen, _clearcoat) into the Scene's tables.

#include "SceneLoad.h"

#include <cmath>

namespace dfb::sceneload {

Status readMaterials(const tinygltf::Model& model, const LoadOptions& options, const std::string& path, Scene& scene) {
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
    return okStatus();
}

} // namespace dfb::sceneload
