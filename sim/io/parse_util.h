#pragma once
// Small helpers shared by the text parsers (internal to sim/io).
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include "sim/io/io_error.h"

namespace ld::io::detail {

// A token as it may appear in a message: at most 40 characters, control bytes escaped.
inline std::string shown(std::string_view tok) {
  std::string s;
  for (char c : tok.substr(0, 40)) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 32 || u >= 127) {
      static const char* hex = "0123456789abcdef";
      s += "\\x";
      s += hex[u >> 4];
      s += hex[u & 15];
    } else {
      s += c;
    }
  }
  if (tok.size() > 40) s += "...";
  return "'" + s + "'";
}

// A decimal floating-point number (a leading '+' allowed). False for anything else,
// including out-of-range values, "nan" and "inf".
inline bool parseDouble(std::string_view tok, double& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty() || tok.front() == '+' || tok.front() == 'n' || tok.front() == 'N' || tok.front() == 'i' ||
      tok.front() == 'I')
    return false;
  const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size() && std::isfinite(out);
}

inline bool parseInt(std::string_view tok, long long& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty() || tok.front() == '+') return false;
  const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

// Whitespace-separated tokens with line numbers. `#` starts a comment to the end of
// the line when comments are enabled.
class Scanner {
 public:
  Scanner(std::string_view text, std::string name, bool hashComments)
      : s_(text), name_(std::move(name)), comments_(hashComments) {}

  // Next token on the current line, or empty at the end of the line.
  std::string_view nextOnLine() {
    skipBlanks();
    return token();
  }
  // Next token, crossing lines; empty at the end of the input.
  std::string_view next() {
    for (;;) {
      skipBlanks();
      if (pos_ >= s_.size()) return {};
      if (s_[pos_] == '\n') {
        // The final newline does not start a line: errors at the end of the input name
        // the file's last line.
        if (pos_ + 1 >= s_.size()) return {};
        ++pos_;
        ++line_;
        continue;
      }
      return token();
    }
  }
  // Skips the rest of the current line including its newline.
  void skipLine() {
    while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
    if (pos_ < s_.size()) {
      ++pos_;
      if (pos_ < s_.size()) ++line_;  // see next(): the final newline starts no line
    }
  }
  // Rest of the current line (without comment handling), then moves past it.
  std::string_view restOfLine() {
    const std::size_t b = pos_;
    while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
    std::string_view r = s_.substr(b, pos_ - b);
    if (!r.empty() && r.back() == '\r') r.remove_suffix(1);
    return r;
  }
  [[nodiscard]] bool atEnd() {
    skipBlanks();
    return pos_ >= s_.size();
  }
  [[nodiscard]] long line() const { return line_; }
  [[nodiscard]] std::size_t offset() const { return pos_; }
  void setOffset(std::size_t p, long line) {
    pos_ = p;
    line_ = line;
  }
  [[nodiscard]] const std::string& name() const { return name_; }

  [[noreturn]] void fail(const std::string& reason) const { throw ParseError(name_, line_, reason); }

  double number(std::string_view tok, const char* what) const {
    double v = 0;
    if (tok.empty())
      fail(std::string("unexpected end of ") + (pos_ >= s_.size() ? "file" : "line") + ", expected " + what);
    if (!parseDouble(tok, v)) {
      if (tok == "nan" || tok == "NaN" || tok == "-nan" || tok == "inf" || tok == "-inf")
        fail(std::string("non-finite ") + what + " " + shown(tok));
      fail(std::string("expected ") + what + ", found " + shown(tok));
    }
    return v;
  }
  long long integer(std::string_view tok, const char* what) const {
    long long v = 0;
    if (tok.empty())
      fail(std::string("unexpected end of ") + (pos_ >= s_.size() ? "file" : "line") + ", expected " + what);
    if (!parseInt(tok, v)) fail(std::string("expected ") + what + ", found " + shown(tok));
    return v;
  }

 private:
  void skipBlanks() {
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
        ++pos_;
      } else if (comments_ && c == '#') {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
      } else {
        break;
      }
    }
  }
  std::string_view token() {
    const std::size_t b = pos_;
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v' || (comments_ && c == '#')) break;
      ++pos_;
    }
    return s_.substr(b, pos_ - b);
  }

  std::string_view s_;
  std::string name_;
  bool comments_;
  std::size_t pos_ = 0;
  long line_ = 1;
};

}  // namespace ld::io::detail
