#pragma once
// Exceptions of the assessment module. Bad task or curriculum files throw
// FormatError with one message per problem, each "file: /json/path: reason".
#include <stdexcept>
#include <string>
#include <vector>

namespace ld::curriculum {

class CurriculumError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class FormatError : public CurriculumError {
 public:
  explicit FormatError(std::vector<std::string> problems)
      : CurriculumError(join(problems)), problems_(std::move(problems)) {}
  [[nodiscard]] const std::vector<std::string>& problems() const { return problems_; }

 private:
  static std::string join(const std::vector<std::string>& p) {
    std::string s;
    for (const auto& x : p) s += (s.empty() ? "" : "\n") + x;
    return s.empty() ? "invalid file" : s;
  }
  std::vector<std::string> problems_;
};

// Misuse of the path-on-tissue API (a point not embedded, a stale mesh).
class PathError : public CurriculumError {
 public:
  using CurriculumError::CurriculumError;
};

}  // namespace ld::curriculum
