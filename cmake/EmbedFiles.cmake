# dfb_embed_files(TARGET <lib> FUNCTION <ns::fn> BASE_DIR <dir> FILES <f>... [VALIDATE_GLSL]
#                 [INCLUDE_DIRS <dir>...] [DEPENDS <file>...])
#
# Embeds text files into a static library as raw string literals, looked up by file name through
#   std::string_view <ns::fn>(std::string_view name)   // empty view if unknown
# `#include "x.glsl"` lines are resolved textually (GLSL has no includes), and with VALIDATE_GLSL
# each resolved shader is checked by glslangValidator at build time, so a shader error fails the
# build (filament's matc + resgen, STYLE.md). An included name is looked for beside the including
# file, then in INCLUDE_DIRS (generated files, such as the engine's common_gpu_interface.glsl,
# which are also listed in DEPENDS so that they are made first).
set(DFB_EMBED_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/embed.cmake)

function(dfb_embed_files)
    cmake_parse_arguments(E "VALIDATE_GLSL" "TARGET;FUNCTION;BASE_DIR" "FILES;INCLUDE_DIRS;DEPENDS" ${ARGN})
    set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/embed_${E_TARGET})
    set(out_cpp ${out_dir}/${E_TARGET}.cpp)
    set(deps "")
    foreach(f ${E_FILES})
        list(APPEND deps ${E_BASE_DIR}/${f})
    endforeach()
    # Any file in BASE_DIR may be included, so depend on all of them.
    file(GLOB all_in_dir ${E_BASE_DIR}/*)
    set(validate 0)
    if(E_VALIDATE_GLSL)
        set(validate 1)
    endif()
    string(REPLACE ";" "|" files_arg "${E_FILES}")
    string(REPLACE ";" "|" include_arg "${E_INCLUDE_DIRS}")
    add_custom_command(
        OUTPUT ${out_cpp}
        COMMAND ${CMAKE_COMMAND} -DOUT=${out_cpp} -DOUT_DIR=${out_dir} -DFUNC=${E_FUNCTION}
                -DBASE_DIR=${E_BASE_DIR} "-DFILES=${files_arg}" "-DINCLUDE_DIRS=${include_arg}" -DVALIDATE=${validate}
                -DGLSLANG=${GLSLANG_VALIDATOR} -P ${DFB_EMBED_SCRIPT}
        DEPENDS ${deps} ${all_in_dir} ${E_DEPENDS} ${DFB_EMBED_SCRIPT}
        COMMENT "Embedding (and validating) files for ${E_TARGET}"
        VERBATIM)
    add_library(${E_TARGET} STATIC ${out_cpp})
    set_target_properties(${E_TARGET} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()
