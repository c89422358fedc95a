// Deep framebuffer EXR I/O: every channel survives a round trip, and broken files give clear
// errors instead of crashes.

#include <dfb/gbuffer/ExrIO.h>

#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfFloatAttribute.h>
#include <ImfIntAttribute.h>
#include <ImfMultiPartInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <sys/resource.h>
#include <unistd.h>

using namespace dfb;

namespace {

std::string tempPath(const std::string& name) {
    return (std::filesystem::temp_directory_path() / ("dfb_exr_io_" + std::to_string(::getpid()) + "_" + name)).string();
}

DeepBuffer randomBuffer(int w, int h, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u01(0.f, 1.f), pos(-100.f, 100.f);
    DeepBuffer b;
    b.allocate(w, h);
    for (size_t i = 0; i < b.pixelCount(); ++i) {
        const bool covered = u01(rng) > 0.2f;
        if (!covered) continue;
        b.A[i] = u01(rng) > 0.5f ? 1.f : 0.25f + 0.5f * u01(rng);
        for (int c = 0; c < 3; ++c) {
            b.P[i * 3 + c] = pos(rng);
            b.albedo[i * 3 + c] = u01(rng);
            b.emission[i * 3 + c] = 4.f * u01(rng);
        }
        glm::vec3 n = glm::normalize(glm::vec3(pos(rng), pos(rng), pos(rng)) + glm::vec3(1e-3f));
        glm::vec3 ng = glm::normalize(glm::vec3(pos(rng), pos(rng), pos(rng)) + glm::vec3(1e-3f));
        for (int c = 0; c < 3; ++c) {
            b.N[i * 3 + c] = n[c];
            b.Ng[i * 3 + c] = ng[c];
        }
        b.Z[i] = 1.f + 50.f * u01(rng);
        for (int c = 0; c < 4; ++c) {
            b.T[i * 4 + c] = u01(rng);
            b.sheen[i * 4 + c] = u01(rng);
        }
        b.coat[i * 2] = u01(rng);
        b.coat[i * 2 + 1] = u01(rng);
        for (int c = 0; c < 4; ++c) b.brdf[i * 4 + c] = u01(rng);
        b.objectId[i] = 1 + rng() % 7;
        b.materialId[i] = 1 + rng() % 5;
    }
    b.camera.name = "test_cam";
    b.camera.worldToCamera = glm::mat4(0.8f, 0.1f, 0.2f, 0.f, -0.1f, 0.9f, 0.3f, 0.f, 0.3f, -0.2f, 0.7f, 0.f, 1.f, 2.f, 3.f, 1.f);
    b.camera.worldToNDC = glm::mat4(2.f) * b.camera.worldToCamera;
    b.camera.yfovRadians = 0.7f;
    b.camera.aspect = float(w) / float(h);
    b.camera.znear = 0.05f;
    b.camera.zfar = 123.f;
    b.sourcePath = "/some/scene.glb";
    b.objectNames = {"a", "b", "c", "d", "e", "f", "g"};
    b.materialNames = {"m1", "m2", "m3", "m4", "m5"};
    return b;
}

// A random five-band environment transfer (each coefficient in bands 0-2's range, |T_i| <= 0.631)
// on the covered samples, zeros elsewhere, as the bake stores it.
void addRandomEnvTransfer(DeepBuffer& b, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-0.63f, 0.63f);
    b.envTransfer.assign(b.sampleCount() * ENV_TRANSFER_COEFFICIENTS, 0.f);
    for (size_t s = 0; s < b.sampleCount(); ++s)
        if (b.A[s] > 0.f)
            for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i) b.envTransfer[s * ENV_TRANSFER_COEFFICIENTS + size_t(i)] = u(rng);
    b.envRays = 64;
    b.envBands = ENV_TRANSFER_BANDS;
}

// randomBuffer's flat 16x9 buffer (seed `seed`), or with `deep` a deep 12x7 one of 0..3 samples
// per pixel (counts from seed - 1; coverage 0.2, normals up).
DeepBuffer flatOrDeepBuffer(bool deep, uint32_t seed) {
    DeepBuffer b = randomBuffer(16, 9, seed);
    if (!deep) return b;
    std::mt19937 rng(seed - 1);
    std::vector<uint32_t> counts(size_t(12 * 7));
    for (auto& c : counts) c = rng() % 4;
    b.allocateSamples(12, 7, counts);
    b.samplesPerPixel = 4;
    for (size_t s = 0; s < b.sampleCount(); ++s) {
        b.A[s] = 0.2f;
        b.N[s * 3 + 1] = 1.f;
    }
    return b;
}

// A random specular lobe (octahedral coordinates in [-1, 1], shares in [0, 1]) on the covered
// samples, zeros elsewhere, as the bake stores it.
void addRandomEnvLobe(DeepBuffer& b, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.f, 1.f), share(0.f, 1.f);
    b.envLobe.assign(b.sampleCount() * ENV_LOBE_COMPONENTS, 0.f);
    for (size_t s = 0; s < b.sampleCount(); ++s)
        if (b.A[s] > 0.f) {
            b.envLobe[s * 3] = u(rng);
            b.envLobe[s * 3 + 1] = u(rng);
            b.envLobe[s * 3 + 2] = share(rng);
        }
}

