#pragma once
// Test support: the third-party scenes of ../shared/assets (DFB_ASSETS_DIR). CI has them beside
// the checkout; a checkout without them skips those tests, saying so.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace dfb::test {
inline std::string assetPath(const std::string& name) { return std::string(DFB_ASSETS_DIR) + "/" + name; }
inline bool haveAssets() { return std::filesystem::exists(assetPath("SHA256SUMS")); }
} // namespace dfb::test

#define DFB_REQUIRE_ASSETS()                                                                       \
    do {                                                                                           \
        if (!dfb::test::haveAssets()) GTEST_SKIP() << "asset scenes not found in " DFB_ASSETS_DIR; \
    } while (false)
