// Deep framebuffer EXR I/O: every channel survives a round trip, and broken files give clear
// errors instead of crashes.

#include <dfb/gbuffer/ExrIO.h>

#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

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
