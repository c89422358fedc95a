# One INTERFACE target carries the warning flags for our code (pbrt's pbrt_warnings).
add_library(dfb_warnings INTERFACE)
target_compile_options(dfb_warnings INTERFACE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Wunused
    -Woverloaded-virtual -Wnull-dereference -Wformat=2 -Wimplicit-fallthrough)
if(DFB_WARNINGS_AS_ERRORS)
    target_compile_options(dfb_warnings INTERFACE -Werror)
endif()
add_library(dfb::warnings ALIAS dfb_warnings)
