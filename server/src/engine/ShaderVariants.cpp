#include "ShaderVariants.h"

#include <cstdlib>

namespace dfb::shaders {
std::string_view serverShader(std::string_view name);
}

namespace dfb::engine {

void ShaderVariants::configure(bool flatSamples) {
    mFlat = flatSamples;
    if (const char* generic = std::getenv("DFB_GENERIC_SHADERS")) mGeneric = *generic && std::string_view(generic) != "0";
}

// Inserts `defines` after the #version line; flat buffers also get DFB_FLAT_SAMPLES.
std::string ShaderVariants::specialise(std::string_view source, const std::string& defines) const {
    std::string out(source);
    const size_t eol = out.find('\n');
    out.insert(eol == std::string::npos ? out.size() : eol + 1, (mFlat ? "#define DFB_FLAT_SAMPLES 1\n" : "") + defines);
    return out;
}

Result<GLuint> ShaderVariants::variant(const std::vector<const char*>& stages, const std::string& defines) {
    std::string key = defines;
    for (const char* s : stages) key += std::string("|") + s;
    if (auto it = mPrograms.find(key); it != mPrograms.end()) return it->second.id();
    std::vector<std::string> texts; // ShaderSource holds views: keep the texts alive
    texts.reserve(stages.size());
    std::vector<gl::ShaderSource> sources;
    for (const char* name : stages) {
        const std::string_view n(name);
        const GLenum stage = n.ends_with(".vert")   ? GL_VERTEX_SHADER
                             : n.ends_with(".tesc") ? GL_TESS_CONTROL_SHADER
                             : n.ends_with(".tese") ? GL_TESS_EVALUATION_SHADER
                             : n.ends_with(".comp") ? GL_COMPUTE_SHADER
                                                    : GL_FRAGMENT_SHADER;
        texts.push_back(specialise(shaders::serverShader(name), defines));
        sources.push_back({stage, name, texts.back()});
    }
    auto p = gl::buildProgram(sources);
    if (!p) return p.error();
    const GLuint id = p->id();
    mPrograms.emplace(std::move(key), std::move(p.value()));
    return id;
}

} // namespace dfb::engine
