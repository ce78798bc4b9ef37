// Fuzz target: the polyline CSV reader refuses bad input with FormatError naming
// source:line, never crashes, and reads back what it writes.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "curriculum/curriculum_error.h"
#include "curriculum/polyline_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ld::curriculum;
  const std::string text(reinterpret_cast<const char*>(data), size);
  Polyline p;
  try {
    p = parsePolylineCsv(text, "fuzz.csv");
  } catch (const FormatError& e) {
    if (std::string(e.what()).rfind("fuzz.csv:", 0) != 0) std::abort();  // the place is named
    return 0;
  }
  if (p.empty() || !p.back().stop) std::abort();
  for (const auto& q : p)
    if (!q.p.allFinite()) std::abort();
  std::ostringstream out;
  writePolylineCsv(p, out);
  const Polyline again = parsePolylineCsv(out.str(), "again");
  if (again.size() != p.size()) std::abort();
  for (std::size_t i = 0; i < p.size(); ++i)
    if (again[i].p != p[i].p || again[i].stop != p[i].stop) std::abort();
  return 0;
}
