#pragma once
// Programmer-error checks (pbrt util/check.h). DFB_CHECK is always on; DFB_DCHECK only in debug
// builds. Expected failures (bad files, bad messages) are values, see Result.h, never checks.

#include <cstdio>
#include <cstdlib>

#define DFB_CHECK(cond)                                                                            \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);          \
            std::abort();                                                                          \
        }                                                                                          \
    } while (false)

#ifdef NDEBUG
#define DFB_DCHECK(cond)                                                                           \
    do {                                                                                           \
    } while (false)
#else
#define DFB_DCHECK(cond) DFB_CHECK(cond)
#endif
