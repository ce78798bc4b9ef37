#pragma once
// The polyline CSV of DESIGN.md (metric tools): header `x,y,z[,stop]`, one point per
// row, `stop=1` ends a piece.
#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>

#include "curriculum/metrics/polyline.h"

namespace ld::curriculum {

// Throws FormatError with one "file:line: reason" message.
Polyline parsePolylineCsv(std::string_view text, const std::string& source);
Polyline readPolylineCsv(const std::filesystem::path& file);
void writePolylineCsv(const Polyline& p, std::ostream& out);

}  // namespace ld::curriculum
