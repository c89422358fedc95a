// Issue 5's light types and controls through real EGL: point lights (Lambert within 1%, cube-map
// shadows against an exact segment test), barn doors, cookies, the soft-shadow filter size,
// progressive refinement (preview shadow maps replaced on the next full render) and the
// multi-layer EXR (light groups that sum to the beauty).

#include <dfb/server/Engine.h>
#include <dfb/server/ImageCodec.h>

#include <gtest/gtest.h>

#include "support/PlaneShot.h"

#include <OpenImageIO/imageio.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

using namespace dfb;

namespace {

constexpr int SIZE = 96;
constexpr float HALF = 2.f; // the plane covers x, z in [-HALF, HALF]

glm::vec3 planePoint(int x, int y) { return test::PlaneShot{}.point(x, y); }

// A SIZE x SIZE shot looking straight down at a Lambertian plane y = 0.
DeepBuffer planeShot(float albedo) {
    test::PlaneShot p;
    p.albedo = glm::vec3(albedo);
    return p.shot();
}

glm::vec3 g(const Vec3& v) { return {v[0], v[1], v[2]}; }

double lambert(const Light& l, const glm::vec3& p, float albedo) {
    const glm::vec3 toLight = g(l.position) - p;
    const float d = glm::length(toLight);
    return albedo / M_PI * l.intensityCd * (toLight.y / d) / (d * d);
}

// Horizontal square blockers: centre (x, z), height y, half-size h.
struct Blocker {
    float x, y, z, h;
};

ShadowGeometry blockers(const std::vector<Blocker>& bs) {
    ShadowGeometry geo;
    for (const Blocker& b : bs) {
        const auto base = uint32_t(geo.positions.size());
        geo.positions.push_back({b.x - b.h, b.y, b.z - b.h});
        geo.positions.push_back({b.x + b.h, b.y, b.z - b.h});
        geo.positions.push_back({b.x + b.h, b.y, b.z + b.h});
        geo.positions.push_back({b.x - b.h, b.y, b.z + b.h});
        for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) geo.indices.push_back(base + i);
    }
    return geo;
}

// Exact visibility: does the segment from p to the light cross a blocker?
bool occluded(const std::vector<Blocker>& bs, const glm::vec3& p, const glm::vec3& light) {
    for (const Blocker& b : bs) {
        const float t = (b.y - p.y) / (light.y - p.y);
        if (t <= 0.f || t >= 1.f) continue;
        const glm::vec3 q = p + t * (light - p);
        if (std::abs(q.x - b.x) <= b.h && std::abs(q.z - b.z) <= b.h) return true;
    }
    return false;
}

Light pointLight() {
    Light l;
    l.name = "bulb";
    l.type = LightType::Point;
    l.position = {0.2f, 0.8f, -0.1f};
    l.intensityCd = 2.f;
    l.shadow = false;
    return l;
}

Light downSpot() {
    Light l;
    l.name = "spot";
    l.position = {0.f, 2.f, 0.f};
    l.direction = {0.f, -1.f, 0.f};
    l.intensityCd = 6.f;
    l.coneAngleDeg = 60.f;
    l.penumbraDeg = 0.5f;
    l.shadow = false;
    return l;
}

} // namespace

TEST(EngineLights, PointLightLambertPlaneWithinOnePercent) {
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), ShadowGeometry{});
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    rig.lights.push_back(pointLight());
    auto img = engine.value()->renderLinear(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    double worst = 0;
    for (int y = 0; y < SIZE; ++y)
        for (int x = 0; x < SIZE; ++x) {
            const double expected = lambert(rig.lights[0], planePoint(x, y), albedo);
            worst = std::max(worst, std::abs(img->rgba[(size_t(y) * SIZE + size_t(x)) * 4] - expected) / expected);
        }
    std::printf("point light over a Lambert plane: %d pixels, worst relative error %.2e\n", SIZE * SIZE, worst);
    EXPECT_LT(worst, 0.01); // every pixel: a point light has no cone
}