// Random rings of the specular lobe (octahedral coordinates in [-1, 1], shares and roughnesses in
// [0, 1]) on the covered samples, zeros elsewhere, as the bake stores them.
void addRandomEnvRings(DeepBuffer& b, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.f, 1.f), unit(0.f, 1.f);
    b.envRings.assign(b.sampleCount() * ENV_RING_COMPONENTS, 0.f);
    for (size_t s = 0; s < b.sampleCount(); ++s)
        if (b.A[s] > 0.f)
            for (int i = 0; i < ENV_RING_COMPONENTS; ++i) b.envRings[s * ENV_RING_COMPONENTS + size_t(i)] = i % 4 < 2 ? u(rng) : unit(rng);
}

// A random near-field horizon (sines in [0, 1]) on the covered samples, zeros elsewhere, as the
// bake stores it.
void addRandomHorizon(DeepBuffer& b, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    b.horizon.assign(b.sampleCount() * HORIZON_AZIMUTHS, 0.f);
    for (size_t s = 0; s < b.sampleCount(); ++s)
        if (b.A[s] > 0.f)
            for (int k = 0; k < HORIZON_AZIMUTHS; ++k) b.horizon[s * HORIZON_AZIMUTHS + size_t(k)] = u(rng);
    b.horizonRadius = 0.0625f;
}

