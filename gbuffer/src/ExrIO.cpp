#include <dfb/gbuffer/ExrIO.h>

#include <ImfChannelList.h>
#include <ImfDeepFrameBuffer.h>
#include <ImfDeepScanLineInputFile.h>
#include <ImfDeepScanLineOutputFile.h>
#include <ImfFloatAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfPartType.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <ImfTestFile.h>
#include <ImfStdIO.h>
#include <ImfXdr.h>
#include <Iex.h>
#include <Imath/half.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <functional>
#include <set>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace dfb {
namespace {

// A file channel and where its samples live in a DeepBuffer layer.
enum class OptionalLayer { None, EnvTransfer, EnvTransferHigh, EnvLobe, EnvRings, Horizon };

struct ChannelSpec {
    const char* name;
    Imf::PixelType fileType;
    int component;  // index within the layer's components
    int components; // components per sample in the layer
    bool required;
    std::function<char*(DeepBuffer&)> base;
    // An optional layer's channels are written only when the buffer holds the layer, and a file
    // holds all of them or none.
    OptionalLayer layer = OptionalLayer::None;
};

// The optional layers: what a refusal of a partial layer calls it and names, the first channel
// (its absence means the file has none), and whether a buffer holds it.
struct LayerInfo {
    const char* name;
    const char* channels;
    const char* firstChannel;
    bool (*held)(const DeepBuffer&);
};
LayerInfo layerInfo(OptionalLayer l) {
    if (l == OptionalLayer::Horizon)
        return {"near-field horizon", "horizon.h0 .. horizon.h15", "horizon.h0", [](const DeepBuffer& b) { return b.hasHorizon(); }};
    if (l == OptionalLayer::EnvRings)
        return {"specular lobe's rings", "env.ring0.u .. env.ring2.roughness", "env.ring0.u", [](const DeepBuffer& b) { return b.hasEnvRings(); }};
    if (l == OptionalLayer::EnvLobe)
        return {"specular lobe", "env.lobe.u, env.lobe.v, env.lobe.vis", "env.lobe.u", [](const DeepBuffer& b) { return b.hasEnvLobe(); }};
    // A five-band transfer is the three-band one's channels and bands 3-4's (format version 5).
    if (l == OptionalLayer::EnvTransferHigh)
        return {"five-band environment transfer", "env.sh9 .. env.sh24", "env.sh9",
                [](const DeepBuffer& b) { return b.hasEnvTransfer() && b.envBands == ENV_TRANSFER_BANDS; }};
    return {"environment transfer", "env.sh0 .. env.sh8", "env.sh0", [](const DeepBuffer& b) { return b.hasEnvTransfer(); }};
}

// The table's rows with env.sh0 .. env.sh24 added: bands 0-2 (EnvTransfer), then 3-4
// (EnvTransferHigh). Half: |T_i| <= max |Y_i| (the cosine lobe's (1/pi) integral is 1), 0.631 on
// bands 0-2 and 0.85 on 3-4, where half's steps (4.9e-4 at most) are far below the Monte Carlo
// error of a bake at MAX_ENV_RAYS.
std::vector<ChannelSpec> withEnvTransfer(std::vector<ChannelSpec> rows) {
    static_assert(ENV_TRANSFER_COEFFICIENTS == 25, "env.sh0 .. env.sh8 are three bands, env.sh9 .. env.sh24 bands 3 and 4");
    static const std::vector<std::string> names = [] {
        std::vector<std::string> n;
        for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i) n.push_back("env.sh" + std::to_string(i));
        return n;
    }(); // outlives the table, which holds pointers to its names
    for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i)
        rows.push_back({names[size_t(i)].c_str(), Imf::HALF, i, ENV_TRANSFER_COEFFICIENTS, false,
                        [](DeepBuffer& b) { return reinterpret_cast<char*>(b.envTransfer.data()); },
                        i < 9 ? OptionalLayer::EnvTransfer : OptionalLayer::EnvTransferHigh});
    return rows;
}

// The table's rows with horizon.h0 .. horizon.h15 added (format version 6). Half: sines in [0, 1],
// steps of 4.9e-4 at most, below the bake's own 1/256.
std::vector<ChannelSpec> withHorizon(std::vector<ChannelSpec> rows) {
    static_assert(HORIZON_AZIMUTHS == 16, "the layer is horizon.h0 .. horizon.h15");
    static const std::vector<std::string> names = [] {
        std::vector<std::string> n;
        for (int i = 0; i < HORIZON_AZIMUTHS; ++i) n.push_back("horizon.h" + std::to_string(i));
        return n;
    }(); // outlives the table, which holds pointers to its names
    for (int i = 0; i < HORIZON_AZIMUTHS; ++i)
        rows.push_back({names[size_t(i)].c_str(), Imf::HALF, i, HORIZON_AZIMUTHS, false,
                        [](DeepBuffer& b) { return reinterpret_cast<char*>(b.horizon.data()); }, OptionalLayer::Horizon});
    return rows;
}

// The rings' channel names in DeepBuffer::envRings' order: env.ringR.u, .v, .share, .roughness per
// ring R (format version 7). Static: the table holds pointers to them.
const std::vector<std::string>& ringChannelNames() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> n;
        for (int r = 0; r < ENV_LOBE_RINGS; ++r)
            for (const char* c : {"u", "v", "share", "roughness"}) n.push_back("env.ring" + std::to_string(r) + "." + c);
        return n;
    }();
    return names;
}

// The table's rows with the lobe's rings added (ringChannelNames). Half: as the lobe's, octahedral
// coordinates in [-1, 1], the share and the roughness in [0, 1].
std::vector<ChannelSpec> withEnvRings(std::vector<ChannelSpec> rows) {
    for (int i = 0; i < ENV_RING_COMPONENTS; ++i)
        rows.push_back({ringChannelNames()[size_t(i)].c_str(), Imf::HALF, i, ENV_RING_COMPONENTS, false,
                        [](DeepBuffer& b) { return reinterpret_cast<char*>(b.envRings.data()); }, OptionalLayer::EnvRings});
    return rows;
}

