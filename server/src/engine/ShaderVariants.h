#pragma once
// The engine's programs, built from the embedded shaders (server/shaders) with #defines inserted
// after the #version line, once per set of stage files and defines, and kept.

#include <dfb/core/Result.h>
#include <dfb/gl/Objects.h>

#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace dfb::engine {

class ShaderVariants {
public:
    /// `flatSamples`: the shot has one sample per pixel, stored at the pixel (every shader gets
    /// DFB_FLAT_SAMPLES). Reads DFB_GENERIC_SHADERS from the environment.
    void configure(bool flatSamples);

    /// DFB_GENERIC_SHADERS=1: no specialised variants and no footprint pre-pass (a diagnostic, and
    /// the reference the specialised path is tested against).
    bool generic() const { return mGeneric; }

    /// The program of these stage files (the stage from each name's extension) with `defines`,
    /// built on first use; the id stays valid while this object lives. Fails with the driver's log.
    Result<GLuint> variant(const std::vector<const char*>& stages, const std::string& defines = "");

private:
    std::string specialise(std::string_view source, const std::string& defines) const;

    bool mFlat = false;
    bool mGeneric = false;
    std::map<std::string, gl::Program> mPrograms; // by defines and stage names
};

} // namespace dfb::engine