std::string readBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// A flat 4x4 file with every required channel and the half channels `extra` (zero-filled pixels).
void writeFileWithChannels(const std::string& path, const std::vector<std::string>& extra) {
    Imf::Header h(4, 4);
    Imf::addWorldToCamera(h, Imath::M44f());
    Imf::addWorldToNDC(h, Imath::M44f());
    for (const char* c : {"P.X", "P.Y", "P.Z", "Z"}) h.channels().insert(c, Imf::Channel(Imf::FLOAT));
    for (const char* c : {"N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "brdf.metallic", "brdf.roughness", "A"})
        h.channels().insert(c, Imf::Channel(Imf::HALF));
    for (const std::string& c : extra) h.channels().insert(c, Imf::Channel(Imf::HALF));
    for (const char* c : {"id.object", "id.material"}) h.channels().insert(c, Imf::Channel(Imf::UINT));
    Imf::OutputFile f(path.c_str(), h); // unwritten lines are zero-filled on close
}

// The same with env.sh{from} .. env.sh{to}.
void writeFileWithEnvChannels(const std::string& path, int from, int to) {
    std::vector<std::string> extra;
    for (int i = from; i <= to; ++i) extra.push_back("env.sh" + std::to_string(i));
    writeFileWithChannels(path, extra);
}

// Writes `b` (which the writer accepts) and expects the reader to refuse it with InvalidValue,
// naming `channel` and the pixel of flat sample i of a 16-wide buffer.
void expectRefusedNaming(const DeepBuffer& b, const std::string& channel, size_t i) {
    const std::string path = tempPath("refused.exr");
    ASSERT_TRUE(writeDeepBuffer(b, path).ok());
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok()) << channel;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidValue);
    EXPECT_NE(r.error().message.find("'" + channel + "'"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("(" + std::to_string(i % 16) + ", " + std::to_string(i / 16) + ")"), std::string::npos)
        << r.error().message;
    std::filesystem::remove(path);
}

// Rewrites an EXR's int attribute `dfb.formatVersion` in place (its 4 value bytes follow the name,
// the type and the size), as tests/fixtures/make_fixtures.cpp makes future_version.exr.
void patchFormatVersion(const std::string& path, int32_t version) {
    std::string bytes = readBytes(path);
    const std::string key = std::string("dfb.formatVersion") + '\0' + "int" + '\0';
    const size_t at = bytes.find(key);
    ASSERT_NE(at, std::string::npos);
    std::memcpy(&bytes[at + key.size() + 4], &version, 4);
    std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// Half precision: 11 significant bits.
void expectHalfNear(const std::vector<float>& a, const std::vector<float>& b, const char* what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    for (size_t i = 0; i < a.size(); ++i) {
        ASSERT_NEAR(a[i], b[i], std::max(1e-3f, std::abs(a[i]) * 1e-3f)) << what << " element " << i;
    }
}

} // namespace

TEST(ExrIO, RoundTripsEveryChannelAndAttribute) {
    const DeepBuffer in = randomBuffer(37, 23, 7);
    const std::string path = tempPath("roundtrip.exr");
    ASSERT_TRUE(writeDeepBuffer(in, path).ok());
    auto r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    const DeepBuffer& out = r.value();
    EXPECT_EQ(out.width, in.width);
    EXPECT_EQ(out.height, in.height);
    EXPECT_EQ(out.P, in.P); // float: exact
    EXPECT_EQ(out.Z, in.Z);
    EXPECT_EQ(out.objectId, in.objectId); // uint: exact
    EXPECT_EQ(out.materialId, in.materialId);
    expectHalfNear(out.N, in.N, "N");
    expectHalfNear(out.Ng, in.Ng, "Ng");
    expectHalfNear(out.albedo, in.albedo, "albedo");
    expectHalfNear(out.brdf, in.brdf, "brdf");
    expectHalfNear(out.emission, in.emission, "emission");
    expectHalfNear(out.A, in.A, "A");
    expectHalfNear(out.T, in.T, "T");
    expectHalfNear(out.sheen, in.sheen, "sheen");
    expectHalfNear(out.coat, in.coat, "coat");
    EXPECT_TRUE(out.isFlat());
    EXPECT_EQ(out.camera.worldToCamera, in.camera.worldToCamera);
    EXPECT_EQ(out.camera.worldToNDC, in.camera.worldToNDC);
    EXPECT_EQ(out.camera.name, in.camera.name);
    EXPECT_FLOAT_EQ(out.camera.yfovRadians, in.camera.yfovRadians);
    EXPECT_FLOAT_EQ(out.camera.znear, in.camera.znear);
    EXPECT_FLOAT_EQ(out.camera.zfar, in.camera.zfar);
    EXPECT_EQ(out.sourcePath, in.sourcePath);
    EXPECT_EQ(out.objectNames, in.objectNames);
    EXPECT_EQ(out.materialNames, in.materialNames);
    std::filesystem::remove(path);
}

TEST(ExrIO, DeepRoundTripKeepsEverySampleOfEveryChannel) {
    // Random sample counts 0..5 per pixel (deep scanline), every channel random.
    std::mt19937 rng(99);
    std::uniform_real_distribution<float> u01(0.f, 1.f);
    const int w = 19, h = 13;
    std::vector<uint32_t> counts(size_t(w * h));
    for (auto& c : counts) c = rng() % 6;
    DeepBuffer in;
    in.allocateSamples(w, h, counts);
    in.samplesPerPixel = 16;
    for (size_t s = 0; s < in.sampleCount(); ++s) {
        in.A[s] = 0.05f + 0.1f * u01(rng); // at most 5 x 0.15 < 1 per pixel
        for (int c = 0; c < 3; ++c) {
            in.P[s * 3 + c] = 200.f * u01(rng) - 100.f;
            in.N[s * 3 + c] = u01(rng);
            in.Ng[s * 3 + c] = u01(rng);
            in.albedo[s * 3 + c] = u01(rng);
            in.emission[s * 3 + c] = u01(rng);
        }
        for (int c = 0; c < 4; ++c) {
            in.T[s * 4 + c] = u01(rng);
            in.brdf[s * 4 + c] = u01(rng);
            in.sheen[s * 4 + c] = u01(rng);
        }
        in.coat[s * 2] = u01(rng);
        in.coat[s * 2 + 1] = u01(rng);
        in.Z[s] = 100.f * u01(rng);
        in.objectId[s] = 1 + rng() % 3;
        in.materialId[s] = 1 + rng() % 2;
    }
    in.objectNames = {"a", "b", "c"};
    in.materialNames = {"m", "n"};
    in.sourceSha256 = std::string(64, 'a');
    const std::string path = tempPath("deep.exr");
    ASSERT_TRUE(writeDeepBuffer(in, path).ok());
    auto r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    const DeepBuffer& out = r.value();
    EXPECT_FALSE(out.isFlat());
    EXPECT_EQ(out.samplesPerPixel, 16);
    EXPECT_EQ(out.sampleOffset, in.sampleOffset);
    EXPECT_EQ(out.P, in.P);
    EXPECT_EQ(out.Z, in.Z);
    EXPECT_EQ(out.objectId, in.objectId);
    EXPECT_EQ(out.materialId, in.materialId);
    expectHalfNear(out.N, in.N, "N");
    expectHalfNear(out.Ng, in.Ng, "Ng");
    expectHalfNear(out.T, in.T, "T");
    expectHalfNear(out.albedo, in.albedo, "albedo");
    expectHalfNear(out.brdf, in.brdf, "brdf");
    expectHalfNear(out.sheen, in.sheen, "sheen");
    expectHalfNear(out.coat, in.coat, "coat");
    expectHalfNear(out.emission, in.emission, "emission");
    expectHalfNear(out.A, in.A, "A");
    EXPECT_EQ(out.sourceSha256, in.sourceSha256);
    std::filesystem::remove(path);
}

TEST(ExrIO, MissingFileIsFileNotFound) {
    auto r = readDeepBuffer("/nonexistent/dir/shot.exr");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::FileNotFound);
    EXPECT_NE(r.error().message.find("/nonexistent/dir/shot.exr"), std::string::npos);
}

TEST(ExrIO, NonExrFileIsInvalidFile) {
    const std::string path = tempPath("not.exr");
    std::ofstream(path) << "this is not an image";
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::InvalidFile);
    std::filesystem::remove(path);
}

TEST(ExrIO, TruncatedFileIsInvalidFile) {
    const std::string path = tempPath("truncated.exr");
    ASSERT_TRUE(writeDeepBuffer(randomBuffer(64, 64, 3), path).ok());
    std::filesystem::resize_file(path, std::filesystem::file_size(path) / 2);
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::InvalidFile) << r.error().toString();
    std::filesystem::remove(path);
}

TEST(ExrIO, MissingRequiredChannelIsNamed) {
    // A plain RGBA EXR: a valid image, but not a deep framebuffer.
    const std::string path = tempPath("rgba.exr");
    Imf::Header h(8, 8);
    for (const char* c : {"R", "G", "B", "A"}) h.channels().insert(c, Imf::Channel(Imf::HALF));
    {
        Imf::OutputFile f(path.c_str(), h);
    } // OpenEXR fills unwritten lines with zeros on close
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::MissingData);
    EXPECT_NE(r.error().message.find("P.X"), std::string::npos) << r.error().message;
    std::filesystem::remove(path);
}

