#pragma once
// Images from the asset folder, read on first use and kept per file name: spot lights' cookies
// as mipmapped textures, area lights' patterns as summed-area tables (dfb/server/AreaPattern.h),
// environment lights' maps prefiltered by roughness (EnvironmentMap.h).

#include "EnvironmentMap.h"

#include <dfb/core/Result.h>
#include <dfb/gl/Objects.h>
#include <dfb/protocol/Rig.h>

#include <dfb/lightmath/SphericalHarmonics.h>

#include <glm/glm.hpp>

#include <array>
#include <map>
#include <string>
#include <vector>

namespace dfb::engine {

class Cookies {
public:
    /// Where Light::cookie names are looked up; default ".". Textures already loaded are kept.
    void setDirectory(std::string dir) { mDirectory = std::move(dir); }

    /// The texture of l.cookie (GL thread). Fails with the image reader's error, naming the light
    /// and the cookie.
    Result<GLuint> texture(const Light& l);

    /// An area light's pattern table on the GPU: (w + 1) x (h + 1) RGBA32F corners holding
    /// S(u, v) - mean u v (AreaLight.h PatternTable; common_area.glsl satCorner), and the mean.
    struct Pattern {
        GLuint texture = 0;
        glm::vec3 mean{1.f};
    };
    /// The table of l.pattern for l's shape (uniform when empty), GL thread. Errors name the light
    /// and the pattern.
    Result<Pattern> pattern(const Light& l);

    /// An environment light's map on the GPU (TEX_ENV_PREFILTERED: ENV_LEVELS mips prefiltered by
    /// roughness, EnvironmentMap.h) and the small copy its spherical harmonics are projected from
    /// (RGBA, shWidth x shHeight). l.envMap empty: a constant environment of radiance 1. Kept per
    /// file name (the last few). Errors name the light and the map. GL thread; the pointers stay
    /// valid until the next call.
    struct Environment {
        GLuint texture = 0;
        /// The map's exact E(N) / pi less its order-3 expansion, by normal in the map's own frame
        /// (TEX_ENV_IRRADIANCE): made once per map, since a rotation only turns where it is read.
        GLuint irradianceResidual = 0;
        const std::vector<float>* sh = nullptr;
        int shWidth = 0, shHeight = 0;
        std::vector<EnvSun> suns; // taken out of the map (texture and sh hold the rest): extractSuns
        /// sh's spherical harmonics, unturned (envProjectSh once per map; a rotation turns them:
        /// lightmath::shRotate25).
        std::array<glm::dvec3, lightmath::SH_TRANSFER_COEFFICIENTS> coefficients{};
    };
    Result<Environment> environment(const Light& l);

private:
    struct EnvEntry {
        gl::Texture texture;
        gl::Texture irradianceResidual;
        std::vector<float> sh;
        int shWidth = 0, shHeight = 0;
        std::vector<EnvSun> suns;
        std::array<glm::dvec3, lightmath::SH_TRANSFER_COEFFICIENTS> coefficients{};
    };
    std::map<std::string, EnvEntry> mEnvironments; // by file name ("" = constant)
    std::string mDirectory = ".";
    std::map<std::string, gl::Texture> mTextures; // by file name
    std::map<std::pair<std::string, bool>, std::pair<gl::Texture, glm::vec3>> mPatterns; // by (file, disk)
};

} // namespace dfb::engine
