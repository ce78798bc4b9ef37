#pragma once
#include <stdexcept>
#include <string>

namespace ld::io {

// A file could not be opened or written.
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Malformed input. what() is "file:line: reason" (line 0 when no line applies).
class ParseError : public std::runtime_error {
 public:
  ParseError(const std::string& file, long line, const std::string& reason)
      : std::runtime_error(file + ":" + std::to_string(line) + ": " + reason),
        file_(file),
        line_(line),
        reason_(reason) {}
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] long line() const { return line_; }
  [[nodiscard]] const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  long line_;
  std::string reason_;
};

}  // namespace ld::io