TEST(EngineLights, PointLightCubeShadowsMatchExactVisibilityOnEveryFace) {
    // The light is low (0.8 above the plane), so the plane is seen through the -Y face and all
    // four side faces; a blocker sits in each of those directions.
    // Shadows land at: under the light (-Y face), x = 1.48 (+X), x = -1.56 (-X), z = 1.66 (+Z),
    // z = -1.54 (-Z).
    const std::vector<Blocker> bs = {{0.2f, 0.4f, -0.1f, 0.12f}, {1.f, 0.3f, 0.f, 0.1f}, {-0.9f, 0.3f, 0.3f, 0.1f},
                                     {0.f, 0.3f, 1.f, 0.1f},     {0.4f, 0.3f, -1.f, 0.1f}};
    auto engine = Engine::create(planeShot(0.5f), blockers(bs));
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    Light l = pointLight();
    l.shadow = true;
    l.shadowMapSize = 1024;
    rig.lights.push_back(l);
    auto mask = engine.value()->renderShadowMask(rig, "bulb");
    ASSERT_TRUE(mask.ok()) << mask.error().toString();
    int shadowed = 0, wrong = 0, faces = 0;
    bool faceSeen[6] = {};
    for (int y = 0; y < SIZE; ++y)
        for (int x = 0; x < SIZE; ++x) {
            const glm::vec3 p = planePoint(x, y);
            const bool dark = occluded(bs, p, g(l.position));
            // Pixels within a pixel of a shadow edge may go either way (filtering, bias).
            bool edge = false;
            for (int dy = -1; dy <= 1 && !edge; ++dy)
                for (int dx = -1; dx <= 1 && !edge; ++dx)
                    edge = occluded(bs, planePoint(x, y) + glm::vec3(dx, 0, dy) * (2.f * HALF / SIZE), g(l.position)) != dark;
            const float vis = mask->rgba[(size_t(y) * SIZE + size_t(x)) * 4];
            if (dark) {
                ++shadowed;
                const glm::vec3 d = p - g(l.position);
                const glm::vec3 a = glm::abs(d);
                const int face = a.x >= a.y && a.x >= a.z ? (d.x > 0 ? 0 : 1) : a.y >= a.z ? (d.y > 0 ? 2 : 3) : (d.z > 0 ? 4 : 5);
                faceSeen[face] = true;
            }
            if (!edge && (vis < 0.5f) != dark) ++wrong;
        }
    for (bool f : faceSeen) faces += f ? 1 : 0;
    std::printf("point light cube shadows: %d shadowed pixels over %d faces, %d of %d disagree off the edges\n", shadowed,
                faces, wrong, SIZE * SIZE);
    EXPECT_EQ(faces, 5); // -Y and the four side faces
    EXPECT_GT(shadowed, 200);
    EXPECT_LE(wrong, SIZE * SIZE / 500); // 0.2%
}

TEST(EngineLights, BarnDoorsCutTheLightPastEachFlap) {
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), ShadowGeometry{});
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    Light l = downSpot();
    // The light points straight down, so its frame uses +X as "up": right = axis x up = +Z,
    // its up = right x axis = +X (Light::barnDoorsDeg).
    l.barnDoorsDeg = {30.f, 10.f, 20.f, 90.f}; // left, right, top, bottom
    rig.lights.push_back(l);
    auto img = engine.value()->renderLinear(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    int lit = 0, cut = 0, bad = 0;
    for (int y = 0; y < SIZE; ++y)
        for (int x = 0; x < SIZE; ++x) {
            const glm::vec3 p = planePoint(x, y);
            const float h = 2.f;
            const float right = glm::degrees(std::atan(p.z / h)), up = glm::degrees(std::atan(p.x / h));
            const float cone = glm::degrees(std::atan(std::hypot(p.x, p.z) / h));
            if (cone > l.coneAngleDeg - 1.f) continue;
            const float margin = 0.5f; // the flaps' soft edge is 0.25 degrees either side
            const bool inside = right < 10.f - margin && -right < 30.f - margin && up < 20.f - margin;
            const bool outside = right > 10.f + margin || -right > 30.f + margin || up > 20.f + margin;
            const double v = img->rgba[(size_t(y) * SIZE + size_t(x)) * 4];
            if (inside) {
                ++lit;
                const double e = lambert(l, p, albedo);
                if (std::abs(v - e) > 0.01 * e) ++bad;
            } else if (outside) {
                ++cut;
                if (v != 0.0) ++bad;
            }
        }
    std::printf("barn doors: %d lit pixels, %d cut, %d wrong\n", lit, cut, bad);
    EXPECT_GT(lit, 500);
    EXPECT_GT(cut, 2000);
    EXPECT_EQ(bad, 0);
}

