// The bake evaluates glTF materials exactly: untextured factors come through unchanged, textured
// inputs equal the texture sampled at the pixel's UV (with KHR_texture_transform, UV set 1 and
// wrap modes), alpha MASK removes surface, BLEND becomes coverage, extension lobes are stored,
// and ids match the manifest. Scenes are built here so every expected value is known.

#include "support/GltfBuilder.h"

#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>

#include <Imath/half.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

using namespace dfb;

namespace {

float toHalf(float v) { return float(half(v)); }

float srgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// GL_LINEAR magnification with GL_REPEAT of an RGBA8 image (row 0 = v 0), decoding sRGB per
// texel first as GL does for sRGB textures.
glm::vec4 bilinear(const std::vector<uint8_t>& img, int w, int h, glm::vec2 uv, bool srgb) {
    const float x = uv.x * float(w) - 0.5f, y = uv.y * float(h) - 0.5f;
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const float fx = x - float(x0), fy = y - float(y0);
    auto texel = [&](int i, int j) {
        i = ((i % w) + w) % w;
        j = ((j % h) + h) % h;
        glm::vec4 c;
        for (int k = 0; k < 4; ++k) {
            const float v = img[(size_t(j) * size_t(w) + size_t(i)) * 4 + size_t(k)] / 255.f;
            c[k] = (srgb && k < 3) ? srgbToLinear(v) : v;
        }
        return c;
    };
    return glm::mix(glm::mix(texel(x0, y0), texel(x0 + 1, y0), fx), glm::mix(texel(x0, y0 + 1), texel(x0 + 1, y0 + 1), fx), fy);
}

struct Fixture {
    std::string path;
    DeepBuffer shot;
};

} // namespace

class Materials : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        // Two quads side by side at y = 0, each 2 x 2, seen from straight above by an
        // orthographic camera covering x in [-2, 2], z in [-2, 2] (128 x 128 pixels).
        test::GltfBuilder b;
        // Left: untextured factors and extension lobes.
        tinygltf::Material plain;
        plain.name = "plain";
        plain.pbrMetallicRoughness.baseColorFactor = {0.2, 0.45, 0.7, 1.0};
        plain.pbrMetallicRoughness.metallicFactor = 0.3;
        plain.pbrMetallicRoughness.roughnessFactor = 0.65;
        plain.emissiveFactor = {0.1, 0.2, 0.3};
        tinygltf::Value::Object strength{{"emissiveStrength", tinygltf::Value(4.0)}};
        plain.extensions["KHR_materials_emissive_strength"] = tinygltf::Value(strength);
        tinygltf::Value::Object sheen{{"sheenColorFactor", tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(0.5), tinygltf::Value(0.25), tinygltf::Value(0.125)})},
                                      {"sheenRoughnessFactor", tinygltf::Value(0.4)}};
        plain.extensions["KHR_materials_sheen"] = tinygltf::Value(sheen);
        tinygltf::Value::Object coat{{"clearcoatFactor", tinygltf::Value(0.75)}, {"clearcoatRoughnessFactor", tinygltf::Value(0.2)}};
        plain.extensions["KHR_materials_clearcoat"] = tinygltf::Value(coat);
        tinygltf::Value::Object spec{{"specularFactor", tinygltf::Value(0.5)}};
        plain.extensions["KHR_materials_specular"] = tinygltf::Value(spec);
        b.addQuad("plain_quad", -2.f, -2.f, 0.f, 2.f, 0.f, b.addMaterial(plain));

        // Right: textured base colour (sRGB, UV set 1, scaled 2x by KHR_texture_transform so it
        // repeats) and metallic-roughness (linear, UV set 0).
        const int tw = 4, th = 4;
        std::vector<uint8_t> colour(size_t(tw * th * 4)), mr(size_t(tw * th * 4));
        for (int j = 0; j < th; ++j)
            for (int i = 0; i < tw; ++i) {
                uint8_t* c = &colour[size_t(j * tw + i) * 4];
                c[0] = uint8_t(40 + 60 * i);
                c[1] = uint8_t(30 + 70 * j);
                c[2] = uint8_t((i + j) % 2 ? 220 : 20);
                c[3] = 255;
                uint8_t* m = &mr[size_t(j * tw + i) * 4];
                m[0] = 0;
                m[1] = uint8_t(255 - 50 * i); // roughness
                m[2] = uint8_t(50 * j + 20);  // metallic
                m[3] = 255;
            }
        mColour = colour;
        mMr = mr;
        tinygltf::Material textured;
        textured.name = "textured";
        textured.pbrMetallicRoughness.baseColorTexture.index = b.addTexture(tw, th, colour);
        textured.pbrMetallicRoughness.baseColorTexture.texCoord = 1;
        tinygltf::Value::Object tt{{"scale", tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(2.0), tinygltf::Value(2.0)})}};
        textured.pbrMetallicRoughness.baseColorTexture.extensions["KHR_texture_transform"] = tinygltf::Value(tt);
        textured.pbrMetallicRoughness.metallicRoughnessTexture.index = b.addTexture(tw, th, mr);
        textured.pbrMetallicRoughness.metallicFactor = 1.0;
        textured.pbrMetallicRoughness.roughnessFactor = 1.0;
        b.addQuad("textured_quad", 0.f, -2.f, 2.f, 2.f, 0.f, b.addMaterial(textured));

        // A MASK strip over the left quad's top (alpha 0.3 < cutoff 0.5: invisible) and a BLEND
        // strip over the right quad's bottom (alpha 0.25: coverage 0.25).
        tinygltf::Material masked;
        masked.name = "masked";
        masked.alphaMode = "MASK";
        masked.alphaCutoff = 0.5;
        masked.pbrMetallicRoughness.baseColorFactor = {1, 0, 0, 0.3};
        b.addQuad("masked_strip", -2.f, -2.f, 0.f, -1.5f, 0.5f, b.addMaterial(masked));
        tinygltf::Material blended;
        blended.name = "blended";
        blended.alphaMode = "BLEND";
        blended.doubleSided = true;
        blended.pbrMetallicRoughness.baseColorFactor = {0, 1, 0, 0.25};
        b.addQuad("blended_strip", 0.f, 1.5f, 2.f, 2.f, 0.5f, b.addMaterial(blended));

        b.addTopCamera("top", 0.f, 0.f, 10.f, 2.f, 2.f);
        sPath = (std::filesystem::temp_directory_path() / ("dfb_materials_" + std::to_string(::getpid()) + ".glb")).string();
        ASSERT_TRUE(b.write(sPath));
        auto scene = loadScene(sPath);
        ASSERT_TRUE(scene.ok()) << scene.error().toString();
        BakeOptions o;
        o.width = 128;
        o.height = 128;
        auto baked = bake(scene.value(), o);
        ASSERT_TRUE(baked.ok()) << baked.error().toString();
        // Through the file, as the server would see it.
        const std::string exr = sPath + ".exr";
        ASSERT_TRUE(writeDeepBuffer(baked.value(), exr).ok());
        auto back = readDeepBuffer(exr);
        ASSERT_TRUE(back.ok()) << back.error().toString();
        sShot = std::move(back.value());
        if (!std::getenv("DFB_KEEP")) std::filesystem::remove(exr);
    }
    static void TearDownTestSuite() { std::filesystem::remove(sPath); }

    // World (x, z) at the centre of pixel (px, py) of the top view.
    static glm::vec2 worldAt(int px, int py) {
        return {-2.f + 4.f * (float(px) + 0.5f) / 128.f, -2.f + 4.f * (float(py) + 0.5f) / 128.f};
    }
    static uint32_t idOf(const std::string& name, const std::vector<std::string>& names) {
        for (size_t i = 0; i < names.size(); ++i)
            if (names[i] == name) return uint32_t(i + 1);
        return 0;
    }

    static inline std::string sPath;
    static inline DeepBuffer sShot;
    static inline std::vector<uint8_t> mColour, mMr;
};

