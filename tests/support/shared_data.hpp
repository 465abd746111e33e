// Locating ../shared (model, data clips) from tests. Tests that need it call
// DESSLAM_REQUIRE_SHARED(path) which skips with a clear message when it is missing, so the
// rest of the suite still passes on a machine without the shared folder.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace desslam::test {

inline std::filesystem::path sharedDir() {
  if (const char* env = std::getenv("DESSLAM_SHARED_DIR"); env != nullptr && *env != '\0')
    return std::filesystem::path(env);
  return std::filesystem::path("..") / "shared";
}

inline std::filesystem::path sourceDir() {
  if (const char* env = std::getenv("DESSLAM_SOURCE_DIR"); env != nullptr && *env != '\0')
    return std::filesystem::path(env);
  return std::filesystem::current_path();
}

inline std::filesystem::path clipDir(const std::string& clip) {
  return sharedDir() / "data" / "clips" / clip;
}

}  // namespace desslam::test

// Skips the current test (with the reason printed) when `path` does not exist.
#define DESSLAM_REQUIRE_SHARED(path)                                                        \
  do {                                                                                      \
    if (!std::filesystem::exists(path)) {                                                   \
      GTEST_SKIP() << "shared data missing: " << (path)                                     \
                   << " (put ../shared beside the project, or set DESSLAM_SHARED_DIR)";     \
    }                                                                                       \
  } while (0)