TEST(ExrIO, NanPositionOnCoveredPixelIsRejected) {
    DeepBuffer b = randomBuffer(16, 16, 11);
    size_t i = 0;
    while (b.A[i] <= 0.f) ++i;
    b.P[i * 3 + 1] = std::nanf("");
    const std::string path = tempPath("nan.exr");
    ASSERT_TRUE(writeDeepBuffer(b, path).ok());
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::InvalidValue);
    EXPECT_NE(r.error().message.find("non-finite"), std::string::npos) << r.error().message;
    std::filesystem::remove(path);
}

TEST(ExrIO, FailedWriteLeavesExistingFileIntact) {
    const std::string path = tempPath("keep.exr");
    ASSERT_TRUE(writeDeepBuffer(randomBuffer(8, 8, 1), path).ok());
    const auto sizeBefore = std::filesystem::file_size(path);
    DeepBuffer empty;
    EXPECT_FALSE(writeDeepBuffer(empty, path).ok());
    EXPECT_EQ(std::filesystem::file_size(path), sizeBefore);
    EXPECT_TRUE(readDeepBuffer(path).ok());
    std::filesystem::remove(path);
}

// Format v3's optional layer: env.sh0 .. env.sh8 (docs/gbuffer-format.md, "Environment transfer").

TEST(ExrIO, EnvTransferRoundTripsFlatAndDeep) {
    DeepBuffer flat = randomBuffer(37, 23, 5);
    addRandomEnvTransfer(flat, 6);
    std::mt19937 rng(8);
    std::vector<uint32_t> counts(size_t(19 * 13));
    for (auto& c : counts) c = rng() % 4;
    DeepBuffer deep;
    deep.allocateSamples(19, 13, counts);
    deep.samplesPerPixel = 4;
    for (size_t s = 0; s < deep.sampleCount(); ++s) {
        deep.A[s] = 0.2f;
        deep.N[s * 3 + 1] = 1.f;
    }
    addRandomEnvTransfer(deep, 9);
    deep.envRays = 4096;
    for (const DeepBuffer* in : {&flat, &deep}) {
        const std::string path = tempPath("env_roundtrip.exr");
        ASSERT_TRUE(writeDeepBuffer(*in, path).ok());
        {
            Imf::InputFile f(path.c_str());
            for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i) {
                const std::string name = "env.sh" + std::to_string(i);
                const Imf::Channel* ch = f.header().channels().findChannel(name);
                ASSERT_NE(ch, nullptr) << name;
                EXPECT_EQ(ch->type, Imf::HALF) << name;
            }
            const auto* version = f.header().findTypedAttribute<Imf::IntAttribute>("dfb.formatVersion");
            ASSERT_NE(version, nullptr);
            EXPECT_EQ(version->value(), GBUFFER_FORMAT_VERSION);
            const auto* rays = f.header().findTypedAttribute<Imf::IntAttribute>("dfb.envRays");
            ASSERT_NE(rays, nullptr);
            EXPECT_EQ(rays->value(), in->envRays);
        }
        auto r = readDeepBuffer(path);
        ASSERT_TRUE(r.ok()) << r.error().toString();
        ASSERT_TRUE(r->hasEnvTransfer());
        EXPECT_EQ(r->envRays, in->envRays);
        EXPECT_EQ(r->isFlat(), in->isFlat());
        // Same values to half precision: each within half a step of 11 significant bits.
        ASSERT_EQ(r->envTransfer.size(), in->envTransfer.size());
        for (size_t k = 0; k < in->envTransfer.size(); ++k)
            ASSERT_NEAR(r->envTransfer[k], in->envTransfer[k], std::max(std::abs(in->envTransfer[k]) * 4.9e-4f, 3e-8f))
                << "element " << k << (in->isFlat() ? " (flat)" : " (deep)");
        expectHalfNear(r->N, in->N, "N"); // the other layers are unaffected
        std::filesystem::remove(path);
    }
}

TEST(ExrIO, WithoutEnvTransferTheFileHasNoEnvChannels) {
    const DeepBuffer in = randomBuffer(16, 9, 4);
    ASSERT_FALSE(in.hasEnvTransfer());
    const std::string path = tempPath("no_env.exr");
    ASSERT_TRUE(writeDeepBuffer(in, path).ok());
    {
        Imf::InputFile f(path.c_str());
        for (auto it = f.header().channels().begin(); it != f.header().channels().end(); ++it)
            EXPECT_NE(std::string(it.name()).rfind("env.", 0), 0u) << it.name();
        EXPECT_EQ(f.header().findTypedAttribute<Imf::IntAttribute>("dfb.envRays"), nullptr);
    }
    auto r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    EXPECT_FALSE(r->hasEnvTransfer());
    EXPECT_EQ(r->envRays, 0);
    std::filesystem::remove(path);
}

