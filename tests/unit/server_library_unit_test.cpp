// The session library's limits and inputs (session/Library.h), in memory: at most MAX_RIGS saved
// rigs and MAX_SNAPSHOTS snapshots (saving a rig under a name in use replaces it and does not
// count), names by the light names' rule, a frame that is not a JPEG refused with nothing kept,
// thumbnails at most THUMBNAIL_WIDTH wide with the frame's aspect. Persistence is tested over
// the network in server_library_test.

#include "session/Library.h"

#include <dfb/protocol/Rig.h>
#include <dfb/server/ImageCodec.h>

#include <gtest/gtest.h>

#include <turbojpeg.h>

using namespace dfb;

namespace {

std::string jpegOf(int w, int h) {
    Image8 img;
    img.width = w;
    img.height = h;
    img.rgba.resize(size_t(w) * size_t(h) * 4);
    for (size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = uint8_t((i * 7) & 0xFF);
    auto j = encodeJpeg(img, 85, 1);
    return j ? std::string(j->begin(), j->end()) : std::string();
}

std::pair<int, int> sizeOf(const std::string& jpeg) {
    tjhandle tj = tjInitDecompress();
    int w = 0, h = 0, sub = 0, cs = 0;
    tjDecompressHeader3(tj, reinterpret_cast<const unsigned char*>(jpeg.data()), (unsigned long)jpeg.size(), &w, &h, &sub, &cs);
    tjDestroy(tj);
    return {w, h};
}

} // namespace

TEST(Library, LimitsNamesAndThumbnails) {
    auto lib = Library::open({});
    ASSERT_TRUE(lib.ok());
    Library& l = *lib.value();
    EXPECT_FALSE(l.persistent());
    Rig rig = defaultRig({-1, 0, -1}, {1, 1, 1});

    for (size_t i = 0; i < Library::MAX_RIGS; ++i) ASSERT_TRUE(l.saveRig("r" + std::to_string(i), rig, "t").ok());
    EXPECT_TRUE(l.saveRig("r0", rig, "t").ok()) << "saving under a name in use replaces it";
    auto over = l.saveRig("one-more", rig, "t");
    ASSERT_FALSE(over.ok());
    EXPECT_EQ(over.error().code, ErrorCode::LimitExceeded);
    EXPECT_NE(over.error().message.find("100 saved rigs"), std::string::npos) << over.error().message;
    auto bad = l.saveRig("no/slash", rig, "t");
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidValue);
    EXPECT_NE(bad.error().message.find("1-64 characters"), std::string::npos);
    EXPECT_FALSE(l.saveRig(std::string(65, 'a'), rig, "t").ok());

    // A frame that is not a JPEG: refused, nothing kept.
    auto junk = l.addSnapshot("junk", rig, "t", "not a jpeg", 320, 180);
    ASSERT_FALSE(junk.ok());
    EXPECT_EQ(junk.error().code, ErrorCode::InvalidValue);
    EXPECT_FALSE(l.snapshot("junk").ok());

    // Thumbnails: the largest libjpeg-turbo scale that fits 240 columns, same aspect.
    for (auto [w, h] : {std::pair{960, 540}, std::pair{320, 180}, std::pair{1920, 1080}, std::pair{100, 400}, std::pair{8000, 100}}) {
        const std::string name = "s" + std::to_string(w);
        auto s = l.addSnapshot(name, rig, "t", jpegOf(w, h), w, h);
        ASSERT_TRUE(s.ok()) << s.error().toString();
        const auto snap = l.snapshot(name).value();
        const auto [tw, th] = sizeOf(*snap->thumbnail);
        std::printf("%dx%d -> thumbnail %dx%d\n", w, h, tw, th);
        if (w / 8 <= Library::THUMBNAIL_WIDTH) {
            EXPECT_LE(tw, Library::THUMBNAIL_WIDTH);
        }
        EXPECT_GE(tw, std::min(w, Library::THUMBNAIL_WIDTH) / 2) << "not smaller than it needs to be";
        EXPECT_NEAR(double(th) / tw, double(h) / w, 0.05);
        EXPECT_EQ(*snap->image, jpegOf(w, h));
    }
    auto dup = l.addSnapshot("s960", rig, "t", jpegOf(32, 32), 32, 32);
    ASSERT_FALSE(dup.ok());
    EXPECT_EQ(dup.error().code, ErrorCode::Conflict);
    EXPECT_TRUE(l.removeSnapshot("s960").ok());
    EXPECT_EQ(l.removeSnapshot("s960").error().code, ErrorCode::MissingData);
    EXPECT_EQ(l.list()["snapshots"].size(), 4u);
    EXPECT_EQ(l.list()["rigs"].size(), Library::MAX_RIGS);
}
