#pragma once
// Helpers for the sim/io tests: parse inline text, write scratch files.
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "sim/io/mesh_formats.h"

namespace ld::io::test {

// A scratch folder removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() / ("ld_io_" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  std::filesystem::path write(const std::string& name, std::string_view content) const {
    const auto p = path_ / name;
    std::ofstream(p, std::ios::binary).write(content.data(), static_cast<std::streamsize>(content.size()));
    return p;
  }

 private:
  std::filesystem::path path_;
};

inline TriangleSoup soupOf(Format f, std::string_view text, ImportReport* rep = nullptr, bool weld = false) {
  return parseSoup(f, text, "test", ReadOptions{weld}, rep);
}

// The ParseError message thrown by `fn`, or "" when it does not throw one.
template <class F>
std::string parseErrorOf(F&& fn) {
  try {
    fn();
  } catch (const ParseError& e) {
    return e.what();
  }
  return "";
}

inline Eigen::Vector3d faceNormal(const TriangleSoup& s, const Triangle& t) {
  return (s.points[t[1]] - s.points[t[0]]).cross(s.points[t[2]] - s.points[t[0]]);
}

inline double signedVolume(const TriangleSoup& s) {
  double v = 0;
  for (const auto& t : s.triangles) v += s.points[t[0]].dot(s.points[t[1]].cross(s.points[t[2]])) / 6.0;
  return v;
}

}  // namespace ld::io::test