TEST(EngineLights, CookieIsProjectedAcrossTheConeAndBadCookiesAreNamed) {
    // A 64x64 cookie with four coloured quadrants: top-left red, top-right green, bottom-left
    // blue, bottom-right white.
    const auto dir = std::filesystem::temp_directory_path() / ("dfb_cookie_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    {
        std::vector<uint8_t> px(64 * 64 * 3);
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 64; ++x) {
                const bool top = y < 32, left = x < 32;
                const uint8_t r = (top && left) || (!top && !left) ? 255 : 0;
                const uint8_t gr = (top && !left) || (!top && !left) ? 255 : 0;
                const uint8_t b = (!top && left) || (!top && !left) ? 255 : 0;
                uint8_t* p = &px[size_t(y * 64 + x) * 3];
                p[0] = r, p[1] = gr, p[2] = b;
            }
        auto out = OIIO::ImageOutput::create((dir / "quad.png").string());
        ASSERT_TRUE(out);
        ASSERT_TRUE(out->open((dir / "quad.png").string(), OIIO::ImageSpec(64, 64, 3, OIIO::TypeDesc::UINT8)));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
        out->close();
    }
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), ShadowGeometry{});
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    engine.value()->setAssetDirectory(dir.string());
    Rig rig;
    Light l = downSpot();
    l.cookie = "quad.png";
    rig.lights.push_back(l);
    auto img = engine.value()->renderLinear(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    // Light frame (straight down): right = +Z, up = +X. The image's top-right quadrant lands at
    // x > 0 (up), z > 0 (right).
    auto rgbAt = [&](float wx, float wz) {
        const int x = int((wx + HALF) / (2.f * HALF) * SIZE), y = int((wz + HALF) / (2.f * HALF) * SIZE);
        const float* p = &img->rgba[(size_t(y) * SIZE + size_t(x)) * 4];
        return glm::vec3(p[0], p[1], p[2]) / float(lambert(l, planePoint(x, y), albedo));
    };
    const struct {
        float x, z;
        glm::vec3 colour;
    } expect[] = {{0.6f, -0.6f, {1, 0, 0}}, {0.6f, 0.6f, {0, 1, 0}}, {-0.6f, -0.6f, {0, 0, 1}}, {-0.6f, 0.6f, {1, 1, 1}}};
    for (const auto& e : expect) {
        const glm::vec3 got = rgbAt(e.x, e.z);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], e.colour[c], 0.01) << "at " << e.x << "," << e.z << " channel " << c;
    }
    // A cookie that is not an image: a clear error naming the light and the file.
    {
        FILE* f = std::fopen((dir / "broken.png").c_str(), "wb");
        std::fputs("not a png", f);
        std::fclose(f);
    }
    rig.lights[0].cookie = "broken.png";
    auto bad = engine.value()->renderLinear(rig);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("light 'spot': cookie 'broken.png'"), std::string::npos) << bad.error().message;
    rig.lights[0].cookie = "missing.png";
    bad = engine.value()->renderLinear(rig);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("missing.png"), std::string::npos) << bad.error().message;
    std::filesystem::remove_all(dir);
}