// The channel table of format v7 (docs/gbuffer-format.md). Positions and depth are float for
// precision over large scenes; directions, colours, lobe parameters and the environment transfer
// are half; ids are uint.
const std::vector<ChannelSpec>& channelSpecs() {
    using PT = Imf::PixelType;
    auto f = [](std::vector<float> DeepBuffer::*m) {
        return [m](DeepBuffer& b) { return reinterpret_cast<char*>((b.*m).data()); };
    };
    auto u = [](std::vector<uint32_t> DeepBuffer::*m) {
        return [m](DeepBuffer& b) { return reinterpret_cast<char*>((b.*m).data()); };
    };
    static const std::vector<ChannelSpec> specs = withEnvRings(withHorizon(withEnvTransfer({
        {"P.X", PT::FLOAT, 0, 3, true, f(&DeepBuffer::P)},
        {"P.Y", PT::FLOAT, 1, 3, true, f(&DeepBuffer::P)},
        {"P.Z", PT::FLOAT, 2, 3, true, f(&DeepBuffer::P)},
        {"N.X", PT::HALF, 0, 3, true, f(&DeepBuffer::N)},
        {"N.Y", PT::HALF, 1, 3, true, f(&DeepBuffer::N)},
        {"N.Z", PT::HALF, 2, 3, true, f(&DeepBuffer::N)},
        {"Ng.X", PT::HALF, 0, 3, false, f(&DeepBuffer::Ng)},
        {"Ng.Y", PT::HALF, 1, 3, false, f(&DeepBuffer::Ng)},
        {"Ng.Z", PT::HALF, 2, 3, false, f(&DeepBuffer::Ng)},
        {"T.X", PT::HALF, 0, 4, false, f(&DeepBuffer::T)},
        {"T.Y", PT::HALF, 1, 4, false, f(&DeepBuffer::T)},
        {"T.Z", PT::HALF, 2, 4, false, f(&DeepBuffer::T)},
        {"T.W", PT::HALF, 3, 4, false, f(&DeepBuffer::T)},
        {"Z", PT::FLOAT, 0, 1, true, f(&DeepBuffer::Z)},
        {"albedo.R", PT::HALF, 0, 3, true, f(&DeepBuffer::albedo)},
        {"albedo.G", PT::HALF, 1, 3, true, f(&DeepBuffer::albedo)},
        {"albedo.B", PT::HALF, 2, 3, true, f(&DeepBuffer::albedo)},
        {"brdf.metallic", PT::HALF, 0, 4, true, f(&DeepBuffer::brdf)},
        {"brdf.roughness", PT::HALF, 1, 4, true, f(&DeepBuffer::brdf)},
        {"brdf.specular", PT::HALF, 2, 4, false, f(&DeepBuffer::brdf)},
        {"brdf.occlusion", PT::HALF, 3, 4, false, f(&DeepBuffer::brdf)},
        {"sheen.R", PT::HALF, 0, 4, false, f(&DeepBuffer::sheen)},
        {"sheen.G", PT::HALF, 1, 4, false, f(&DeepBuffer::sheen)},
        {"sheen.B", PT::HALF, 2, 4, false, f(&DeepBuffer::sheen)},
        {"sheen.roughness", PT::HALF, 3, 4, false, f(&DeepBuffer::sheen)},
        {"coat.weight", PT::HALF, 0, 2, false, f(&DeepBuffer::coat)},
        {"coat.roughness", PT::HALF, 1, 2, false, f(&DeepBuffer::coat)},
        {"emission.R", PT::HALF, 0, 3, false, f(&DeepBuffer::emission)},
        {"emission.G", PT::HALF, 1, 3, false, f(&DeepBuffer::emission)},
        {"emission.B", PT::HALF, 2, 3, false, f(&DeepBuffer::emission)},
        {"A", PT::HALF, 0, 1, true, f(&DeepBuffer::A)},
        {"id.object", PT::UINT, 0, 1, true, u(&DeepBuffer::objectId)},
        {"id.material", PT::UINT, 0, 1, true, u(&DeepBuffer::materialId)},
        // Half: the octahedral coordinates in [-1, 1] (steps of 4.9e-4 at most: a direction to
        // within 0.05 degrees) and the visible share in [0, 1].
        {"env.lobe.u", PT::HALF, 0, ENV_LOBE_COMPONENTS, false, f(&DeepBuffer::envLobe), OptionalLayer::EnvLobe},
        {"env.lobe.v", PT::HALF, 1, ENV_LOBE_COMPONENTS, false, f(&DeepBuffer::envLobe), OptionalLayer::EnvLobe},
        {"env.lobe.vis", PT::HALF, 2, ENV_LOBE_COMPONENTS, false, f(&DeepBuffer::envLobe), OptionalLayer::EnvLobe},
    })));
    static_assert(ENV_LOBE_COMPONENTS == 3, "the table lists env.lobe.u, .v, .vis");
    return specs;
}

// Whether a buffer writes channel c: every channel, but an optional layer's only when it holds it.
bool writes(const ChannelSpec& c, const DeepBuffer& b) { return c.layer == OptionalLayer::None || layerInfo(c.layer).held(b); }

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

// Largest accepted image side. A shot is a single frame; 16k covers any plate while rejecting
// corrupt headers that would otherwise make us allocate terabytes.
constexpr long MAX_SIDE = 16384; // as the bake's limit (GL_MAX_TEXTURE_SIZE of GL 4.5)

