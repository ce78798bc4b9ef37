#pragma once
// Where the tests find third-party data (../shared/data) and the bundled resources.
// No Eigen here (test_support.h has it): the CLI tests, which do not link Eigen, include this.
#include <cstdlib>
#include <filesystem>
#include <string>

namespace ld::test {

inline std::filesystem::path sharedDataDir() {
  if (const char* env = std::getenv("LD_SHARED_DATA")) return env;
  return LD_SHARED_DATA_DIR;
}

inline std::filesystem::path resourcesDir() {
  if (const char* env = std::getenv("LD_RESOURCES")) return env;
  return LD_RESOURCES_DIR;
}

// Path of a file in ../shared/data, or empty when the folder is absent.
inline std::filesystem::path sharedData(const std::string& rel) {
  auto p = sharedDataDir() / rel;
  return std::filesystem::exists(p) ? p : std::filesystem::path();
}

}  // namespace ld::test
