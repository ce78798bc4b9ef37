#pragma once
#include <stdexcept>
#include <string>

namespace ld::devices {

// Bad input in a device file (trajectory, recording). what() is "file:line: reason".
class ParseError : public std::runtime_error {
 public:
  ParseError(const std::string& file, long line, const std::string& reason)
      : std::runtime_error(file + ":" + std::to_string(line) + ": " + reason), file_(file), line_(line) {}
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] long line() const { return line_; }

 private:
  std::string file_;
  long line_;
};

}  // namespace ld::devices