TEST_F(Materials, CameraAndLayoutAreAsBuilt) {
    ASSERT_EQ(sShot.width, 128);
    EXPECT_TRUE(sShot.camera.orthographic);
    EXPECT_EQ(sShot.camera.name, "top");
    // Pixel centres land on the world points the layout says (orthographic: exact).
    for (int py : {10, 64, 120})
        for (int px : {5, 70, 127}) {
            if (sShot.coverage(px, py) <= 0.f) continue;
            const glm::vec3 p = sShot.position(px, py);
            const glm::vec2 w = worldAt(px, py);
            EXPECT_NEAR(p.x, w.x, 1e-4f);
            EXPECT_NEAR(p.z, w.y, 1e-4f);
        }
}

TEST_F(Materials, UntexturedFactorsAreStoredExactly) {
    const uint32_t plainId = idOf("plain", sShot.materialNames);
    ASSERT_NE(plainId, 0u);
    int checked = 0;
    for (int py = 20; py < 128; py += 7)
        for (int px = 0; px < 64; px += 5) {
            const uint32_t s = sShot.firstSample(px, py);
            if (sShot.materialId[s] != plainId) continue;
            ++checked;
            EXPECT_EQ(sShot.albedo[s * 3 + 0], toHalf(0.2f));
            EXPECT_EQ(sShot.albedo[s * 3 + 1], toHalf(0.45f));
            EXPECT_EQ(sShot.albedo[s * 3 + 2], toHalf(0.7f));
            EXPECT_EQ(sShot.brdf[s * 4 + 0], toHalf(0.3f));
            EXPECT_EQ(sShot.brdf[s * 4 + 1], toHalf(0.65f));
            EXPECT_EQ(sShot.brdf[s * 4 + 2], toHalf(0.25f)); // 0.5 * specularFactor 0.5
            EXPECT_EQ(sShot.brdf[s * 4 + 3], toHalf(1.f));
            EXPECT_EQ(sShot.emission[s * 3 + 1], toHalf(0.8f)); // 0.2 * strength 4
            EXPECT_EQ(sShot.sheen[s * 4 + 0], toHalf(0.5f));
            EXPECT_EQ(sShot.sheen[s * 4 + 2], toHalf(0.125f));
            EXPECT_EQ(sShot.sheen[s * 4 + 3], toHalf(0.4f));
            EXPECT_EQ(sShot.coat[s * 2 + 0], toHalf(0.75f));
            EXPECT_EQ(sShot.coat[s * 2 + 1], toHalf(0.2f));
            EXPECT_EQ(sShot.A[s], 1.f);
            // N unit and facing the camera (+Y); T unit and orthogonal to N.
            EXPECT_NEAR(sShot.N[s * 3 + 1], 1.f, 1e-3f);
            EXPECT_NEAR(glm::length(glm::vec3(sShot.T[s * 4], sShot.T[s * 4 + 1], sShot.T[s * 4 + 2])), 1.f, 2e-3f);
            EXPECT_NEAR(sShot.T[s * 4 + 1], 0.f, 2e-3f);
        }
    EXPECT_GT(checked, 100);
}

