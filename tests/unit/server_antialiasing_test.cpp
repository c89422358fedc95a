// Anti-aliasing through the deep framebuffer: a 16-sample bake relit by the server matches, on
// silhouette pixels, the relight of a 4x-resolution bake box-filtered down; a 1-sample bake
// does not.

#include <dfb/gbuffer/Baker.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

using namespace dfb;

namespace {

ImageF relight(const Scene& scene, int w, int h, int samples, const Rig& rig) {
    BakeOptions o;
    o.width = w;
    o.height = h;
    o.samples = samples;
    auto shot = bake(scene, o);
    EXPECT_TRUE(shot.ok()) << shot.error().toString();
    auto engine = Engine::create(shot.value(), shadowCasters(scene));
    EXPECT_TRUE(engine.ok()) << engine.error().toString();
    auto img = engine.value()->renderLinear(rig);
    EXPECT_TRUE(img.ok()) << img.error().toString();
    return img.value();
}

} // namespace

TEST(AntiAliasing, MultiSampleEdgesMatchABoxFilteredSupersampledRelight) {
    auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    const Bounds& b = scene->bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    rig.lights[0].shadowMapSize = 4096; // shadow edges sharper than a pixel: the test is about silhouettes

    const int W = 160, H = 90, F = 4;
    BakeOptions o;
    o.width = W;
    o.height = H;
    o.samples = F * F; // the 4x4 stratified grid: the supersampled bake's pixel centres
    auto aaShot = bake(scene.value(), o);
    ASSERT_TRUE(aaShot.ok()) << aaShot.error().toString();
    auto engine = Engine::create(aaShot.value(), shadowCasters(scene.value()));
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    auto aa = engine.value()->renderLinear(rig);
    ASSERT_TRUE(aa.ok());
    engine.value().reset();
    const ImageF big = relight(scene.value(), W * F, H * F, 1, rig);
    const ImageF one = relight(scene.value(), W, H, 1, rig);

    // Silhouette pixels: several surfaces, or partial coverage (an object against the background).
    double errAA = 0, errOne = 0, refMean = 0;
    size_t n = 0, multi = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const DeepBuffer& d = aaShot.value();
            const bool edge = d.pixelSamples(x, y) > 1 || (d.coverage(x, y) > 0.f && d.coverage(x, y) < 0.999f);
            if (!edge) continue;
            multi += d.pixelSamples(x, y) > 1;
            for (int c = 0; c < 3; ++c) {
                double ref = 0;
                for (int j = 0; j < F; ++j)
                    for (int i = 0; i < F; ++i) ref += big.rgba[((size_t(y) * F + j) * size_t(W * F) + size_t(x) * F + i) * 4 + c];
                ref /= F * F;
                const size_t k = (size_t(y) * W + x) * 4 + size_t(c);
                errAA += std::abs(aa->rgba[k] - ref);
                errOne += std::abs(one.rgba[k] - ref);
                refMean += ref;
            }
            ++n;
        }
    ASSERT_GT(n, 300u) << "expected many silhouette pixels";
    ASSERT_GT(multi, 100u) << "expected pixels with several surfaces";
    errAA /= double(n) * 3;
    errOne /= double(n) * 3;
    refMean /= double(n) * 3;
    std::printf("silhouette pixels: %zu (%zu with several surfaces); mean radiance %.4f\n", n, multi, refMean);
    std::printf("mean abs error vs 4x supersampled relight: 16 spp %.5f (%.1f%%), 1 spp %.5f (%.1f%%)\n", errAA,
                100 * errAA / refMean, errOne, 100 * errOne / refMean);
    // Tolerance: merging a pixel's samples on one surface averages positions and normals before
    // shading, which differs from averaging shaded samples where lighting varies inside a pixel.
    EXPECT_LT(errAA, 0.25 * errOne);
    // Measured on llvmpipe: 6.2% of the mean silhouette radiance (1 spp: 41.9%).
    EXPECT_LT(errAA / refMean, 0.08);
}