TEST(ExrIO, Version2FileWithoutEnvChannelsLoads) {
    // Version 2's channels and attributes are version 3's without env.sh* and dfb.envRays: the
    // writer's file without the layer, its version set to 2, is a version 2 file.
    const DeepBuffer in = randomBuffer(20, 10, 12);
    const std::string path = tempPath("v2.exr");
    ASSERT_TRUE(writeDeepBuffer(in, path).ok());
    patchFormatVersion(path, 2);
    {
        Imf::InputFile f(path.c_str());
        EXPECT_EQ(f.header().findTypedAttribute<Imf::IntAttribute>("dfb.formatVersion")->value(), 2);
    }
    auto r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    EXPECT_TRUE(r->envTransfer.empty());
    EXPECT_EQ(r->envRays, 0);
    EXPECT_EQ(r->P, in.P);
    std::filesystem::remove(path);
}

TEST(ExrIO, SomeButNotAllEnvChannelsAreRefusedNamingTheFirstMissing) {
    // Part of bands 0-2; part of bands 3-4 (format v5); bands 3-4 without 0-2.
    struct Case {
        int from, to;
        const char* missing;
    };
    for (const Case& c : {Case{0, 4, "'env.sh5' is missing"}, Case{0, 12, "'env.sh13' is missing"}, Case{9, 24, "'env.sh0' is missing"}}) {
        const std::string path = tempPath("env_partial.exr");
        writeFileWithEnvChannels(path, c.from, c.to);
        auto r = readDeepBuffer(path);
        ASSERT_FALSE(r.ok()) << c.missing;
        EXPECT_EQ(r.error().code, ErrorCode::MissingData);
        EXPECT_NE(r.error().message.find(c.missing), std::string::npos) << r.error().message;
        EXPECT_NE(r.error().message.find(path), std::string::npos) << r.error().message;
        std::filesystem::remove(path);
    }
}

// Format v5's five-band transfer: env.sh9 .. env.sh24 beside v3's env.sh0 .. env.sh8, a band count
// read from the channels present (docs/gbuffer-format.md, "Environment transfer").

TEST(ExrIO, ThreeBandTransferWritesNineChannelsAndAVersion4FileReadsAsThreeBands) {
    DeepBuffer b = randomBuffer(16, 9, 31);
    addRandomEnvTransfer(b, 32);
    b.envBands = 3;
    for (size_t s = 0; s < b.sampleCount(); ++s)
        for (int i = 9; i < ENV_TRANSFER_COEFFICIENTS; ++i) b.envTransfer[s * ENV_TRANSFER_COEFFICIENTS + size_t(i)] = 0.f;
    const std::string path = tempPath("env_three_bands.exr");
    ASSERT_TRUE(writeDeepBuffer(b, path).ok());
    {
        Imf::InputFile f(path.c_str());
        EXPECT_NE(f.header().channels().findChannel("env.sh8"), nullptr);
        EXPECT_EQ(f.header().channels().findChannel("env.sh9"), nullptr);
    }
    // A version 4 shot is this file with its version set to 4.
    patchFormatVersion(path, 4);
    auto r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    ASSERT_TRUE(r->hasEnvTransfer());
    EXPECT_EQ(r->envBands, 3);
    ASSERT_EQ(r->envTransfer.size(), b.envTransfer.size());
    for (size_t k = 0; k < b.envTransfer.size(); ++k)
        ASSERT_NEAR(r->envTransfer[k], b.envTransfer[k], std::max(std::abs(b.envTransfer[k]) * 4.9e-4f, 3e-8f)) << "element " << k;
    // Five bands: all 25 channels, read back as five bands with bands 3-4 kept.
    addRandomEnvTransfer(b, 33);
    b.envBands = 5;
    ASSERT_TRUE(writeDeepBuffer(b, path).ok());
    r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    EXPECT_EQ(r->envBands, 5);
    size_t nonZeroHigh = 0;
    for (size_t s = 0; s < b.sampleCount(); ++s) nonZeroHigh += r->envTransfer[s * ENV_TRANSFER_COEFFICIENTS + 24] != 0.f;
    EXPECT_GT(nonZeroHigh, 0u);
    // A band count the format does not have is refused, and the file is left as it was.
    b.envBands = 4;
    const auto before = std::filesystem::file_size(path);
    auto w = writeDeepBuffer(b, path);
    EXPECT_FALSE(w.ok());
    EXPECT_EQ(std::filesystem::file_size(path), before);
    EXPECT_TRUE(readDeepBuffer(path).ok());
    std::filesystem::remove(path);
}

TEST(ExrIO, NonFiniteEnvTransferIsRefusedNamingTheChannel) {
    for (const bool covered : {true, false}) {
        DeepBuffer b = randomBuffer(16, 16, 13);
        addRandomEnvTransfer(b, 14);
        size_t i = 0;
        while ((b.A[i] > 0.f) != covered) ++i;
        b.envTransfer[i * ENV_TRANSFER_COEFFICIENTS + 3] = covered ? std::nanf("") : INFINITY;
        const std::string path = tempPath("env_nan.exr");
        ASSERT_TRUE(writeDeepBuffer(b, path).ok());
        auto r = readDeepBuffer(path);
        ASSERT_FALSE(r.ok()) << (covered ? "NaN on a covered sample" : "infinity on an uncovered sample");
        EXPECT_EQ(r.error().code, ErrorCode::InvalidValue);
        EXPECT_NE(r.error().message.find("'env.sh3'"), std::string::npos) << r.error().message;
        const std::string pixel = "(" + std::to_string(i % 16) + ", " + std::to_string(i / 16) + ")";
        EXPECT_NE(r.error().message.find(pixel), std::string::npos) << r.error().message;
        std::filesystem::remove(path);
    }
}