void writeHeaderAttributes(Imf::Header& header, const DeepBuffer& b) {
    Imf::addWorldToCamera(header, toImath(b.camera.worldToCamera));
    Imf::addWorldToNDC(header, toImath(b.camera.worldToNDC));
    header.insert("dfb.formatVersion", Imf::IntAttribute(GBUFFER_FORMAT_VERSION));
    header.insert("dfb.samplesPerPixel", Imf::IntAttribute(b.samplesPerPixel));
    header.insert("dfb.camera.name", Imf::StringAttribute(b.camera.name));
    header.insert("dfb.camera.projection", Imf::StringAttribute(b.camera.orthographic ? "orthographic" : "perspective"));
    header.insert("dfb.camera.yfov", Imf::FloatAttribute(b.camera.yfovRadians));
    header.insert("dfb.camera.ymag", Imf::FloatAttribute(b.camera.ymag));
    header.insert("dfb.camera.aspect", Imf::FloatAttribute(b.camera.aspect));
    header.insert("dfb.camera.near", Imf::FloatAttribute(b.camera.znear));
    header.insert("dfb.camera.far", Imf::FloatAttribute(b.camera.zfar));
    header.insert("dfb.source", Imf::StringAttribute(b.sourcePath));
    header.insert("dfb.sourceSha256", Imf::StringAttribute(b.sourceSha256));
    nlohmann::json manifest = {{"objects", b.objectNames}, {"materials", b.materialNames}};
    header.insert("dfb.manifest", Imf::StringAttribute(manifest.dump()));
    if (b.hasEnvTransfer() && b.envRays > 0) header.insert("dfb.envRays", Imf::IntAttribute(b.envRays));
    if (b.hasHorizon()) header.insert("dfb.horizonRadius", Imf::FloatAttribute(b.horizonRadius));
    for (const ChannelSpec& c : channelSpecs())
        if (writes(c, b)) header.channels().insert(c.name, Imf::Channel(c.fileType));
}

// Samples of one channel in the file's type: half channels are staged (OpenEXR output needs
// slices of the channel's own type), float and uint point into the layer with a stride.
struct Staged {
    std::vector<half> halves;
    char* base = nullptr;
    size_t stride = 0; // bytes between consecutive samples
};

Staged stage(const ChannelSpec& c, DeepBuffer& b) {
    Staged s;
    const size_t n = b.sampleCount();
    const size_t elem = c.fileType == Imf::UINT ? sizeof(uint32_t) : sizeof(float);
    char* base = c.base(b) + elem * size_t(c.component);
    if (c.fileType == Imf::HALF) {
        const float* src = reinterpret_cast<const float*>(base);
        s.halves.resize(n);
        for (size_t i = 0; i < n; ++i) s.halves[i] = half(src[i * size_t(c.components)]);
        s.base = reinterpret_cast<char*>(s.halves.data());
        s.stride = sizeof(half);
    } else {
        s.base = base;
        s.stride = elem * size_t(c.components);
    }
    return s;
}

// The output stream of writeDeepBuffer: a file written with pwrite that keeps its first error.
// OpenEXR's output files write their line offset table in their destructors and swallow any
// exception there, and its own stream (std::ofstream) flushes its last buffer in its destructor
// unchecked: with them a disk that filled up at the end of the file went unnoticed and a short
// file was renamed into place. finish() reports that error, else makes the file durable.
class CheckedOutput final : public Imf::OStream {
public:
    explicit CheckedOutput(const std::string& path) : Imf::OStream(path.c_str()), mPath(path) {
        // O_EXCL: the name is this writer's alone (writeDeepBuffer), never another's file.
        mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (mFd < 0) fail("cannot create");
    }
    ~CheckedOutput() override {
        if (mFd >= 0) ::close(mFd);
    }
    CheckedOutput(const CheckedOutput&) = delete;
    CheckedOutput& operator=(const CheckedOutput&) = delete;

    void write(const char c[], int n) override {
        if (!mError.empty()) throw IEX_NAMESPACE::IoExc(mError); // nothing after a failure
        size_t done = 0;
        while (done < size_t(n)) {
            const ssize_t w = ::pwrite(mFd, c + done, size_t(n) - done, off_t(mPos + done));
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) {
                if (w == 0) errno = ENOSPC;
                fail("write");
            }
            done += size_t(w);
        }
        mPos += uint64_t(n);
    }
    uint64_t tellp() override { return mPos; }
    void seekp(uint64_t pos) override { mPos = pos; }

    /// After the OpenEXR file object is gone: the first error of any write, else fsync and close
    /// (a network filesystem may report a failed write only there).
    Status finish() {
        if (mError.empty() && ::fsync(mFd) != 0) record("fsync");
        if (::close(mFd) != 0 && mError.empty()) record("close");
        mFd = -1;
        if (!mError.empty()) return makeError(ErrorCode::IoError, mError);
        return okStatus();
    }

private:
    void record(const char* what) {
        if (mError.empty()) mError = mPath + ": " + what + ": " + std::strerror(errno);
    }
    [[noreturn]] void fail(const char* what) {
        record(what);
        throw IEX_NAMESPACE::IoExc(mError);
    }

    std::string mPath;
    std::string mError;
    int mFd = -1;
    uint64_t mPos = 0;
};

