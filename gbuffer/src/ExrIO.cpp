#include <dfb/gbuffer/ExrIO.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfFloatAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <ImfStringVectorAttribute.h>
#include <ImfTestFile.h>
#include <Iex.h>
#include <Imath/half.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>
#include <unistd.h>
#include <sys/stat.h>

namespace dfb {
namespace {

// A file channel and where its samples live in a DeepBuffer layer.
struct ChannelSpec {
    const char* name;
    Imf::PixelType fileType;
    int component;   // index within the layer's components
    int components;  // components per pixel in the layer
    bool required;
    std::function<char*(DeepBuffer&)> base;
};

// The channel table of format v1 (docs/gbuffer-format.md). Positions and depth are float for
// precision over large scenes; directions, colours and lobe parameters are half.
std::vector<ChannelSpec> channelSpecs() {
    using PT = Imf::PixelType;
    auto f = [](std::vector<float> DeepBuffer::*m) {
        return [m](DeepBuffer& b) { return reinterpret_cast<char*>((b.*m).data()); };
    };
    auto u = [](std::vector<uint32_t> DeepBuffer::*m) {
        return [m](DeepBuffer& b) { return reinterpret_cast<char*>((b.*m).data()); };
    };
    return {
        {"P.X", PT::FLOAT, 0, 3, true, f(&DeepBuffer::P)},
        {"P.Y", PT::FLOAT, 1, 3, true, f(&DeepBuffer::P)},
        {"P.Z", PT::FLOAT, 2, 3, true, f(&DeepBuffer::P)},
        {"N.X", PT::HALF, 0, 3, true, f(&DeepBuffer::N)},
        {"N.Y", PT::HALF, 1, 3, true, f(&DeepBuffer::N)},
        {"N.Z", PT::HALF, 2, 3, true, f(&DeepBuffer::N)},
        {"Ng.X", PT::HALF, 0, 3, false, f(&DeepBuffer::Ng)},
        {"Ng.Y", PT::HALF, 1, 3, false, f(&DeepBuffer::Ng)},
        {"Ng.Z", PT::HALF, 2, 3, false, f(&DeepBuffer::Ng)},
        {"Z", PT::FLOAT, 0, 1, true, f(&DeepBuffer::Z)},
        {"albedo.R", PT::HALF, 0, 3, true, f(&DeepBuffer::albedo)},
        {"albedo.G", PT::HALF, 1, 3, true, f(&DeepBuffer::albedo)},
        {"albedo.B", PT::HALF, 2, 3, true, f(&DeepBuffer::albedo)},
        {"brdf.metallic", PT::HALF, 0, 4, true, f(&DeepBuffer::brdf)},
        {"brdf.roughness", PT::HALF, 1, 4, true, f(&DeepBuffer::brdf)},
        {"brdf.specular", PT::HALF, 2, 4, false, f(&DeepBuffer::brdf)},
        {"brdf.occlusion", PT::HALF, 3, 4, false, f(&DeepBuffer::brdf)},
        {"emission.R", PT::HALF, 0, 3, false, f(&DeepBuffer::emission)},
        {"emission.G", PT::HALF, 1, 3, false, f(&DeepBuffer::emission)},
        {"emission.B", PT::HALF, 2, 3, false, f(&DeepBuffer::emission)},
        {"A", PT::HALF, 0, 1, true, f(&DeepBuffer::A)},
        {"id.object", PT::UINT, 0, 1, true, u(&DeepBuffer::objectId)},
        {"id.material", PT::UINT, 0, 1, true, u(&DeepBuffer::materialId)},
    };
}

Imath::M44f toImath(const glm::mat4& m) {
    Imath::M44f r;
    // Imath uses row vectors (p' = p * M) and glm column vectors (p' = M * p) with column-major
    // storage, so the two memory layouts coincide: r[i][j] = m[i][j].
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) r[i][j] = m[i][j];
    return r;
}

glm::mat4 toGlm(const Imath::M44f& m) {
    glm::mat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) r[i][j] = m[i][j];
    return r;
}

// Largest accepted image side. A shot is a single frame; 32k covers any plate while rejecting
// corrupt headers that would otherwise make us allocate terabytes.
constexpr int MAX_SIDE = 32768;

} // namespace

