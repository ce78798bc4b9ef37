#pragma once
// Line and field handling shared by our small CSV formats (trajectories here, drawn
// and cut polylines in curriculum/), so that every reader treats byte-order marks,
// comments, blank lines, spaces and bad numbers the same way.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace ld::devices::csv {

// Without leading spaces/tabs and trailing spaces/tabs/CR.
[[nodiscard]] std::string_view trim(std::string_view s);

// The comma-separated fields of a line, each trimmed (an empty line gives one field).
[[nodiscard]] std::vector<std::string_view> splitFields(std::string_view line);

// Calls fn(lineNumber, line) for every line that is neither blank nor a '#' comment,
// trimmed, after an optional UTF-8 byte-order mark. Returns the number of lines read,
// for "empty file" messages that point at the end.
template <class Fn>
long forEachRecord(std::string_view text, Fn&& fn) {
  long lineNo = 0;
  std::size_t pos = text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;
  while (pos <= text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = trim(text.substr(pos, end - pos));
    pos = end + 1;
    ++lineNo;
    if (line.empty() || line.front() == '#') continue;
    fn(lineNo, line);
  }
  return lineNo;
}

enum class NumberStatus { Ok, NotANumber, NotFinite };
// The whole field as a finite double.
[[nodiscard]] NumberStatus parseNumber(std::string_view field, double& out);
// "column x: 'abc' is not a number" / "column x is not finite" ("" for Ok).
[[nodiscard]] std::string numberProblem(std::string_view column, std::string_view field, NumberStatus status);

// The file's bytes; false when it cannot be opened.
[[nodiscard]] bool readFile(const std::filesystem::path& file, std::string& out);

}  // namespace ld::devices::csv