Status writeFlat(const DeepBuffer& b, Imf::OStream& out) {
    Imf::Header header(b.width, b.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    writeHeaderAttributes(header, b);
    DeepBuffer& mb = const_cast<DeepBuffer&>(b); // slices take char*; we only read from them
    std::vector<Staged> staged;
    staged.reserve(channelSpecs().size());
    Imf::FrameBuffer fb;
    for (const ChannelSpec& c : channelSpecs()) {
        if (!writes(c, b)) continue;
        staged.push_back(stage(c, mb));
        fb.insert(c.name, Imf::Slice(c.fileType, staged.back().base, staged.back().stride,
                                     staged.back().stride * size_t(b.width)));
    }
    Imf::OutputFile file(out, header);
    file.setFrameBuffer(fb);
    file.writePixels(b.height);
    return okStatus();
}

Status writeDeep(const DeepBuffer& b, Imf::OStream& out) {
    Imf::Header header(b.width, b.height);
    header.setType(Imf::DEEPSCANLINE);
    header.compression() = Imf::ZIPS_COMPRESSION;
    writeHeaderAttributes(header, b);
    DeepBuffer& mb = const_cast<DeepBuffer&>(b);
    const size_t np = b.pixelCount();
    std::vector<uint32_t> counts(np);
    for (size_t p = 0; p < np; ++p) counts[p] = b.sampleOffset[p + 1] - b.sampleOffset[p];
    Imf::DeepFrameBuffer fb;
    fb.insertSampleCountSlice(Imf::Slice(Imf::UINT, reinterpret_cast<char*>(counts.data()), sizeof(uint32_t),
                                         sizeof(uint32_t) * size_t(b.width)));
    std::vector<Staged> staged;
    std::vector<std::vector<char*>> pointers;
    staged.reserve(channelSpecs().size());
    pointers.reserve(channelSpecs().size());
    for (const ChannelSpec& c : channelSpecs()) {
        if (!writes(c, b)) continue;
        staged.push_back(stage(c, mb));
        auto& ptrs = pointers.emplace_back(np);
        for (size_t p = 0; p < np; ++p) ptrs[p] = staged.back().base + staged.back().stride * b.sampleOffset[p];
        // DeepSlice: base points at a per-pixel array of sample pointers (OpenEXR ImfDeepFrameBuffer.h).
        fb.insert(c.name, Imf::DeepSlice(c.fileType, reinterpret_cast<char*>(ptrs.data()), sizeof(char*),
                                         sizeof(char*) * size_t(b.width), staged.back().stride));
    }
    Imf::DeepScanLineOutputFile file(out, header);
    file.setFrameBuffer(fb);
    file.writePixels(b.height);
    return okStatus();
}

// OpenEXR 3.1 allocates whatever size a header attribute declares before reading it (a corrupt
// 1 KB file made it allocate 2 GB; found by scripts/fuzz). Walk the header's attribute list first
// and refuse sizes that exceed the file: name\0 type\0 int32 size, value; an empty name ends it.
bool headerAttributeSizesFit(const std::string& path, uint64_t fileSize) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    std::vector<char> head(size_t(std::min<uint64_t>(fileSize, 1u << 20)));
    const size_t n = std::fread(head.data(), 1, head.size(), f);
    std::fclose(f);
    size_t at = 8; // magic, version
    auto readName = [&](std::string& out) {
        out.clear();
        while (at < n && head[at] != '\0' && out.size() < 256) out.push_back(head[at++]);
        if (at >= n || head[at] != '\0') return false;
        ++at;
        return true;
    };
    std::string name, type;
    while (at < n) {
        if (!readName(name)) return false;
        if (name.empty()) return true; // end of the header
        if (!readName(type) || at + 4 > n) return false;
        int32_t size;
        std::memcpy(&size, &head[at], 4);
        at += 4;
        if (size < 0 || uint64_t(at) + uint64_t(size) > fileSize) return false;
        // OpenEXR reads these two by their content, not by the size before them: a content that
        // disagrees with the size moves its reader to another place than this scan, where a
        // garbage "size" of a later attribute became a 1.5 GB string (found by fuzzing), and a
        // preview's declared pixels are allocated as they are.
        if (type == "chlist") {
            // Channels: name, pixel type (4), pLinear + 3 reserved (4), xSampling, ySampling (8);
            // an empty name ends the list.
            size_t c = at;
            const size_t end = std::min(n, at + size_t(size));
            for (;;) {
                if (c >= end) return false;
                if (head[c] == '\0') { // the empty name that ends the list
                    ++c;
                    break;
                }
                while (c < end && head[c] != '\0') ++c;
                if (c >= end) return false;
                c += 1 + 16;
            }
            if (c != at + size_t(size)) return false;
        } else if (type == "preview") {
            if (size < 8 || at + 8 > n) return false;
            uint32_t w, h;
            std::memcpy(&w, &head[at], 4);
            std::memcpy(&h, &head[at + 4], 4);
            if (uint64_t(w) * uint64_t(h) * 4 + 8 != uint64_t(size)) return false;
        }
        at += size_t(size);
    }
    return false;
}

Error fileError(ErrorCode code, const std::string& path, const std::string& what) {
    return makeError(code, path + ": " + what);
}

