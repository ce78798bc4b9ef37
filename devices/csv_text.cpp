#include "devices/csv_text.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace ld::devices::csv {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> splitFields(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == ',') {
      out.push_back(trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return out;
}

NumberStatus parseNumber(std::string_view field, double& out) {
  if (field.empty()) return NumberStatus::NotANumber;
  const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), out);
  if (ec != std::errc() || ptr != field.data() + field.size()) return NumberStatus::NotANumber;
  return std::isfinite(out) ? NumberStatus::Ok : NumberStatus::NotFinite;
}

std::string numberProblem(std::string_view column, std::string_view field, NumberStatus status) {
  switch (status) {
    case NumberStatus::Ok:
      return {};
    case NumberStatus::NotANumber:
      return "column " + std::string(column) + ": '" + std::string(field) + "' is not a number";
    case NumberStatus::NotFinite:
      return "column " + std::string(column) + " is not finite";
  }
  return {};
}

bool readFile(const std::filesystem::path& file, std::string& out) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  std::ostringstream ss;
  ss << in.rdbuf();
  out = std::move(ss).str();
  return true;
}

}  // namespace ld::devices::csv
