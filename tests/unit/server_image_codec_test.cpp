// JPEG encoding in strips: the joined file (restart markers between strips) is a valid baseline
// JPEG that decodes to exactly the pixels of a single-threaded libjpeg-turbo encoding, for sizes
// that split into several strips, into a last short strip, or not at all.

#include <dfb/server/ImageCodec.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <turbojpeg.h>

#include <cmath>
#include <atomic>
#include <random>
#include <thread>

using namespace dfb;

namespace {

Image8 testImage(int w, int h) {
    Image8 img;
    img.width = w;
    img.height = h;
    img.rgba.resize(size_t(w) * size_t(h) * 4);
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> noise(-20, 20);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &img.rgba[(size_t(y) * size_t(w) + size_t(x)) * 4];
            p[0] = uint8_t(std::clamp(int(127 + 100 * std::sin(x * 0.05)) + noise(rng), 0, 255));
            p[1] = uint8_t(std::clamp(y * 255 / std::max(h - 1, 1) + noise(rng), 0, 255));
            p[2] = uint8_t(((x / 8 + y / 8) % 2) ? 220 : 30);
            p[3] = 255;
        }
    return img;
}

std::vector<uint8_t> decode(const std::vector<uint8_t>& jpeg, int& w, int& h) {
    tjhandle tj = tjInitDecompress();
    int sub = 0, cs = 0;
    EXPECT_EQ(tjDecompressHeader3(tj, jpeg.data(), jpeg.size(), &w, &h, &sub, &cs), 0) << tjGetErrorStr2(tj);
    std::vector<uint8_t> rgb(size_t(w) * size_t(h) * 3);
    EXPECT_EQ(tjDecompress2(tj, jpeg.data(), jpeg.size(), rgb.data(), w, 0, h, TJPF_RGB, 0), 0) << tjGetErrorStr2(tj);
    tjDestroy(tj);
    return rgb;
}

std::vector<uint8_t> singleThreaded(const Image8& img, int quality) {
    tjhandle tj = tjInitCompress();
    unsigned char* out = nullptr;
    unsigned long size = 0;
    EXPECT_EQ(tjCompress2(tj, img.rgba.data(), img.width, img.width * 4, img.height, TJPF_RGBA, &out, &size, TJSAMP_420,
                          quality, TJFLAG_FASTDCT),
              0);
    std::vector<uint8_t> bytes(out, out + size);
    tjFree(out);
    tjDestroy(tj);
    return bytes;
}

size_t countMarkers(const std::vector<uint8_t>& j, uint8_t lo, uint8_t hi) {
    size_t n = 0;
    for (size_t i = 0; i + 1 < j.size(); ++i) n += j[i] == 0xFF && j[i + 1] >= lo && j[i + 1] <= hi;
    return n;
}

} // namespace

TEST(JpegStrips, JoinedStripsDecodeToTheSinglyEncodedPixels) {
    struct Case {
        int w, h, threads;
        size_t restarts; // RST markers expected
    };
    // 1000 rows = 63 MCU rows: 4 strips of 16 MCU rows (the last 15); 1080 rows on 8 threads; a
    // small image stays one strip (strips are at least 64 rows); odd widths pad the last MCU.
    for (const Case c : {Case{700, 1000, 4, 3}, Case{1920, 1080, 8, 7}, Case{33, 60, 4, 0}, Case{257, 300, 3, 2}}) {
        SCOPED_TRACE(std::to_string(c.w) + "x" + std::to_string(c.h));
        const Image8 img = testImage(c.w, c.h);
        auto joined = encodeJpeg(img, 85, c.threads);
        ASSERT_TRUE(joined.ok()) << joined.error().toString();
        EXPECT_EQ(countMarkers(joined.value(), 0xD0, 0xD7), c.restarts);
        EXPECT_EQ(countMarkers(joined.value(), 0xDD, 0xDD), c.restarts > 0 ? 1u : 0u); // DRI
        int w = 0, h = 0, w1 = 0, h1 = 0;
        const auto got = decode(joined.value(), w, h);
        const auto want = decode(singleThreaded(img, 85), w1, h1);
        ASSERT_EQ(w, c.w);
        ASSERT_EQ(h, c.h);
        size_t differing = 0;
        for (size_t i = 0; i < got.size(); ++i) differing += got[i] != want[i];
        EXPECT_EQ(differing, 0u);

        // An independent reader (OpenImageIO's JPEG plugin) takes the file too.
        OIIO::Filesystem::IOMemReader mem(joined->data(), joined->size());
        auto in = OIIO::ImageInput::open("frame.jpg", nullptr, &mem);
        ASSERT_TRUE(in) << OIIO::geterror();
        std::vector<uint8_t> pixels(size_t(c.w) * size_t(c.h) * 3);
        ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, pixels.data())) << in->geterror();
        int worst = 0;
        for (size_t i = 0; i < pixels.size(); ++i) worst = std::max(worst, std::abs(int(pixels[i]) - int(want[i])));
        EXPECT_LE(worst, 2); // its decoder may use another IDCT / upsampling
    }
}

// Several threads encoding at once share the strip workers: every result is still right.
TEST(JpegStrips, ConcurrentEncodingsShareTheWorkers) {
    const Image8 img = testImage(640, 720);
    int w0 = 0, h0 = 0;
    const auto want = decode(singleThreaded(img, 80), w0, h0);
    std::vector<std::thread> threads;
    std::atomic<int> wrong{0};
    for (int t = 0; t < 4; ++t) {
        threads.emplace_back([&] {
            for (int k = 0; k < 5; ++k) {
                auto j = encodeJpeg(img, 80, 6);
                int w = 0, h = 0;
                if (!j || decode(j.value(), w, h) != want) ++wrong;
            }
        });
    }
    for (std::thread& t : threads) t.join();
    EXPECT_EQ(wrong.load(), 0);
}
