#pragma once
// Small validation helper for the task and curriculum files: every problem is
// recorded as "file: /json/path: reason" and checking goes on, so an author sees all
// problems at once.
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace ld::curriculum {

class JsonCheck {
 public:
  explicit JsonCheck(std::string source) : source_(std::move(source)) {}
  void error(const std::string& path, const std::string& reason);
  [[nodiscard]] const std::vector<std::string>& errors() const { return errors_; }
  [[nodiscard]] bool ok() const { return errors_.empty(); }
  [[nodiscard]] const std::string& source() const { return source_; }
  // Throws FormatError when problems were found.
  void throwIfErrors() const;

  // Reports keys of `obj` not in `known`.
  void onlyKeys(const nlohmann::json& obj, const std::string& path, std::initializer_list<std::string_view> known);
  // The member, or nullptr (an error when required, or when present with the wrong type).
  const nlohmann::json* object(const nlohmann::json& obj, const std::string& path, const char* key, bool required);
  const nlohmann::json* array(const nlohmann::json& obj, const std::string& path, const char* key, bool required);
  std::optional<std::string> string(const nlohmann::json& obj, const std::string& path, const char* key, bool required,
                                    bool nonEmpty = true);
  std::optional<double> number(const nlohmann::json& obj, const std::string& path, const char* key, bool required,
                               double min, double max);
  std::optional<long long> integer(const nlohmann::json& obj, const std::string& path, const char* key, bool required,
                                   long long min, long long max);
  std::optional<bool> boolean(const nlohmann::json& obj, const std::string& path, const char* key, bool required);

 private:
  std::string source_;
  std::vector<std::string> errors_;
};

// Parses JSON text; a syntax error throws FormatError "file:line:column: reason".
nlohmann::json parseJsonText(const std::string& text, const std::string& source);
// Reads and parses a file (FormatError when unreadable).
nlohmann::json readJsonFile(const std::string& file);

std::string jsonPath(const std::string& parent, const std::string& key);
std::string jsonPath(const std::string& parent, std::size_t index);

}  // namespace ld::curriculum