TEST(EngineLights, SoftShadowFilterSizeWidensThePenumbra) {
    const std::vector<Blocker> bs = {{0.f, 1.f, 0.f, 0.25f}};
    auto engine = Engine::create(planeShot(0.5f), blockers(bs));
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    Light l = downSpot();
    l.shadow = true;
    l.shadowMapSize = 256;
    rig.lights.push_back(l);
    int partial[5] = {};
    for (int r : {0, 1, 4}) {
        rig.lights[0].shadowFilter = r;
        auto mask = engine.value()->renderShadowMask(rig, "spot");
        ASSERT_TRUE(mask.ok()) << mask.error().toString();
        for (size_t i = 0; i < mask->rgba.size(); i += 4)
            if (mask->rgba[i + 1] > 0.5f && mask->rgba[i] > 0.05f && mask->rgba[i] < 0.95f) ++partial[r];
    }
    std::printf("soft-shadow filter: partially shadowed pixels r=0: %d, r=1: %d, r=4: %d\n", partial[0], partial[1], partial[4]);
    EXPECT_LT(partial[0], partial[1]);
    EXPECT_LT(partial[1], partial[4]);
}

TEST(EngineLights, PreviewShadowMapsAreReplacedByTheFullRender) {
    const std::vector<Blocker> bs = {{0.f, 1.f, 0.f, 0.25f}, {1.f, 0.5f, 1.f, 0.2f}};
    auto engine = Engine::create(planeShot(0.5f), blockers(bs));
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Engine& e = *engine.value();
    Rig rig;
    Light l = downSpot();
    l.shadow = true;
    l.shadowMapSize = 2048;
    rig.lights.push_back(l);
    Light p = pointLight();
    p.shadow = true;
    p.shadowMapSize = 1024;
    rig.lights.push_back(p);
    FrameStats st;
    ASSERT_TRUE(e.render(rig, &st).ok());
    // A drag: previews re-render the moved light's shadow map small.
    e.setPreview(true);
    rig.lights[0].position[0] += 0.3f;
    rig.lights[1].position[2] += 0.2f;
    auto preview = e.renderLinear(rig);
    ASSERT_TRUE(preview.ok());
    ASSERT_TRUE(e.render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0); // nothing changed since the preview
    // The drag stops: the same rig at full quality re-renders both shadow maps, and the result
    // equals a fresh engine's.
    e.setPreview(false);
    ASSERT_TRUE(e.render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 2);
    EXPECT_EQ(st.lightsShaded, 2);
    auto refined = e.renderLinear(rig);
    ASSERT_TRUE(refined.ok());
    auto fresh = Engine::create(planeShot(0.5f), blockers(bs));
    ASSERT_TRUE(fresh.ok());
    auto reference = fresh.value()->renderLinear(rig);
    ASSERT_TRUE(reference.ok());
    double worst = 0, previewDiff = 0;
    for (size_t i = 0; i < reference->rgba.size(); ++i) {
        worst = std::max(worst, double(std::abs(refined->rgba[i] - reference->rgba[i])));
        previewDiff += std::abs(preview->rgba[i] - reference->rgba[i]);
    }
    std::printf("preview vs full: mean abs difference %.2e; refined vs fresh: worst %.2e\n",
                previewDiff / double(reference->rgba.size()), worst);
    EXPECT_LT(worst, 1e-4);
    EXPECT_GT(previewDiff, 0.0); // the preview really used smaller maps
}