TEST_F(Materials, TexturedInputsMatchTheTextureAtThePixelsUv) {
    const uint32_t texturedId = idOf("textured", sShot.materialNames);
    ASSERT_NE(texturedId, 0u);
    int checked = 0;
    double worst = 0;
    for (int py = 0; py < 120; py += 3)
        for (int px = 64; px < 128; px += 3) {
            const uint32_t s = sShot.firstSample(px, py);
            if (sShot.materialId[s] != texturedId) continue;
            const glm::vec2 w = worldAt(px, py);
            const glm::vec2 uv((w.x - 0.f) / 2.f, (w.y + 2.f) / 4.f);
            // Base colour: UV set 1, scaled 2x (KHR_texture_transform), sRGB, repeating.
            const glm::vec4 c = bilinear(mColour, 4, 4, uv * 2.f, true);
            // Metallic-roughness: UV set 0, linear; metallic in B, roughness in G.
            const glm::vec4 m = bilinear(mMr, 4, 4, uv, false);
            for (int k = 0; k < 3; ++k) {
                // Tolerance: 8-bit texel decode plus the filter's fixed-point weights (about 1/256
                // of the texel difference on llvmpipe) plus half storage.
                EXPECT_NEAR(sShot.albedo[s * 3 + size_t(k)], c[k], 0.012f) << "pixel " << px << "," << py << " channel " << k;
                worst = std::max(worst, double(std::abs(sShot.albedo[s * 3 + size_t(k)] - c[k])));
            }
            EXPECT_NEAR(sShot.brdf[s * 4 + 0], m.b, 0.012f);
            EXPECT_NEAR(sShot.brdf[s * 4 + 1], m.g, 0.012f);
            ++checked;
        }
    EXPECT_GT(checked, 200);
    std::printf("textured albedo: worst difference from the CPU texture lookup %.4f over %d pixels\n", worst, checked);
}

TEST_F(Materials, AlphaMaskRemovesSurfaceAndBlendBecomesCoverage) {
    const uint32_t plainId = idOf("plain", sShot.materialNames), blendedId = idOf("blended", sShot.materialNames);
    const uint32_t maskedId = idOf("masked", sShot.materialNames);
    ASSERT_NE(maskedId, 0u);
    // Under the MASK strip (z in [-2, -1.5] on the left) the plain quad shows through.
    for (int px = 4; px < 60; px += 8) {
        const uint32_t s = sShot.firstSample(px, 4);
        EXPECT_EQ(sShot.materialId[s], plainId);
    }
    // The BLEND strip (z in [1.5, 2] on the right) is stored with coverage 0.25.
    int blended = 0;
    for (int px = 68; px < 124; px += 8) {
        const uint32_t s = sShot.firstSample(px, 124);
        EXPECT_EQ(sShot.materialId[s], blendedId);
        EXPECT_NEAR(sShot.A[s], 0.25f, 1e-3f);
        ++blended;
    }
    EXPECT_GT(blended, 3);
}

TEST_F(Materials, IdsMatchTheManifest) {
    for (size_t s = 0; s < sShot.sampleCount(); ++s) {
        if (sShot.A[s] <= 0.f) {
            EXPECT_EQ(sShot.objectId[s], 0u);
            continue;
        }
        ASSERT_GE(sShot.objectId[s], 1u);
        ASSERT_LE(sShot.objectId[s], sShot.objectNames.size());
        const std::string& object = sShot.objectNames[sShot.objectId[s] - 1];
        const std::string& material = sShot.materialNames[sShot.materialId[s] - 1];
        // Every object here is named after its material.
        EXPECT_EQ(object.substr(0, material.size()), material) << object << " vs " << material;
    }
    EXPECT_EQ(sShot.sourceSha256.size(), 64u);
}
