#pragma once
// CSV writing (RFC 4180 quoting) for exports opened in spreadsheets.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace ld::db {

// Quotes when needed. Text cells starting with = + - @ or a tab are prefixed with ' so that
// a spreadsheet shows a name like "=HYPERLINK(...)" as text instead of running it.
std::string csvText(const std::string& s);
std::string csvNumber(double v);  // shortest round-trip form; empty for NaN
std::string csvRow(const std::vector<std::string>& cells);

// Flattens nested objects to dotted keys ("deviation.xy"); arrays are kept as JSON text.
void flattenJson(const nlohmann::json& j, const std::string& prefix,
                 std::vector<std::pair<std::string, nlohmann::json>>& out);

}  // namespace ld::db
