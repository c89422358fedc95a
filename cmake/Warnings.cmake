# One INTERFACE target carries the warning flags for our code (pbrt's pbrt_warnings).
add_library(dfb_warnings INTERFACE)
target_compile_options(dfb_warnings INTERFACE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Wunused
    -Woverloaded-virtual -Wformat=2 -Wimplicit-fallthrough
    # GCC 12 reports std::string concatenation as overlapping memcpy (GCC bug 105329).
    $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>)
if(DFB_WARNINGS_AS_ERRORS)
    target_compile_options(dfb_warnings INTERFACE -Werror)
endif()
add_library(dfb::warnings ALIAS dfb_warnings)