// Reads the header attributes shared by flat and deep files.
Status readHeaderAttributes(const Imf::Header& h, const std::string& path, DeepBuffer& b) {
    if (const auto* a = h.findTypedAttribute<Imf::M44fAttribute>("worldToCamera")) {
        b.camera.worldToCamera = toGlm(a->value());
    } else {
        return fileError(ErrorCode::MissingData, path, "header attribute 'worldToCamera' is missing");
    }
    if (const auto* a = h.findTypedAttribute<Imf::M44fAttribute>("worldToNDC")) {
        b.camera.worldToNDC = toGlm(a->value());
    } else {
        return fileError(ErrorCode::MissingData, path, "header attribute 'worldToNDC' is missing");
    }
    if (const auto* a = h.findTypedAttribute<Imf::IntAttribute>("dfb.formatVersion")) {
        if (a->value() < 1 || a->value() > GBUFFER_FORMAT_VERSION) {
            return fileError(ErrorCode::InvalidFile, path, "format version " + std::to_string(a->value()) +
                                                               " is not supported (this build reads 1.." +
                                                               std::to_string(GBUFFER_FORMAT_VERSION) + ")");
        }
    }
    if (const auto* a = h.findTypedAttribute<Imf::IntAttribute>("dfb.samplesPerPixel")) {
        if (a->value() < 1 || a->value() > MAX_SAMPLES_PER_PIXEL) {
            return fileError(ErrorCode::InvalidValue, path, "dfb.samplesPerPixel " + std::to_string(a->value()) +
                                                                " is out of range [1, " +
                                                                std::to_string(MAX_SAMPLES_PER_PIXEL) + "]");
        }
        b.samplesPerPixel = a->value();
    }
    if (const auto* a = h.findTypedAttribute<Imf::IntAttribute>("dfb.envRays"); a && a->value() < 1) {
        return fileError(ErrorCode::InvalidValue, path, "dfb.envRays " + std::to_string(a->value()) + " is not positive");
    }
    if (const auto* a = h.findTypedAttribute<Imf::FloatAttribute>("dfb.horizonRadius"); a && !(a->value() > 0.f && std::isfinite(a->value()))) {
        return fileError(ErrorCode::InvalidValue, path, "dfb.horizonRadius " + std::to_string(a->value()) + " is not a positive distance");
    }
    auto getFloat = [&](const char* name, float& out) {
        if (const auto* a = h.findTypedAttribute<Imf::FloatAttribute>(name)) out = a->value();
    };
    getFloat("dfb.camera.yfov", b.camera.yfovRadians);
    getFloat("dfb.camera.ymag", b.camera.ymag);
    getFloat("dfb.camera.aspect", b.camera.aspect);
    getFloat("dfb.camera.near", b.camera.znear);
    getFloat("dfb.camera.far", b.camera.zfar);
    auto getString = [&](const char* name, std::string& out) {
        if (const auto* a = h.findTypedAttribute<Imf::StringAttribute>(name)) out = a->value();
    };
    std::string projection;
    getString("dfb.camera.projection", projection);
    b.camera.orthographic = projection == "orthographic";
    getString("dfb.camera.name", b.camera.name);
    getString("dfb.source", b.sourcePath);
    getString("dfb.sourceSha256", b.sourceSha256);
    if (const auto* a = h.findTypedAttribute<Imf::StringAttribute>("dfb.manifest")) {
        auto j = nlohmann::json::parse(a->value(), nullptr, false);
        if (j.is_discarded() || !j.is_object()) {
            return fileError(ErrorCode::InvalidFile, path, "header attribute 'dfb.manifest' is not valid JSON");
        }
        try {
            b.objectNames = j.value("objects", std::vector<std::string>{});
            b.materialNames = j.value("materials", std::vector<std::string>{});
        } catch (const nlohmann::json::exception&) {
            return fileError(ErrorCode::InvalidFile, path, "'dfb.manifest' lists are not string arrays");
        }
    }
    return okStatus();
}

// Checks every channel the table requires and the types of those present; collects the absent.
// An optional layer's channels come all or none: a file with some is refused naming the first
// absent one (half a transfer would be read as zeros, a wrong transfer rather than none).
Status checkChannels(const Imf::Header& h, const std::string& path, std::set<std::string>& missing) {
    std::set<OptionalLayer> anyOfLayer;
    for (const ChannelSpec& c : channelSpecs())
        if (c.layer != OptionalLayer::None && h.channels().findChannel(c.name)) anyOfLayer.insert(c.layer);
    for (const ChannelSpec& c : channelSpecs()) {
        const Imf::Channel* ch = h.channels().findChannel(c.name);
        if (!ch) {
            if (c.required) return fileError(ErrorCode::MissingData, path, std::string("required channel '") + c.name + "' is missing");
            if (anyOfLayer.count(c.layer)) {
                return fileError(ErrorCode::MissingData, path,
                                 std::string("channel '") + c.name + "' is missing (the " + layerInfo(c.layer).name +
                                     " needs all of " + layerInfo(c.layer).channels + ", or none)");
            }
            missing.insert(c.name);
            continue;
        }
        const bool wantUint = c.fileType == Imf::UINT;
        if (wantUint != (ch->type == Imf::UINT)) {
            return fileError(ErrorCode::InvalidFile, path, std::string("channel '") + c.name + "' has the wrong type (" +
                                                               (wantUint ? "uint expected" : "half or float expected") + ")");
        }
        if (ch->xSampling != 1 || ch->ySampling != 1) {
            return fileError(ErrorCode::InvalidFile, path, std::string("channel '") + c.name + "' is subsampled");
        }
    }
    // Bands 3 and 4 extend bands 0-2: alone they are no transfer.
    if (anyOfLayer.count(OptionalLayer::EnvTransferHigh) && !anyOfLayer.count(OptionalLayer::EnvTransfer)) {
        return fileError(ErrorCode::MissingData, path,
                         std::string("channel 'env.sh0' is missing (the ") + layerInfo(OptionalLayer::EnvTransferHigh).name +
                             " needs env.sh0 .. env.sh8 too)");
    }
    return okStatus();
}

Result<Imath::Box2i> checkWindow(const Imf::Header& h, const std::string& path) {
    const Imath::Box2i dw = h.dataWindow();
    const long w = long(dw.max.x) - dw.min.x + 1;
    const long hgt = long(dw.max.y) - dw.min.y + 1;
    if (w <= 0 || hgt <= 0 || w > MAX_SIDE || hgt > MAX_SIDE) {
        return fileError(ErrorCode::InvalidValue, path, "absurd image size " + std::to_string(w) + "x" + std::to_string(hgt));
    }
    if (dw != h.displayWindow()) return fileError(ErrorCode::InvalidFile, path, "data window differs from display window");
    return dw;
}

// What flat and deep reads check before allocating: window, channels, attributes, completeness
// (a truncated file is refused before its pixels are allocated: its line offsets are missing).
template <typename File>
Result<Imath::Box2i> readPrelude(File& file, const std::string& path, DeepBuffer& b, std::set<std::string>& missing) {
    const Imf::Header& h = file.header();
    auto dw = checkWindow(h, path);
    if (!dw) return dw.error();
    if (auto s = checkChannels(h, path, missing); !s) return s.error();
    if (auto s = readHeaderAttributes(h, path, b); !s) return s.error();
    if (!file.isComplete()) return fileError(ErrorCode::InvalidFile, path, "the file is truncated or incomplete");
    return dw;
}