TEST(ExrIO, EnvLobeRoundTripsAndAVersion3FileLoadsWithoutIt) {
    DeepBuffer b = randomBuffer(16, 9, 21);
    addRandomEnvTransfer(b, 22);
    addRandomEnvLobe(b, 23);
    b.envLobe[0] = -1.f; // the range's ends survive half precision
    b.envLobe[1] = 1.f;
    const std::string path = tempPath("env_lobe.exr");
    ASSERT_TRUE(writeDeepBuffer(b, path).ok());
    {
        Imf::InputFile f(path.c_str());
        for (const char* c : {"env.lobe.u", "env.lobe.v", "env.lobe.vis"}) {
            const Imf::Channel* ch = f.header().channels().findChannel(c);
            ASSERT_NE(ch, nullptr) << c;
            EXPECT_EQ(ch->type, Imf::HALF) << c;
        }
    }
    auto r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    ASSERT_TRUE(r->hasEnvLobe());
    ASSERT_EQ(r->envLobe.size(), b.envLobe.size());
    for (size_t k = 0; k < b.envLobe.size(); ++k)
        ASSERT_NEAR(r->envLobe[k], b.envLobe[k], std::max(std::abs(b.envLobe[k]) * 4.9e-4f, 3e-8f)) << "element " << k;
    // Without the lobe (a version 3 shot): no env.lobe channels, and it reads back without one.
    b.envLobe.clear();
    ASSERT_TRUE(writeDeepBuffer(b, path).ok());
    {
        Imf::InputFile f(path.c_str());
        EXPECT_EQ(f.header().channels().findChannel("env.lobe.u"), nullptr);
    }
    r = readDeepBuffer(path);
    ASSERT_TRUE(r.ok()) << r.error().toString();
    EXPECT_TRUE(r->hasEnvTransfer());
    EXPECT_FALSE(r->hasEnvLobe());
    std::filesystem::remove(path);
}

TEST(ExrIO, EnvLobeOutOfRangeOrPartialIsRefusedNamingTheChannel) {
    struct Case {
        int component;
        float value;
        const char* channel;
    };
    for (const Case& c : {Case{0, std::nanf(""), "env.lobe.u"}, Case{1, -1.5f, "env.lobe.v"}, Case{2, 1.25f, "env.lobe.vis"},
                          Case{2, -0.5f, "env.lobe.vis"}}) {
        DeepBuffer b = randomBuffer(16, 16, 24);
        addRandomEnvTransfer(b, 25);
        addRandomEnvLobe(b, 26);
        const size_t i = 37;
        b.envLobe[i * ENV_LOBE_COMPONENTS + size_t(c.component)] = c.value;
        SCOPED_TRACE(c.value);
        expectRefusedNaming(b, c.channel, i);
    }
    // Some but not all of the lobe's channels: refused naming the first absent one.
    const std::string path = tempPath("env_lobe_partial.exr");
    writeFileWithChannels(path, {"env.lobe.u", "env.lobe.vis"});
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::MissingData);
    EXPECT_NE(r.error().message.find("'env.lobe.v' is missing"), std::string::npos) << r.error().message;
    std::filesystem::remove(path);
}

TEST(ExrIO, HorizonRoundTripsFlatAndDeepAndAVersion5FileLoadsWithoutIt) {
    for (bool deep : {false, true}) {
        SCOPED_TRACE(deep ? "deep" : "flat");
        DeepBuffer b = flatOrDeepBuffer(deep, 31);
        addRandomHorizon(b, 32);
        b.horizon[0] = 1.f; // the range's ends survive half precision
        b.horizon[1] = 0.f;
        const std::string path = tempPath("horizon.exr");
        ASSERT_TRUE(writeDeepBuffer(b, path).ok());
        {
            Imf::MultiPartInputFile f(path.c_str());
            for (int k = 0; k < HORIZON_AZIMUTHS; ++k) {
                const Imf::Channel* ch = f.header(0).channels().findChannel("horizon.h" + std::to_string(k));
                ASSERT_NE(ch, nullptr) << k;
                EXPECT_EQ(ch->type, Imf::HALF) << k;
            }
            EXPECT_EQ(f.header(0).channels().findChannel("horizon.h16"), nullptr);
        }
        auto r = readDeepBuffer(path);
        ASSERT_TRUE(r.ok()) << r.error().toString();
        ASSERT_TRUE(r->hasHorizon());
        EXPECT_EQ(r->horizonRadius, 0.0625f);
        ASSERT_EQ(r->horizon.size(), b.horizon.size());
        for (size_t k = 0; k < b.horizon.size(); ++k) ASSERT_NEAR(r->horizon[k], b.horizon[k], 4.9e-4f) << "element " << k;
        // Without the horizon (a version 5 shot): no horizon channels, and it reads back without one.
        b.horizon.clear();
        b.horizonRadius = 0.f;
        ASSERT_TRUE(writeDeepBuffer(b, path).ok());
        {
            Imf::MultiPartInputFile f(path.c_str());
            EXPECT_EQ(f.header(0).channels().findChannel("horizon.h0"), nullptr);
            EXPECT_EQ(f.header(0).findTypedAttribute<Imf::FloatAttribute>("dfb.horizonRadius"), nullptr);
        }
        patchFormatVersion(path, 5);
        r = readDeepBuffer(path);
        ASSERT_TRUE(r.ok()) << r.error().toString();
        EXPECT_FALSE(r->hasHorizon());
        EXPECT_EQ(r->horizonRadius, 0.f);
        std::filesystem::remove(path);
    }
}

