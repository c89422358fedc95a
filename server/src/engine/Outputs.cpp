#include <dfb/server/Outputs.h>

#include <dfb/gbuffer/LayerImage.h>
#include <dfb/server/EnvironmentReference.h>
#include <dfb/server/ImageCodec.h>

#include <dfb/lightmath/Environment.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>

namespace dfb {
namespace {

// The filmic view transform: the ACES curve fitted by Narkowicz (2016), as composite_tonemap.frag.
// The curve reaches 1 at x = 7.24; the cap at 1e4 keeps x * x finite.
float filmic(float x) {
    x = std::clamp(x, 0.f, 1e4f);
    return std::clamp((x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f), 0.f, 1.f);
}

float srgbEncode(float c) {
    c = std::clamp(c, 0.f, 1.f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

// An 8-bit image of `f` with `encode` per colour channel, alpha 255.
template <class Encode>
Image8 toImage8(const ImageF& f, Encode encode) {
    Image8 img;
    img.width = f.width;
    img.height = f.height;
    img.rgba.resize(f.rgba.size());
    for (size_t i = 0; i < f.rgba.size(); i += 4) {
        for (size_t c = 0; c < 3; ++c) img.rgba[i + c] = uint8_t(std::lround(encode(f.rgba[i + c]) * 255.f));
        img.rgba[i + 3] = 255;
    }
    return img;
}

struct Parsed {
    std::string kind; // beauty, light, shadow, layer
    std::string name;
};

Result<Parsed> parse(const OutputRequest& r) {
    if (r.format != "png" && r.format != "jpeg" && r.format != "jpg" && r.format != "exr") {
        return makeError(ErrorCode::InvalidValue, "unknown format '" + r.format + "' (jpeg, png or exr)");
    }
    if (r.output == "beauty" || r.output.empty()) return Parsed{"beauty", ""};
    const size_t colon = r.output.find(':');
    Parsed p{r.output.substr(0, colon), colon == std::string::npos ? "" : r.output.substr(colon + 1)};
    if ((p.kind != "light" && p.kind != "reference" && p.kind != "shadow" && p.kind != "layer") || p.name.empty()) {
        return makeError(ErrorCode::InvalidValue,
                         "unknown output '" + r.output + "' (beauty, light:NAME, reference:NAME, shadow:NAME or layer:NAME)");
    }
    if (p.kind == "layer" && r.format == "exr") {
        return makeError(ErrorCode::InvalidValue, "layer outputs are 8-bit views (png, jpeg); the shot's EXR file holds the float layers");
    }
    return p;
}

Result<EncodedImage> encode8(const Image8& img, const OutputRequest& r) {
    auto bytes = r.format == "png" ? encodePng(img) : encodeJpeg(img, r.jpegQuality);
    if (!bytes) return bytes.error();
    return EncodedImage{std::move(bytes.value()), r.format == "png" ? "image/png" : "image/jpeg", img.width, img.height};
}

Result<EncodedImage> encodeFloat(std::vector<NamedImageF> layers) {
    const int w = layers.at(0).image.width, h = layers.at(0).image.height;
    auto bytes = encodeExr(layers);
    if (!bytes) return bytes.error();
    return EncodedImage{std::move(bytes.value()), "image/x-exr", w, h};
}

void scale(ImageF& img, float s, bool alphaToo) {
    for (size_t i = 0; i < img.rgba.size(); ++i)
        if (alphaToo || i % 4 != 3) img.rgba[i] *= s;
}

// Maps the backdrop read, by path, while the file's time and size stay the same: a viewer's
// frames are encoded once per rig version and would otherwise read the file each time. At most
// MAX_CACHED_MAPS (the largest map is 512 MiB as RGBA float).
struct CachedMap {
    std::filesystem::file_time_type time;
    uintmax_t size = 0;
    std::shared_ptr<const ImageF> image;
};
constexpr size_t MAX_CACHED_MAPS = 2;
std::mutex gMapMutex;
std::map<std::string, CachedMap> gMaps;

Result<std::shared_ptr<const ImageF>> backdropMap(const std::string& path) {
    std::error_code ec;
    const auto time = std::filesystem::last_write_time(path, ec);
    const uintmax_t size = ec ? 0 : std::filesystem::file_size(path, ec);
    {
        std::lock_guard lock(gMapMutex);
        if (auto it = gMaps.find(path); !ec && it != gMaps.end() && it->second.time == time && it->second.size == size) {
            return it->second.image;
        }
    }
    auto img = readHdrImage(path, MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
    if (!img) return img.error();
    auto shared = std::make_shared<const ImageF>(std::move(img.value()));
    std::lock_guard lock(gMapMutex);
    if (gMaps.size() >= MAX_CACHED_MAPS && !gMaps.count(path)) gMaps.erase(gMaps.begin());
    gMaps[path] = CachedMap{time, size, shared};
    return shared;
}

// Bilinear lookup of a latitude-longitude map at map direction d (lightmath::envLatLong; texel
// centres at (i + 0.5) / w), wrapping around in u and clamped at the poles.
glm::vec3 mapRadiance(const ImageF& m, const glm::dvec3& d) {
    const glm::dvec2 uv = lightmath::envLatLong(d);
    const double x = uv.x * m.width - 0.5, y = std::clamp(uv.y * m.height - 0.5, 0.0, double(m.height - 1));
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const float fx = float(x - x0), fy = float(y - y0);
    auto at = [&](int i, int j) {
        i = ((i % m.width) + m.width) % m.width;
        j = std::clamp(j, 0, m.height - 1);
        const float* t = &m.rgba[(size_t(j) * size_t(m.width) + size_t(i)) * 4];
        return glm::vec3(t[0], t[1], t[2]);
    };
    return glm::mix(glm::mix(at(x0, y0), at(x0 + 1, y0), fx), glm::mix(at(x0, y0 + 1), at(x0 + 1, y0 + 1), fx), fy);
}

} // namespace

Result<ImageF> environmentBackground(const DeepBuffer& shot, const Rig& rig, const std::string& assetDir) {
    ImageF out;
    out.width = shot.width;
    out.height = shot.height;
    out.rgba.assign(shot.pixelCount() * 4, 0.f);
    struct Env {
        glm::dmat3 rotation;
        glm::vec3 scale;
        std::shared_ptr<const ImageF> map; // null: the constant colour
    };
    std::vector<Env> envs;
    for (const Light& l : rig.lights) {
        if (l.type != LightType::Environment || !l.enabled) continue;
        Env e{lightmath::envRotation(l.envRotationDeg), glm::vec3(l.color[0], l.color[1], l.color[2]) * l.intensityCd, nullptr};
        if (!l.envMap.empty()) {
            auto m = backdropMap((std::filesystem::path(assetDir) / l.envMap).string());
            if (!m) return makeError(m.error().code, "light '" + l.name + "': map '" + l.envMap + "': " + m.error().message);
            e.map = m.value();
        }
        envs.push_back(std::move(e));
    }
    if (envs.empty()) return out;
    // The camera ray through a pixel's centre: from NDC depth -1 to 1 (docs/gbuffer-format.md,
    // "NDC"), perspective and orthographic alike.
    const glm::dmat4 fromNdc = glm::inverse(glm::dmat4(shot.camera.worldToNDC));
    for (int y = 0; y < shot.height; ++y) {
        for (int x = 0; x < shot.width; ++x) {
            const float uncovered = 1.f - std::clamp(shot.coverage(x, y), 0.f, 1.f);
            if (uncovered <= 0.f) continue;
            const double nx = (x + 0.5) / shot.width * 2 - 1, ny = 1 - (y + 0.5) / shot.height * 2;
            const glm::dvec4 a = fromNdc * glm::dvec4(nx, ny, -1, 1), b = fromNdc * glm::dvec4(nx, ny, 1, 1);
            const glm::dvec3 dir = glm::normalize(glm::dvec3(b) / b.w - glm::dvec3(a) / a.w);
            glm::vec3 sum(0.f);
            for (const Env& e : envs) {
                // World = R map: the map direction is R^T world.
                sum += e.scale * (e.map ? mapRadiance(*e.map, glm::transpose(e.rotation) * dir) : glm::vec3(1.f));
            }
            float* px = &out.rgba[(size_t(y) * size_t(shot.width) + size_t(x)) * 4];
            for (int c = 0; c < 3; ++c) px[c] = uncovered * sum[c];
        }
    }
    return out;
}

Result<EncodedImage> renderOutput(Engine& engine, const DeepBuffer& shot, const Rig& rig, const OutputRequest& request,
                                  const ReferenceScene& reference) {
    auto parsed = parse(request);
    if (!parsed) return parsed.error();
    const auto& [kind, name] = parsed.value();
    const float exposure = std::exp2(rig.exposureStops);
    const bool exr = request.format == "exr";
    if (kind == "beauty") {
        if (!exr && request.background) {
            auto linear = engine.renderLinear(rig);
            if (!linear) return linear.error();
            auto back = environmentBackground(shot, rig, reference.assetDir);
            if (!back) return back.error();
            ImageF& f = linear.value();
            for (size_t i = 0; i < f.rgba.size(); ++i) f.rgba[i] = exposure * (f.rgba[i] + back->rgba[i]);
            return encode8(displayImage(f, rig.viewTransform), request);
        }
        if (!exr) {
            auto img = engine.render(rig);
            if (!img) return img.error();
            return encode8(img.value(), request);
        }
        auto layers = engine.renderLayers(rig);
        if (!layers) return layers.error();
        for (NamedImageF& l : layers.value()) scale(l.image, exposure, false);
        return encodeFloat(std::move(layers.value()));
    }
    if (kind == "layer") {
        auto rgb = layerImage(shot, name);
        if (!rgb) return rgb.error();
        Image8 img;
        img.width = shot.width;
        img.height = shot.height;
        img.rgba.resize(size_t(img.width) * size_t(img.height) * 4, 255);
        for (size_t p = 0; p < size_t(img.width) * size_t(img.height); ++p)
            for (int c = 0; c < 3; ++c) img.rgba[p * 4 + size_t(c)] = rgb.value()[p * 3 + size_t(c)];
        return encode8(img, request);
    }
    const Light* light = rig.find(name);
    const bool environment = kind == "reference" && light && light->type == LightType::Environment;
    if (environment && !reference.scene) {
        return makeError(ErrorCode::InvalidValue, "light '" + name + "': no reference here (the scene's hierarchy is not loaded)");
    }
    if (environment && !light->enabled) return makeError(ErrorCode::InvalidValue, "light '" + name + "' is disabled");
    auto linear = kind == "light"     ? engine.renderLightLinear(rig, name)
                  : environment       ? renderEnvironmentReference(shot, reference.scene, reference.sceneRadius, *light,
                                                                   reference.assetDir, ENV_REFERENCE_OUTPUT_RAYS)
                  : kind == "reference" ? engine.renderAreaReference(rig, name, AREA_REFERENCE_OUTPUT_CELLS)
                                        : engine.renderShadowMask(rig, name);
    if (!linear) return linear.error();
    ImageF& f = linear.value();
    if (kind == "shadow") {
        for (size_t i = 0; i < f.rgba.size(); i += 4) {
            const float coverage = f.rgba[i + 1];
            const float vis = coverage > 0.f ? std::clamp(f.rgba[i] / coverage, 0.f, 1.f) * std::min(coverage, 1.f) : 0.f;
            f.rgba[i] = f.rgba[i + 1] = f.rgba[i + 2] = vis;
            f.rgba[i + 3] = std::min(coverage, 1.f);
        }
    } else {
        scale(f, exposure, false);
        for (size_t i = 3; i < f.rgba.size(); i += 4) f.rgba[i] = 1.f;
    }
    if (exr) return encodeFloat({{"", std::move(f)}});
    if (kind == "shadow") return encode8(toImage8(f, [](float x) { return std::clamp(x, 0.f, 1.f); }), request);
    return encode8(displayImage(f, rig.viewTransform), request);
}

Image8 displayImage(const ImageF& image, ViewTransform viewTransform) {
    if (viewTransform == ViewTransform::Filmic) return toImage8(image, [](float x) { return srgbEncode(filmic(x)); });
    return toImage8(image, srgbEncode);
}

} // namespace dfb
