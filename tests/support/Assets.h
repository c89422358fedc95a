#pragma once
// Test support: the third-party scenes of tests/assets (DFB_ASSETS_DIR), kept in the repository
// with their licences: a test that needs them fails, not skips, when they are missing.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace dfb::test {
inline std::string assetPath(const std::string& name) { return std::string(DFB_ASSETS_DIR) + "/" + name; }
inline bool haveAssets() { return std::filesystem::exists(assetPath("SHA256SUMS")); }
} // namespace dfb::test

#define DFB_REQUIRE_ASSETS()                                                                       \
    do {                                                                                           \
        if (!dfb::test::haveAssets()) FAIL() << "asset scenes not found in " DFB_ASSETS_DIR;     \
    } while (false)