TEST(ExrIO, HorizonOutOfRangeOrPartialIsRefusedNamingTheChannel) {
    struct Case {
        int azimuth;
        float value;
    };
    for (const Case& c : {Case{0, std::nanf("")}, Case{7, -0.25f}, Case{15, 1.5f}}) {
        DeepBuffer b = randomBuffer(16, 16, 33);
        addRandomHorizon(b, 34);
        const size_t i = 37;
        b.horizon[i * HORIZON_AZIMUTHS + size_t(c.azimuth)] = c.value;
        SCOPED_TRACE(c.value);
        expectRefusedNaming(b, "horizon.h" + std::to_string(c.azimuth), i);
    }
    // A reach that is no distance.
    {
        DeepBuffer b = randomBuffer(8, 8, 35);
        addRandomHorizon(b, 36);
        b.horizonRadius = -1.f;
        const std::string path = tempPath("horizon_reach.exr");
        ASSERT_TRUE(writeDeepBuffer(b, path).ok());
        auto r = readDeepBuffer(path);
        ASSERT_FALSE(r.ok());
        EXPECT_EQ(r.error().code, ErrorCode::InvalidValue);
        EXPECT_NE(r.error().message.find("dfb.horizonRadius"), std::string::npos) << r.error().message;
        std::filesystem::remove(path);
    }
    // Some but not all of the horizon's channels: refused naming the first absent one.
    const std::string path = tempPath("horizon_partial.exr");
    std::vector<std::string> partial;
    for (int k = 0; k < HORIZON_AZIMUTHS; ++k)
        if (k != 9) partial.push_back("horizon.h" + std::to_string(k));
    writeFileWithChannels(path, partial);
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::MissingData);
    EXPECT_NE(r.error().message.find("'horizon.h9' is missing"), std::string::npos) << r.error().message;
    std::filesystem::remove(path);
}

TEST(ExrIO, EnvRingsRoundTripFlatAndDeepAndAVersion6FileLoadsWithoutThem) {
    for (bool deep : {false, true}) {
        SCOPED_TRACE(deep ? "deep" : "flat");
        DeepBuffer b = flatOrDeepBuffer(deep, 41);
        addRandomEnvTransfer(b, 43);
        addRandomEnvLobe(b, 44);
        addRandomEnvRings(b, 45);
        b.envRings[0] = -1.f; // the range's ends survive half precision
        b.envRings[3] = 1.f;
        const std::string path = tempPath("rings.exr");
        ASSERT_TRUE(writeDeepBuffer(b, path).ok());
        {
            Imf::MultiPartInputFile f(path.c_str());
            for (int r = 0; r < ENV_LOBE_RINGS; ++r)
                for (const char* c : {"u", "v", "share", "roughness"}) {
                    const std::string name = "env.ring" + std::to_string(r) + "." + c;
                    const Imf::Channel* ch = f.header(0).channels().findChannel(name);
                    ASSERT_NE(ch, nullptr) << name;
                    EXPECT_EQ(ch->type, Imf::HALF) << name;
                }
            EXPECT_EQ(f.header(0).channels().findChannel("env.ring3.u"), nullptr);
            EXPECT_EQ(f.header(0).findTypedAttribute<Imf::IntAttribute>("dfb.formatVersion")->value(), 7);
        }
        auto r = readDeepBuffer(path);
        ASSERT_TRUE(r.ok()) << r.error().toString();
        ASSERT_TRUE(r->hasEnvRings());
        ASSERT_EQ(r->envRings.size(), b.envRings.size());
        for (size_t k = 0; k < b.envRings.size(); ++k) ASSERT_NEAR(r->envRings[k], b.envRings[k], 4.9e-4f) << "element " << k;
        // Without the rings (a version 6 shot): no ring channels, and it reads back without them.
        b.envRings.clear();
        ASSERT_TRUE(writeDeepBuffer(b, path).ok());
        {
            Imf::MultiPartInputFile f(path.c_str());
            EXPECT_EQ(f.header(0).channels().findChannel("env.ring0.u"), nullptr);
        }
        patchFormatVersion(path, 6);
        r = readDeepBuffer(path);
        ASSERT_TRUE(r.ok()) << r.error().toString();
        EXPECT_FALSE(r->hasEnvRings());
        EXPECT_TRUE(r->hasEnvLobe());
        std::filesystem::remove(path);
    }
}