Status writeDeepBuffer(const DeepBuffer& b, const std::string& path) {
    if (b.width <= 0 || b.height <= 0 || b.P.size() != b.pixelCount() * 3) {
        return makeError(ErrorCode::InvalidValue, "refusing to write " + path + ": deep buffer is empty or inconsistent");
    }
    const std::string tmp = path + ".tmp" + std::to_string(::getpid());
    try {
        Imf::Header header(b.width, b.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        Imf::addWorldToCamera(header, toImath(b.camera.worldToCamera));
        Imf::addWorldToNDC(header, toImath(b.camera.worldToNDC));
        header.insert("dfb.formatVersion", Imf::IntAttribute(GBUFFER_FORMAT_VERSION));
        header.insert("dfb.camera.name", Imf::StringAttribute(b.camera.name));
        header.insert("dfb.camera.yfov", Imf::FloatAttribute(b.camera.yfovRadians));
        header.insert("dfb.camera.aspect", Imf::FloatAttribute(b.camera.aspect));
        header.insert("dfb.camera.near", Imf::FloatAttribute(b.camera.znear));
        header.insert("dfb.camera.far", Imf::FloatAttribute(b.camera.zfar));
        header.insert("dfb.source", Imf::StringAttribute(b.sourcePath));
        nlohmann::json manifest = {{"objects", b.objectNames}, {"materials", b.materialNames}};
        header.insert("dfb.manifest", Imf::StringAttribute(manifest.dump()));

        Imf::FrameBuffer fb;
        DeepBuffer& mb = const_cast<DeepBuffer&>(b); // slices take char*; we only read from them
        // OutputFile needs slices of the channel's own type (only InputFile converts), so half
        // channels are staged in half buffers.
        std::vector<std::vector<half>> halves;
        halves.reserve(channelSpecs().size());
        for (const ChannelSpec& c : channelSpecs()) {
            header.channels().insert(c.name, Imf::Channel(c.fileType));
            const bool isUint = c.fileType == Imf::UINT;
            const size_t elem = isUint ? sizeof(uint32_t) : sizeof(float);
            char* base = c.base(mb) + elem * c.component;
            if (c.fileType == Imf::HALF) {
                const float* src = reinterpret_cast<const float*>(base);
                auto& h = halves.emplace_back(b.pixelCount());
                for (size_t i = 0; i < h.size(); ++i) h[i] = half(src[i * size_t(c.components)]);
                fb.insert(c.name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(h.data()), sizeof(half),
                                             sizeof(half) * size_t(b.width)));
                continue;
            }
            fb.insert(c.name, Imf::Slice(isUint ? Imf::UINT : Imf::FLOAT, base, elem * c.components,
                                         elem * c.components * b.width));
        }
        Imf::OutputFile file(tmp.c_str(), header);
        file.setFrameBuffer(fb);
        file.writePixels(b.height);
    } catch (const std::exception& e) {
        std::remove(tmp.c_str());
        return makeError(ErrorCode::IoError, "writing " + path + ": " + e.what());
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::remove(tmp.c_str());
        return makeError(ErrorCode::IoError, "renaming " + tmp + " to " + path + ": " + ec.message());
    }
    return okStatus();
}