// After allocateSamples, which leaves the optional layers empty: the environment transfer's layer
// and ray count, and the specular lobe's layer, when the file has their channels.
void allocateOptionalLayers(const Imf::Header& h, const std::set<std::string>& missing, DeepBuffer& b) {
    if (!missing.count(layerInfo(OptionalLayer::EnvLobe).firstChannel)) b.envLobe.assign(b.sampleCount() * ENV_LOBE_COMPONENTS, 0.f);
    if (!missing.count(layerInfo(OptionalLayer::EnvRings).firstChannel)) b.envRings.assign(b.sampleCount() * ENV_RING_COMPONENTS, 0.f);
    if (!missing.count(layerInfo(OptionalLayer::Horizon).firstChannel)) {
        b.horizon.assign(b.sampleCount() * HORIZON_AZIMUTHS, 0.f);
        if (const auto* a = h.findTypedAttribute<Imf::FloatAttribute>("dfb.horizonRadius")) b.horizonRadius = a->value();
    }
    if (missing.count(layerInfo(OptionalLayer::EnvTransfer).firstChannel)) return;
    b.envTransfer.assign(b.sampleCount() * ENV_TRANSFER_COEFFICIENTS, 0.f);
    b.envBands = missing.count(layerInfo(OptionalLayer::EnvTransferHigh).firstChannel) ? 3 : ENV_TRANSFER_BANDS;
    if (const auto* a = h.findTypedAttribute<Imf::IntAttribute>("dfb.envRays")) b.envRays = a->value();
}

Status readFlat(const std::string& path, DeepBuffer& b, std::set<std::string>& missing) {
    Imf::InputFile file(path.c_str());
    auto dw = readPrelude(file, path, b, missing);
    if (!dw) return dw.error();
    const long w = long(dw->max.x) - dw->min.x + 1, hgt = long(dw->max.y) - dw->min.y + 1;
    b.allocate(int(w), int(hgt));
    allocateOptionalLayers(file.header(), missing, b);
    Imf::FrameBuffer fb;
    for (const ChannelSpec& c : channelSpecs()) {
        if (missing.count(c.name)) continue;
        const bool isUint = c.fileType == Imf::UINT;
        const size_t elem = isUint ? sizeof(uint32_t) : sizeof(float);
        char* base = c.base(b) + elem * size_t(c.component);
        // Slices are addressed from the data window origin (OpenEXR's base-pointer rule); the
        // reader converts half to float.
        base -= (long(dw->min.y) * w + dw->min.x) * long(elem * size_t(c.components));
        fb.insert(c.name, Imf::Slice(isUint ? Imf::UINT : Imf::FLOAT, base, elem * size_t(c.components),
                                     elem * size_t(c.components) * size_t(w)));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw->min.y, dw->max.y);
    return okStatus();
}

Status readDeep(const std::string& path, DeepBuffer& b, std::set<std::string>& missing) {
    Imf::DeepScanLineInputFile file(path.c_str());
    auto dw = readPrelude(file, path, b, missing);
    if (!dw) return dw.error();
    const long w = long(dw->max.x) - dw->min.x + 1, hgt = long(dw->max.y) - dw->min.y + 1;
    const size_t np = size_t(w) * size_t(hgt);
    std::vector<uint32_t> counts(np);
    const long origin = long(dw->min.y) * w + dw->min.x;
    // OpenEXR's deep read: one frame buffer with the count slice and every channel's pointer
    // array, set once; read the counts, allocate, fill the pointers, then read the samples.
    struct Stage {
        const ChannelSpec* spec;
        std::vector<half> halves;
        std::vector<char*> ptrs;
    };
    std::vector<Stage> stages;
    stages.reserve(channelSpecs().size());
    Imf::DeepFrameBuffer fb;
    fb.insertSampleCountSlice(Imf::Slice(Imf::UINT, reinterpret_cast<char*>(counts.data() - origin), sizeof(uint32_t),
                                         sizeof(uint32_t) * size_t(w)));
    for (const ChannelSpec& c : channelSpecs()) {
        if (missing.count(c.name)) continue;
        Stage& st = stages.emplace_back();
        st.spec = &c;
        st.ptrs.resize(np);
        const size_t stride = c.fileType == Imf::HALF ? sizeof(half) : c.fileType == Imf::UINT ? sizeof(uint32_t) * size_t(c.components)
                                                                                               : sizeof(float) * size_t(c.components);
        fb.insert(c.name, Imf::DeepSlice(c.fileType, reinterpret_cast<char*>(st.ptrs.data() - origin), sizeof(char*),
                                         sizeof(char*) * size_t(w), stride));
    }
    file.setFrameBuffer(fb);
    file.readPixelSampleCounts(dw->min.y, dw->max.y);
    uint64_t total = 0;
    for (size_t p = 0; p < np; ++p) {
        if (counts[p] > uint32_t(MAX_SAMPLES_PER_PIXEL)) {
            return fileError(ErrorCode::InvalidValue, path, "pixel (" + std::to_string(p % size_t(w)) + ", " +
                                                                std::to_string(p / size_t(w)) + ") has " +
                                                                std::to_string(counts[p]) + " samples (at most " +
                                                                std::to_string(MAX_SAMPLES_PER_PIXEL) + " allowed)");
        }
        total += counts[p];
    }
    b.allocateSamples(int(w), int(hgt), counts);
    allocateOptionalLayers(file.header(), missing, b);
    for (Stage& st : stages) {
        const ChannelSpec& c = *st.spec;
        size_t stride;
        char* base;
        if (c.fileType == Imf::HALF) {
            st.halves.resize(size_t(total));
            base = reinterpret_cast<char*>(st.halves.data());
            stride = sizeof(half);
        } else {
            const size_t elem = c.fileType == Imf::UINT ? sizeof(uint32_t) : sizeof(float);
            base = c.base(b) + elem * size_t(c.component);
            stride = elem * size_t(c.components);
        }
        for (size_t p = 0; p < np; ++p) st.ptrs[p] = base + stride * b.sampleOffset[p];
    }
    file.readPixels(dw->min.y, dw->max.y);
    for (Stage& st : stages) {
        if (st.spec->fileType != Imf::HALF) continue;
        float* dst = reinterpret_cast<float*>(st.spec->base(b)) + st.spec->component;
        for (size_t i = 0; i < st.halves.size(); ++i) dst[i * size_t(st.spec->components)] = float(st.halves[i]);
    }
    return okStatus();
}

} // namespace