TEST(EngineLights, MultiLayerExrHoldsTheBeautyAndOneLayerPerLightThatSumToIt) {
    auto engine = Engine::create(planeShot(0.5f), blockers({{0.f, 1.f, 0.f, 0.25f}}));
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    Light l = downSpot();
    l.shadow = true;
    rig.lights.push_back(l);
    rig.lights.push_back(pointLight());
    auto layers = engine.value()->renderLayers(rig);
    ASSERT_TRUE(layers.ok()) << layers.error().toString();
    ASSERT_EQ(layers->size(), 3u);
    auto bytes = encodeExr(layers.value());
    ASSERT_TRUE(bytes.ok()) << bytes.error().toString();
    const auto path = std::filesystem::temp_directory_path() / ("dfb_layers_" + std::to_string(::getpid()) + ".exr");
    {
        FILE* f = std::fopen(path.c_str(), "wb");
        std::fwrite(bytes->data(), 1, bytes->size(), f);
        std::fclose(f);
    }
    auto in = OIIO::ImageInput::open(path.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec spec = in->spec();
    std::vector<std::string> names(spec.channelnames.begin(), spec.channelnames.end());
    EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
    auto channel = [&](const std::string& n) {
        auto it = std::find(names.begin(), names.end(), n);
        return it == names.end() ? -1 : int(it - names.begin());
    };
    for (const char* n : {"R", "G", "B", "A", "spot.R", "spot.G", "spot.B", "bulb.R", "bulb.G", "bulb.B"})
        EXPECT_GE(channel(n), 0) << "channel " << n << " missing";
    std::vector<float> px(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
    ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data()));
    in->close();
    std::filesystem::remove(path);
    double worst = 0, total = 0;
    for (size_t p = 0; p < size_t(spec.width) * size_t(spec.height); ++p)
        for (const char* c : {"R", "G", "B"}) {
            const float* q = &px[p * size_t(spec.nchannels)];
            const double sum = q[channel(std::string("spot.") + c)] + q[channel(std::string("bulb.") + c)];
            worst = std::max(worst, std::abs(q[channel(c)] - sum));
            total += q[channel(c)];
        }
    std::printf("multi-layer EXR: %zu channels, beauty - sum of light layers: worst %.2e (mean beauty %.3f)\n", names.size(),
                worst, total / (3.0 * spec.width * spec.height));
    EXPECT_GT(total, 0.0);
    EXPECT_LT(worst, 1e-3);
}

TEST(EngineLights, FilmicViewTransformRollsHighlightsOffInsteadOfClipping) {
    // A bright point light: the plane's radiance runs from ~0.05 to ~4. sRGB clips everything
    // above 1; the filmic curve (Narkowicz's ACES fit, which reaches white only near 7) maps each
    // pixel to its closed form.
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), ShadowGeometry{});
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    Light l = pointLight();
    l.intensityCd = 16.f;
    rig.lights.push_back(l);
    auto srgb = [](double c) {
        c = std::clamp(c, 0.0, 1.0);
        return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
    };
    auto filmic = [](double x) { return std::clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); };
    auto plain = engine.value()->render(rig);
    rig.viewTransform = ViewTransform::Filmic;
    auto film = engine.value()->render(rig);
    ASSERT_TRUE(plain.ok() && film.ok());
    int clipped = 0, worst = 0;
    for (int y = 0; y < SIZE; ++y)
        for (int x = 0; x < SIZE; ++x) {
            const size_t i = (size_t(y) * SIZE + size_t(x)) * 4;
            const double radiance = lambert(l, planePoint(x, y), albedo);
            clipped += plain->rgba[i] == 255 ? 1 : 0;
            const int expected = int(std::lround(255.0 * srgb(filmic(radiance))));
            worst = std::max(worst, std::abs(int(film->rgba[i]) - expected));
            ASSERT_LT(film->rgba[i], 255) << "filmic must not clip at " << x << "," << y << " (radiance " << radiance << ")";
        }
    std::printf("filmic view transform: %d pixels clip in sRGB, none in filmic; worst difference from the curve %d code values\n",
                clipped, worst);
    EXPECT_GT(clipped, 500);
    EXPECT_LE(worst, 1);
}

TEST(EngineLights, NoUsableGpuIsAClearErrorNotAHang) {
    // A failed GL context (here: an EGL platform that does not exist) is a GpuError naming why.
    ::setenv("DFB_EGL_PLATFORM", "no-such-platform", 1);
    auto engine = Engine::create(planeShot(0.5f), ShadowGeometry{});
    ::unsetenv("DFB_EGL_PLATFORM");
    ASSERT_FALSE(engine.ok());
    EXPECT_EQ(engine.error().code, ErrorCode::GpuError);
    EXPECT_NE(engine.error().message.find("EGL platform"), std::string::npos) << engine.error().message;
    auto again = Engine::create(planeShot(0.5f), ShadowGeometry{}); // and nothing is left broken
    EXPECT_TRUE(again.ok()) << again.error().toString();
}
