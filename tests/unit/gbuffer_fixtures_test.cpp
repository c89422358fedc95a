// Every malformed file of tests/fixtures/ is refused with a clear error naming the file and what
// is wrong, never a crash (regenerate them with dfb-make-fixtures).

#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>

#include <gtest/gtest.h>

#include <filesystem>

using namespace dfb;

namespace {
struct Case {
    const char* file;
    ErrorCode code;
    const char* mentions; // a fragment the message must contain
};
const std::string DIR = DFB_SOURCE_DIR "/tests/fixtures/";
} // namespace

TEST(Fixtures, MalformedShotsGiveClearErrors) {
    const Case cases[] = {
        {"truncated.exr", ErrorCode::InvalidFile, "truncated.exr"},
        {"absurd_size.exr", ErrorCode::InvalidValue, "absurd image size 100000x100000"},
        {"oversized_for_file.exr", ErrorCode::InvalidFile, "declares 67108864 pixels"},
        {"not_exr.exr", ErrorCode::InvalidFile, "not an OpenEXR file"},
        {"missing_channel.exr", ErrorCode::MissingData, "'N.Y' is missing"},
        {"wrong_channel_type.exr", ErrorCode::InvalidFile, "'id.object' has the wrong type"},
        {"nan_position.exr", ErrorCode::InvalidValue, "non-finite P or N at pixel (3, 3)"},
        {"id_out_of_range.exr", ErrorCode::InvalidValue, "object id 42"},
        {"too_many_samples.exr", ErrorCode::InvalidValue, "100 samples"},
        {"coverage_over_one.exr", ErrorCode::InvalidValue, "add up to more than 1"},
        {"future_version.exr", ErrorCode::InvalidFile, "format version 99"},
        {"bad_manifest.exr", ErrorCode::InvalidFile, "dfb.manifest"},
        {"env_partial.exr", ErrorCode::MissingData, "'env.sh5' is missing"},
        {"env_nan.exr", ErrorCode::InvalidValue, "non-finite environment transfer in channel 'env.sh3' at pixel (3, 3)"},
        // Found by scripts/fuzz: a header attribute declaring 2 GB in a 1 KB file.
        {"fuzz_slow_attribute_size.exr", ErrorCode::InvalidFile, "corrupt header"},
        // Found by scripts/fuzz: a channel list whose content disagrees with its declared size;
        // OpenEXR read the next attribute from the wrong place and allocated a 1.5 GB string
        // (5 s and 1.9 GB for a 1.6 KB file) before failing.
        {"fuzz_slow_channel_list.exr", ErrorCode::InvalidFile, "corrupt header"},
    };
    for (const Case& c : cases) {
        auto r = readDeepBuffer(DIR + c.file);
        ASSERT_FALSE(r.ok()) << c.file << " was accepted";
        EXPECT_EQ(r.error().code, c.code) << c.file << ": " << r.error().toString();
        EXPECT_NE(r.error().message.find(c.file), std::string::npos) << r.error().message;
        EXPECT_NE(r.error().message.find(c.mentions), std::string::npos) << c.file << ": " << r.error().message;
    }
}

// Format v3 reads version 2 shots: they have no environment transfer.
TEST(Fixtures, Version2ShotLoadsWithoutEnvTransfer) {
    auto r = readDeepBuffer(DIR + "v2_shot.exr");
    ASSERT_TRUE(r.ok()) << r.error().toString();
    EXPECT_EQ(r->width, 8);
    EXPECT_FALSE(r->hasEnvTransfer());
    EXPECT_EQ(r->envRays, 0);
}

TEST(Fixtures, MalformedScenesGiveClearErrors) {
    const Case cases[] = {
        {"not_gltf.glb", ErrorCode::InvalidFile, "not a glTF file"},
        {"truncated.glb", ErrorCode::InvalidFile, "glTF parse error"},
        {"draco_required.gltf", ErrorCode::InvalidFile, "unsupported glTF extension KHR_draco_mesh_compression"},
        {"meshopt_required.gltf", ErrorCode::InvalidFile, "unsupported glTF extension EXT_meshopt_compression"},
        {"index_out_of_range.gltf", ErrorCode::InvalidFile, "index 99 out of range"},
        {"nan_vertex.gltf", ErrorCode::InvalidFile, "non-finite vertex position 1"},
        {"accessor_overflow.gltf", ErrorCode::InvalidFile, "past the end"},
        {"no_triangles.gltf", ErrorCode::MissingData, "no triangles"},
        // Found by scripts/fuzz: a buffer view naming a buffer that does not exist.
        {"fuzz_crash_buffer_index.gltf", ErrorCode::InvalidFile, "buffer out of range"},
        // Found by scripts/fuzz: a buffer URI that names no regular file (tinygltf's own reader
        // tried to allocate a directory's "size").
        {"fuzz_crash_uri_directory.gltf", ErrorCode::InvalidFile, "glTF parse error"},
    };
    for (const Case& c : cases) {
        auto r = loadScene(DIR + c.file);
        ASSERT_FALSE(r.ok()) << c.file << " was accepted";
        EXPECT_EQ(r.error().code, c.code) << c.file << ": " << r.error().toString();
        EXPECT_NE(r.error().message.find(c.file), std::string::npos) << r.error().message;
        EXPECT_NE(r.error().message.find(c.mentions), std::string::npos) << c.file << ": " << r.error().message;
    }
}