Status writeDeepBuffer(const DeepBuffer& b, const std::string& path) {
    if (b.width <= 0 || b.height <= 0 || b.sampleOffset.size() != b.pixelCount() + 1 ||
        b.P.size() != b.sampleCount() * 3 ||
        (b.hasEnvTransfer() && (b.envTransfer.size() != b.sampleCount() * ENV_TRANSFER_COEFFICIENTS || !validEnvBands(b.envBands))) ||
        (b.hasEnvLobe() && b.envLobe.size() != b.sampleCount() * ENV_LOBE_COMPONENTS) ||
        (b.hasEnvRings() && b.envRings.size() != b.sampleCount() * ENV_RING_COMPONENTS) ||
        (b.hasHorizon() && b.horizon.size() != b.sampleCount() * HORIZON_AZIMUTHS)) {
        return makeError(ErrorCode::InvalidValue, "refusing to write " + path + ": deep buffer is empty or inconsistent");
    }
    // The temporary name is this writer's alone: the process id is not enough where every writer
    // is PID 1 of its own container on one shared folder (two pods of the bake Job baking one
    // shot). It does not end in .exr, so dfb-server --sessions never takes it for a shot.
    char suffix[40];
    std::snprintf(suffix, sizeof suffix, ".tmp%ld-%08x", long(::getpid()), unsigned(std::random_device{}()));
    const std::string tmp = path + suffix;
    bool created = false;
    std::string failure;
    try {
        CheckedOutput out(tmp);
        created = true;
        Status s = b.isFlat() ? writeFlat(b, out) : writeDeep(b, out);
        if (s) s = out.finish();
        if (!s) failure = s.error().message;
    } catch (const std::exception& e) {
        failure = e.what();
    }
    if (!failure.empty()) {
        if (created) std::remove(tmp.c_str());
        return makeError(ErrorCode::IoError, "writing " + path + ": " + failure);
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::remove(tmp.c_str());
        return makeError(ErrorCode::IoError, "renaming " + tmp + " to " + path + ": " + ec.message());
    }
    // The rename durable too. A filesystem that cannot fsync a folder (EINVAL) has the file in
    // place all the same.
    const std::filesystem::path dir = std::filesystem::path(path).parent_path();
    const int dfd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    const int rc = dfd < 0 ? -1 : ::fsync(dfd);
    const int err = errno;
    if (dfd >= 0) ::close(dfd);
    if (rc != 0 && err != EINVAL && err != ENOTSUP) {
        return makeError(ErrorCode::IoError, "fsync of the folder of " + path + " after renaming the shot into place: " + std::strerror(err));
    }
    return okStatus();
}

