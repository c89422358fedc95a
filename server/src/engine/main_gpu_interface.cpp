// dfb-gpu-interface: writes the GLSL side of GpuInterface.h, one #define per table row, to the
// file named by its argument (the build's common_gpu_interface.glsl, included by the shaders),
// so that every binding and location is written once, in the C++ header.
//
//   dfb-gpu-interface OUT.glsl

#include "GpuInterface.h"

#include <cstdio>

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s OUT.glsl\n", argv[0]);
        return 2;
    }
    std::FILE* out = std::fopen(argv[1], "w");
    if (!out) {
        std::perror(argv[1]);
        return 1;
    }
    std::fputs("// Generated at build time from server/src/engine/GpuInterface.h by main_gpu_interface.cpp.\n"
               "// Do not edit: change the header.\n"
               "#ifndef DFB_GPU_INTERFACE_GLSL\n"
               "#define DFB_GPU_INTERFACE_GLSL\n",
               out);
    // Values through long long: the tables hold enumerators of several types and sizeof.
#define DFB_GPU_DEFINE(name, value, what) std::fprintf(out, "#define %s %lld // %s\n", #name, (long long)(value), what);
#define DFB_GPU_GROUP(title, TABLE)      \
    std::fputs("\n// " title "\n", out); \
    TABLE(DFB_GPU_DEFINE)
    DFB_GPU_GROUP("Texture units", DFB_GPU_TEXTURE_UNITS)
    DFB_GPU_GROUP("Shader storage buffers", DFB_GPU_STORAGE_BINDINGS)
    DFB_GPU_GROUP("Uniform blocks", DFB_GPU_UNIFORM_BLOCKS)
    DFB_GPU_GROUP("Uniform locations", DFB_GPU_UNIFORM_LOCATIONS)
    DFB_GPU_GROUP("Vertex attributes and fragment outputs", DFB_GPU_STAGE_INTERFACE)
    DFB_GPU_GROUP("Limits", DFB_GPU_LIMITS)
#undef DFB_GPU_GROUP
#undef DFB_GPU_DEFINE
    std::fputs("\n// Real-valued limits\n", out);
#define DFB_GPU_FLOAT_DEFINE(name, value, what) std::fprintf(out, "#define %s %.9g // %s\n", #name, double(value), what);
    DFB_GPU_FLOAT_LIMITS(DFB_GPU_FLOAT_DEFINE)
#undef DFB_GPU_FLOAT_DEFINE
    std::fputs("\n#endif // DFB_GPU_INTERFACE_GLSL\n", out);
    return std::fclose(out) == 0 ? 0 : 1;
}
