#include "curriculum/polyline_csv.h"

#include <iomanip>
#include <ostream>
#include <vector>

#include "curriculum/curriculum_error.h"
#include "devices/csv_text.h"

namespace ld::curriculum {
namespace {

[[noreturn]] void fail(const std::string& source, long line, const std::string& reason) {
  throw FormatError({source + ":" + std::to_string(line) + ": " + reason});
}

}  // namespace

Polyline parsePolylineCsv(std::string_view text, const std::string& source) {
  Polyline out;
  bool header = false, hasStop = false;
  const long lines = devices::csv::forEachRecord(text, [&](long lineNo, std::string_view line) {
    const auto cols = devices::csv::splitFields(line);
    if (!header) {
      if (cols.size() < 3 || cols.size() > 4 || cols[0] != "x" || cols[1] != "y" || cols[2] != "z" ||
          (cols.size() == 4 && cols[3] != "stop"))
        fail(source, lineNo, "expected the header x,y,z[,stop]");
      header = true;
      hasStop = cols.size() == 4;
      return;
    }
    const std::size_t want = hasStop ? 4 : 3;
    if (cols.size() != want)
      fail(source, lineNo, std::to_string(cols.size()) + " columns, expected " + std::to_string(want));
    static constexpr const char* kAxis[3] = {"x", "y", "z"};
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) {
      const auto col = cols[static_cast<std::size_t>(a)];
      const auto status = devices::csv::parseNumber(col, p[a]);
      if (status != devices::csv::NumberStatus::Ok)
        fail(source, lineNo, devices::csv::numberProblem(kAxis[a], col, status));
    }
    bool stop = false;
    if (hasStop) {
      if (cols[3] == "1")
        stop = true;
      else if (cols[3] != "0" && !cols[3].empty())
        fail(source, lineNo, "column stop: '" + std::string(cols[3]) + "' is not 0 or 1");
    }
    out.push_back({p, stop});
  });
  if (!header) fail(source, lines, "empty file: expected the header x,y,z[,stop]");
  if (out.empty()) fail(source, lines, "no points");
  out.back().stop = true;
  return out;
}

Polyline readPolylineCsv(const std::filesystem::path& file) {
  std::string text;
  if (!devices::csv::readFile(file, text)) throw FormatError({file.string() + ":0: cannot be read"});
  return parsePolylineCsv(text, file.string());
}
void writePolylineCsv(const Polyline& p, std::ostream& out) {
  out << "x,y,z,stop\n" << std::setprecision(17);
  for (const auto& q : p) out << q.p.x() << ',' << q.p.y() << ',' << q.p.z() << ',' << (q.stop ? 1 : 0) << '\n';
}

}  // namespace ld::curriculum