Result<DeepBuffer> readDeepBuffer(const std::string& path) {
    struct stat st{};
    if (::stat(path.c_str(), &st) != 0) return makeError(ErrorCode::FileNotFound, path + ": no such file");
    DeepBuffer b;
    std::set<std::string> missing;
    try {
        bool tiled = false, deep = false, multiPart = false;
        if (!Imf::isOpenExrFile(path.c_str(), tiled, deep, multiPart)) {
            return makeError(ErrorCode::InvalidFile, path + ": not an OpenEXR file");
        }
        if (tiled) return makeError(ErrorCode::InvalidFile, path + ": tiled EXR files are not supported (write scanlines)");
        if (!headerAttributeSizesFit(path, uint64_t(st.st_size))) {
            return makeError(ErrorCode::InvalidFile, path + ": corrupt header (an attribute is larger than the file, or its "
                                                         "content disagrees with its size)");
        }
        {
            // Check the size in the header alone before OpenEXR reads the line-offset table that
            // a corrupt size would make it allocate.
            Imf::StdIFStream is(path.c_str());
            int magic = 0, version = 0;
            Imf::Xdr::read<Imf::StreamIO>(is, magic);
            Imf::Xdr::read<Imf::StreamIO>(is, version);
            Imf::Header header;
            header.readFrom(is, version);
            auto dw = checkWindow(header, path);
            if (!dw) return dw.error();
            // A file far smaller than its declared size is corrupt: our data compresses at most
            // about 1000:1 (zlib's limit is 1032:1), so demand one byte per 1024 pixels before
            // allocating memory for them.
            const uint64_t pixels = uint64_t(dw->max.x - dw->min.x + 1) * uint64_t(dw->max.y - dw->min.y + 1);
            if (uint64_t(st.st_size) < pixels / 1024) {
                return makeError(ErrorCode::InvalidFile, path + ": declares " + std::to_string(pixels) + " pixels but holds only " +
                                                             std::to_string(st.st_size) + " bytes (truncated or corrupt)");
            }
        }
        Status s = deep ? readDeep(path, b, missing) : readFlat(path, b, missing);
        if (!s) return s.error();
    } catch (const std::exception& e) {
        return makeError(ErrorCode::InvalidFile, path + ": " + e.what());
    }

    // Optional channels take their documented defaults (docs/gbuffer-format.md).
    for (size_t i = 0; i < b.sampleCount(); ++i) {
        if (missing.count("brdf.specular")) b.brdf[i * 4 + 2] = 0.5f;
        if (missing.count("brdf.occlusion")) b.brdf[i * 4 + 3] = 1.f;
        if (missing.count("Ng.X")) {
            for (int c = 0; c < 3; ++c) b.Ng[i * 3 + c] = b.N[i * 3 + c];
        }
        if (missing.count("T.X")) {
            const glm::vec3 n = b.normal(i);
            const glm::vec3 a = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
            const glm::vec3 t = glm::length(n) > 0.f ? glm::normalize(glm::cross(a, n)) : glm::vec3(1, 0, 0);
            b.T[i * 4] = t.x;
            b.T[i * 4 + 1] = t.y;
            b.T[i * 4 + 2] = t.z;
            b.T[i * 4 + 3] = 1.f;
        }
    }

    // Covered samples must have finite geometry: the relight loop would otherwise spread NaNs.
    for (int y = 0; y < b.height; ++y) {
        for (int x = 0; x < b.width; ++x) {
            float sum = 0.f;
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y); ++s) {
                const float a = b.A[s];
                const std::string where = " at pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")";
                if (!std::isfinite(a) || a < 0.f || a > 1.f + 1e-3f) {
                    return makeError(ErrorCode::InvalidValue, path + ": coverage A" + where + " is out of [0,1]");
                }
                sum += a;
                if (a <= 0.f) continue;
                for (int c = 0; c < 3; ++c) {
                    if (!std::isfinite(b.P[s * 3 + c]) || !std::isfinite(b.N[s * 3 + c])) {
                        return makeError(ErrorCode::InvalidValue, path + ": non-finite P or N" + where);
                    }
                }
            }
            // The transfer of every sample, covered or not: the writer stores finite values only
            // (zeros where A = 0), so anything else is a damaged or foreign file.
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y) && b.hasEnvTransfer(); ++s) {
                for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i) {
                    if (!std::isfinite(b.envTransfer[size_t(s) * ENV_TRANSFER_COEFFICIENTS + size_t(i)])) {
                        return makeError(ErrorCode::InvalidValue, path + ": non-finite environment transfer in channel 'env.sh" +
                                                                      std::to_string(i) + "' at pixel (" + std::to_string(x) +
                                                                      ", " + std::to_string(y) + ")");
                    }
                }
            }
            // The lobe: octahedral coordinates within [-1, 1], a share within [0, 1] (half's
            // rounding of values written in range stays in range).
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y) && b.hasEnvLobe(); ++s) {
                static const char* names[ENV_LOBE_COMPONENTS] = {"env.lobe.u", "env.lobe.v", "env.lobe.vis"};
                for (int i = 0; i < ENV_LOBE_COMPONENTS; ++i) {
                    const float v = b.envLobe[size_t(s) * ENV_LOBE_COMPONENTS + size_t(i)];
                    const float lo = i == 2 ? 0.f : -1.f;
                    if (!std::isfinite(v) || v < lo || v > 1.f) {
                        return makeError(ErrorCode::InvalidValue, path + ": channel '" + names[i] + "' at pixel (" + std::to_string(x) + ", " +
                                                                      std::to_string(y) + ") is " + std::to_string(v) + ", outside [" +
                                                                      (i == 2 ? "0" : "-1") + ", 1]");
                    }
                }
            }
            // The rings: octahedral coordinates within [-1, 1], shares and roughnesses within [0, 1].
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y) && b.hasEnvRings(); ++s) {
                for (int i = 0; i < ENV_RING_COMPONENTS; ++i) {
                    const float v = b.envRings[size_t(s) * ENV_RING_COMPONENTS + size_t(i)];
                    const bool direction = i % 4 < 2;
                    if (!std::isfinite(v) || v < (direction ? -1.f : 0.f) || v > 1.f) {
                        return makeError(ErrorCode::InvalidValue, path + ": channel '" + ringChannelNames()[size_t(i)] + "' at pixel (" +
                                                                      std::to_string(x) + ", " + std::to_string(y) + ") is " +
                                                                      std::to_string(v) + ", outside [" + (direction ? "-1" : "0") +
                                                                      ", 1]");
                    }
                }
            }
            // The horizon: sines within [0, 1].
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y) && b.hasHorizon(); ++s) {
                for (int i = 0; i < HORIZON_AZIMUTHS; ++i) {
                    const float v = b.horizon[size_t(s) * HORIZON_AZIMUTHS + size_t(i)];
                    if (!std::isfinite(v) || v < 0.f || v > 1.f) {
                        return makeError(ErrorCode::InvalidValue, path + ": channel 'horizon.h" + std::to_string(i) + "' at pixel (" +
                                                                      std::to_string(x) + ", " + std::to_string(y) + ") is " +
                                                                      std::to_string(v) + ", outside [0, 1]");
                    }
                }
            }
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y); ++s) {
                const bool haveManifest = !b.objectNames.empty() || !b.materialNames.empty();
                if (haveManifest && b.A[s] > 0.f &&
                    (b.objectId[s] > b.objectNames.size() || b.materialId[s] > b.materialNames.size())) {
                    return makeError(ErrorCode::InvalidValue, path + ": object id " + std::to_string(b.objectId[s]) +
                                                                  " / material id " + std::to_string(b.materialId[s]) +
                                                                  " at pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                                                  ") is not in the manifest");
                }
            }
            if (sum > 1.f + 1e-2f) {
                return makeError(ErrorCode::InvalidValue, path + ": coverages at pixel (" + std::to_string(x) + ", " +
                                                              std::to_string(y) + ") add up to more than 1");
            }
        }
    }
    return b;
}

} // namespace dfb
