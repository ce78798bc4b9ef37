#include "curriculum/json_check.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "curriculum/curriculum_error.h"

namespace ld::curriculum {

std::string jsonPath(const std::string& parent, const std::string& key) {
  std::string k;
  for (char c : key) k += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
  return parent + "/" + k;
}

std::string jsonPath(const std::string& parent, std::size_t index) { return parent + "/" + std::to_string(index); }

void JsonCheck::error(const std::string& path, const std::string& reason) {
  errors_.push_back(source_ + ": " + (path.empty() ? std::string("/") : path) + ": " + reason);
}

void JsonCheck::throwIfErrors() const {
  if (!errors_.empty()) throw FormatError(errors_);
}

void JsonCheck::onlyKeys(const nlohmann::json& obj, const std::string& path,
                         std::initializer_list<std::string_view> known) {
  if (!obj.is_object()) return;
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (std::find(known.begin(), known.end(), std::string_view(it.key())) == known.end())
      error(jsonPath(path, it.key()), "unknown key (a typo?)");
}

namespace {
const char* typeName(const nlohmann::json& j) { return j.type_name(); }
}  // namespace

const nlohmann::json* JsonCheck::object(const nlohmann::json& obj, const std::string& path, const char* key,
                                        bool required) {
  if (!obj.is_object() || !obj.contains(key)) {
    if (required) error(jsonPath(path, key), "missing (an object is required)");
    return nullptr;
  }
  const nlohmann::json& v = obj.at(key);
  if (!v.is_object()) {
    error(jsonPath(path, key), std::string("must be an object, not ") + typeName(v));
    return nullptr;
  }
  return &v;
}

const nlohmann::json* JsonCheck::array(const nlohmann::json& obj, const std::string& path, const char* key,
                                       bool required) {
  if (!obj.is_object() || !obj.contains(key)) {
    if (required) error(jsonPath(path, key), "missing (an array is required)");
    return nullptr;
  }
  const nlohmann::json& v = obj.at(key);
  if (!v.is_array()) {
    error(jsonPath(path, key), std::string("must be an array, not ") + typeName(v));
    return nullptr;
  }
  return &v;
}

std::optional<std::string> JsonCheck::string(const nlohmann::json& obj, const std::string& path, const char* key,
                                             bool required, bool nonEmpty) {
  if (!obj.is_object() || !obj.contains(key)) {
    if (required) error(jsonPath(path, key), "missing (a string is required)");
    return std::nullopt;
  }
  const nlohmann::json& v = obj.at(key);
  if (!v.is_string()) {
    error(jsonPath(path, key), std::string("must be a string, not ") + typeName(v));
    return std::nullopt;
  }
  std::string s = v.get<std::string>();
  if (nonEmpty && s.find_first_not_of(" \t\r\n") == std::string::npos) {
    error(jsonPath(path, key), "must not be empty");
    return std::nullopt;
  }
  return s;
}

std::optional<double> JsonCheck::number(const nlohmann::json& obj, const std::string& path, const char* key,
                                        bool required, double min, double max) {
  if (!obj.is_object() || !obj.contains(key)) {
    if (required) error(jsonPath(path, key), "missing (a number is required)");
    return std::nullopt;
  }
  const nlohmann::json& v = obj.at(key);
  if (!v.is_number()) {
    error(jsonPath(path, key), std::string("must be a number, not ") + typeName(v));
    return std::nullopt;
  }
  const double d = v.get<double>();
  if (!std::isfinite(d) || d < min || d > max) {
    std::ostringstream os;
    os << d << " is out of range [" << min << ", " << max << "]";
    error(jsonPath(path, key), os.str());
    return std::nullopt;
  }
  return d;
}

std::optional<long long> JsonCheck::integer(const nlohmann::json& obj, const std::string& path, const char* key,
                                            bool required, long long min, long long max) {
  if (!obj.is_object() || !obj.contains(key)) {
    if (required) error(jsonPath(path, key), "missing (an integer is required)");
    return std::nullopt;
  }
  const nlohmann::json& v = obj.at(key);
  if (!v.is_number_integer()) {
    error(jsonPath(path, key), std::string("must be an integer, not ") + (v.is_number() ? "a fraction" : typeName(v)));
    return std::nullopt;
  }
  if (v.is_number_unsigned() && v.get<unsigned long long>() > static_cast<unsigned long long>(max)) {
    error(jsonPath(path, key), std::to_string(v.get<unsigned long long>()) + " is out of range [" +
                                   std::to_string(min) + ", " + std::to_string(max) + "]");
    return std::nullopt;
  }
  const long long i = v.is_number_unsigned() ? static_cast<long long>(v.get<unsigned long long>()) : v.get<long long>();
  if (i < min || i > max) {
    error(jsonPath(path, key),
          std::to_string(i) + " is out of range [" + std::to_string(min) + ", " + std::to_string(max) + "]");
    return std::nullopt;
  }
  return i;
}

std::optional<bool> JsonCheck::boolean(const nlohmann::json& obj, const std::string& path, const char* key,
                                       bool required) {
  if (!obj.is_object() || !obj.contains(key)) {
    if (required) error(jsonPath(path, key), "missing (true or false is required)");
    return std::nullopt;
  }
  const nlohmann::json& v = obj.at(key);
  if (!v.is_boolean()) {
    error(jsonPath(path, key), std::string("must be true or false, not ") + typeName(v));
    return std::nullopt;
  }
  return v.get<bool>();
}

nlohmann::json parseJsonText(const std::string& text, const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Byte offset -> line and column.
    const std::size_t at = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    long line = 1, col = 1;
    for (std::size_t i = 0; i < at; ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string what = e.what();
    // nlohmann's message: "[json.exception.parse_error.101] parse error at line 1, column 2: reason"
    const auto colon = what.find(": ");
    if (colon != std::string::npos) what = what.substr(colon + 2);
    throw FormatError(
        {source + ":" + std::to_string(line) + ":" + std::to_string(col) + ": JSON syntax error: " + what});
  } catch (const nlohmann::json::exception& e) {
    // e.g. a number too large for a double
    std::string what = e.what();
    const auto bracket = what.find("] ");
    if (bracket != std::string::npos) what = what.substr(bracket + 2);
    throw FormatError({source + ": JSON error: " + what});
  }
}

nlohmann::json readJsonFile(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw FormatError({file + ": cannot be read"});
  std::ostringstream ss;
  ss << in.rdbuf();
  return parseJsonText(ss.str(), file);
}

}  // namespace ld::curriculum