TEST(ExrIO, EnvRingsOutOfRangeOrPartialAreRefusedNamingTheChannel) {
    struct Case {
        int component;
        float value;
        const char* name;
    };
    for (const Case& c : {Case{0, std::nanf(""), "env.ring0.u"}, Case{5, -1.5f, "env.ring1.v"}, Case{6, -0.25f, "env.ring1.share"},
                          Case{11, 1.5f, "env.ring2.roughness"}}) {
        DeepBuffer b = randomBuffer(16, 16, 46);
        addRandomEnvTransfer(b, 47);
        addRandomEnvLobe(b, 48);
        addRandomEnvRings(b, 49);
        const size_t i = 37;
        b.envRings[i * ENV_RING_COMPONENTS + size_t(c.component)] = c.value;
        SCOPED_TRACE(c.name);
        expectRefusedNaming(b, c.name, i);
    }
    // Some but not all of the rings' channels: refused naming the first absent one.
    const std::string path = tempPath("rings_partial.exr");
    std::vector<std::string> partial;
    for (int r = 0; r < ENV_LOBE_RINGS; ++r)
        for (const char* c : {"u", "v", "share", "roughness"})
            if (!(r == 1 && std::string(c) == "share")) partial.push_back("env.ring" + std::to_string(r) + "." + c);
    writeFileWithChannels(path, partial);
    auto r = readDeepBuffer(path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::MissingData);
    EXPECT_NE(r.error().message.find("'env.ring1.share' is missing"), std::string::npos) << r.error().message;
    std::filesystem::remove(path);
}

TEST(ExrIO, InconsistentEnvTransferIsNotWritten) {
    DeepBuffer b = randomBuffer(8, 8, 15);
    b.envTransfer.assign(b.sampleCount() * ENV_TRANSFER_COEFFICIENTS - 1, 0.f);
    EXPECT_FALSE(writeDeepBuffer(b, tempPath("env_short.exr")).ok());
}

// Writing is atomic (a temporary file beside the output, renamed into place), also when the output
// is on a folder many machines share (docs/deployment.md: the bake Job writes the shots the
// nodes open).

namespace {

// Entries of the folder of `path` whose names start with its file name and ".tmp".
std::vector<std::string> tempFilesOf(const std::string& path) {
    const std::filesystem::path p(path);
    std::vector<std::string> found;
    for (const auto& e : std::filesystem::directory_iterator(p.parent_path())) {
        if (e.path().filename().string().rfind(p.filename().string() + ".tmp", 0) == 0) found.push_back(e.path().string());
    }
    return found;
}

// A deep buffer (0..3 samples per pixel, zero channels: only the writing is tested).
DeepBuffer deepZeros(int w, int h) {
    std::vector<uint32_t> counts(size_t(w * h));
    for (size_t i = 0; i < counts.size(); ++i) counts[i] = uint32_t(i % 4);
    DeepBuffer b;
    b.allocateSamples(w, h, counts);
    b.samplesPerPixel = 4;
    return b;
}

} // namespace

// Two bake pods of one shot are both PID 1 in their containers: the temporary name must not be
// one that another writer of the same output may be using.
TEST(ExrIO, AnotherWritersTemporaryFileIsLeftAlone) {
    const std::string path = tempPath("shared.exr");
    const std::string other = path + ".tmp" + std::to_string(::getpid());
    std::ofstream(other) << "another writer's half-written shot";
    ASSERT_TRUE(writeDeepBuffer(randomBuffer(8, 8, 21), path).ok());
    EXPECT_TRUE(readDeepBuffer(path).ok());
    EXPECT_EQ(readBytes(other), "another writer's half-written shot");
    EXPECT_EQ(tempFilesOf(path), std::vector<std::string>{other});
    std::filesystem::remove(other);
    std::filesystem::remove(path);
}

// A disk that fills up at the very end of the file (here the file size limit, a few bytes short):
// OpenEXR writes the line offset table from its output files' destructors and swallows any error
// there, and std::ofstream flushes its last buffer in its destructor unchecked, so the end of a
// file is where a failure could pass unseen and a short shot be renamed into place. The write
// must fail (IoError), leaving neither the output nor a temporary file. Flat and deep files.
TEST(ExrIO, WriteFailingAtTheEndOfTheFileIsAnErrorAndLeavesNothing) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    for (const bool deep : {false, true}) {
        const DeepBuffer b = deep ? deepZeros(40, 30) : randomBuffer(40, 30, 22);
        ASSERT_EQ(b.isFlat(), !deep);
        const std::string whole = tempPath("whole.exr"), path = tempPath("short.exr");
        ASSERT_TRUE(writeDeepBuffer(b, whole).ok());
        const auto size = std::filesystem::file_size(whole);
        std::filesystem::remove(whole);
        const auto attempt = [&] {
            // Writing past the limit fails with EFBIG instead of raising SIGXFSZ.
            ::signal(SIGXFSZ, SIG_IGN);
            const rlimit limit{rlim_t(size - 8), rlim_t(size - 8)};
            ::setrlimit(RLIMIT_FSIZE, &limit);
            const Status s = writeDeepBuffer(b, path);
            if (s.ok()) {
                std::fprintf(stderr, "the write succeeded\n");
                std::exit(1);
            }
            std::fprintf(stderr, "%s\n", s.error().toString().c_str());
            std::exit(s.error().code == ErrorCode::IoError && !std::filesystem::exists(path) && tempFilesOf(path).empty() ? 0 : 2);
        };
        EXPECT_EXIT(attempt(), ::testing::ExitedWithCode(0), "io_error: .*short\\.exr")
            << (deep ? "deep" : "flat");
        std::filesystem::remove(path);
        for (const auto& t : tempFilesOf(path)) std::filesystem::remove(t);
    }
}