Result<DeepBuffer> readDeepBuffer(const std::string& path) {
    struct stat st{};
    if (::stat(path.c_str(), &st) != 0) {
        return makeError(ErrorCode::FileNotFound, path + ": no such file");
    }
    DeepBuffer b;
    std::set<std::string> missing;
    try {
        if (!Imf::isOpenExrFile(path.c_str())) {
            return makeError(ErrorCode::InvalidFile, path + ": not an OpenEXR file");
        }
        Imf::InputFile file(path.c_str());
        const Imf::Header& h = file.header();
        const Imath::Box2i dw = h.dataWindow();
        const Imath::Box2i disp = h.displayWindow();
        const long w = long(dw.max.x) - dw.min.x + 1;
        const long hgt = long(dw.max.y) - dw.min.y + 1;
        if (w <= 0 || hgt <= 0 || w > MAX_SIDE || hgt > MAX_SIDE) {
            return makeError(ErrorCode::InvalidValue, path + ": absurd image size " + std::to_string(w) +
                                                          "x" + std::to_string(hgt));
        }
        if (dw != disp) {
            return makeError(ErrorCode::InvalidFile, path + ": data window differs from display window");
        }
        b.allocate(int(w), int(hgt));

        Imf::FrameBuffer fb;
        for (const ChannelSpec& c : channelSpecs()) {
            const Imf::Channel* ch = h.channels().findChannel(c.name);
            if (!ch) missing.insert(c.name);
            if (!ch) {
                if (c.required) {
                    return makeError(ErrorCode::MissingData, path + ": required channel '" + c.name + "' is missing");
                }
                continue;
            }
            const bool wantUint = c.fileType == Imf::UINT;
            if (wantUint != (ch->type == Imf::UINT)) {
                return makeError(ErrorCode::InvalidFile, path + ": channel '" + c.name + "' has the wrong type (" +
                                                             (wantUint ? "uint expected" : "half or float expected") + ")");
            }
            if (ch->xSampling != 1 || ch->ySampling != 1) {
                return makeError(ErrorCode::InvalidFile, path + ": channel '" + c.name + "' is subsampled");
            }
            const size_t elem = wantUint ? sizeof(uint32_t) : sizeof(float);
            char* base = c.base(b) + elem * c.component;
            // Slices are addressed from the data window origin (OpenEXR's base-pointer rule).
            base -= (long(dw.min.y) * w + dw.min.x) * long(elem * c.components);
            fb.insert(c.name, Imf::Slice(wantUint ? Imf::UINT : Imf::FLOAT, base, elem * c.components,
                                         elem * c.components * size_t(w)));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);

        if (const auto* a = h.findTypedAttribute<Imf::M44fAttribute>("worldToCamera")) {
            b.camera.worldToCamera = toGlm(a->value());
        } else {
            return makeError(ErrorCode::MissingData, path + ": header attribute 'worldToCamera' is missing");
        }
        if (const auto* a = h.findTypedAttribute<Imf::M44fAttribute>("worldToNDC")) {
            b.camera.worldToNDC = toGlm(a->value());
        } else {
            return makeError(ErrorCode::MissingData, path + ": header attribute 'worldToNDC' is missing");
        }
        if (const auto* a = h.findTypedAttribute<Imf::IntAttribute>("dfb.formatVersion")) {
            if (a->value() != GBUFFER_FORMAT_VERSION) {
                return makeError(ErrorCode::InvalidFile, path + ": format version " + std::to_string(a->value()) +
                                                             " is not supported (this build reads " +
                                                             std::to_string(GBUFFER_FORMAT_VERSION) + ")");
            }
        }
        auto getFloat = [&](const char* name, float& out) {
            if (const auto* a = h.findTypedAttribute<Imf::FloatAttribute>(name)) out = a->value();
        };
        getFloat("dfb.camera.yfov", b.camera.yfovRadians);
        getFloat("dfb.camera.aspect", b.camera.aspect);
        getFloat("dfb.camera.near", b.camera.znear);
        getFloat("dfb.camera.far", b.camera.zfar);
        if (const auto* a = h.findTypedAttribute<Imf::StringAttribute>("dfb.camera.name")) b.camera.name = a->value();
        if (const auto* a = h.findTypedAttribute<Imf::StringAttribute>("dfb.source")) b.sourcePath = a->value();
        if (const auto* a = h.findTypedAttribute<Imf::StringAttribute>("dfb.manifest")) {
            auto j = nlohmann::json::parse(a->value(), nullptr, false);
            if (j.is_discarded() || !j.is_object()) {
                return makeError(ErrorCode::InvalidFile, path + ": header attribute 'dfb.manifest' is not valid JSON");
            }
            try {
                b.objectNames = j.value("objects", std::vector<std::string>{});
                b.materialNames = j.value("materials", std::vector<std::string>{});
            } catch (const nlohmann::json::exception&) {
                return makeError(ErrorCode::InvalidFile, path + ": 'dfb.manifest' lists are not string arrays");
            }
        }
    } catch (const std::exception& e) {
        return makeError(ErrorCode::InvalidFile, path + ": " + e.what());
    }

    // Optional channels take their documented defaults (docs/gbuffer-format.md).
    for (size_t i = 0; i < b.pixelCount(); ++i) {
        if (b.A[i] <= 0.f) continue;
        if (missing.count("brdf.specular")) b.brdf[i * 4 + 2] = 0.5f;
        if (missing.count("brdf.occlusion")) b.brdf[i * 4 + 3] = 1.f;
        if (missing.count("Ng.X")) {
            for (int c = 0; c < 3; ++c) b.Ng[i * 3 + c] = b.N[i * 3 + c];
        }
    }

    // Covered pixels must have finite geometry: the relight loop would otherwise spread NaNs.
    for (int y = 0; y < b.height; ++y) {
        for (int x = 0; x < b.width; ++x) {
            const size_t i = size_t(y) * b.width + x;
            const float a = b.A[i];
            if (!std::isfinite(a) || a < 0.f || a > 1.f + 1e-3f) {
                return makeError(ErrorCode::InvalidValue, path + ": coverage A at pixel (" + std::to_string(x) + ", " +
                                                              std::to_string(y) + ") is out of [0,1]");
            }
            if (a <= 0.f) continue;
            for (int c = 0; c < 3; ++c) {
                if (!std::isfinite(b.P[i * 3 + c]) || !std::isfinite(b.N[i * 3 + c])) {
                    return makeError(ErrorCode::InvalidValue, path + ": non-finite P or N at pixel (" +
                                                                  std::to_string(x) + ", " + std::to_string(y) + ")");
                }
            }
        }
    }
    return b;
}

} // namespace dfb
