#pragma once
// Spot lights' cookie images: read from the asset folder on first use, kept per file name as
// mipmapped textures.

#include <dfb/core/Result.h>
#include <dfb/gl/Objects.h>
#include <dfb/protocol/Rig.h>

#include <map>
#include <string>

namespace dfb::engine {

class Cookies {
public:
    /// Where Light::cookie names are looked up; default ".". Textures already loaded are kept.
    void setDirectory(std::string dir) { mDirectory = std::move(dir); }

    /// The texture of l.cookie (GL thread). Fails with the image reader's error, naming the light
    /// and the cookie.
    Result<GLuint> texture(const Light& l);

private:
    std::string mDirectory = ".";
    std::map<std::string, gl::Texture> mTextures; // by file name
};

} // namespace dfb::engine
