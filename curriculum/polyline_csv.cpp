#include "curriculum/polyline_csv.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <vector>

#include "curriculum/curriculum_error.h"

namespace ld::curriculum {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i)
    if (i == line.size() || line[i] == ',') {
      out.push_back(trim(line.substr(start, i - start)));
      start = i + 1;
    }
  return out;
}

[[noreturn]] void fail(const std::string& source, long line, const std::string& reason) {
  throw FormatError({source + ":" + std::to_string(line) + ": " + reason});
}

}  // namespace

Polyline parsePolylineCsv(std::string_view text, const std::string& source) {
  Polyline out;
  long lineNo = 0;
  bool header = false, hasStop = false;
  std::size_t pos = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;
  while (pos <= text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = trim(text.substr(pos, end - pos));
    pos = end + 1;
    ++lineNo;
    if (line.empty() || line.front() == '#') continue;
    const auto cols = split(line);
    if (!header) {
      if (cols.size() < 3 || cols.size() > 4 || cols[0] != "x" || cols[1] != "y" || cols[2] != "z" ||
          (cols.size() == 4 && cols[3] != "stop"))
        fail(source, lineNo, "expected the header x,y,z[,stop]");
      header = true;
      hasStop = cols.size() == 4;
      continue;
    }
    const std::size_t want = hasStop ? 4 : 3;
    if (cols.size() != want)
      fail(source, lineNo, std::to_string(cols.size()) + " columns, expected " + std::to_string(want));
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) {
      double v = 0.0;
      const auto col = cols[static_cast<std::size_t>(a)];
      const auto [ptr, ec] = std::from_chars(col.data(), col.data() + col.size(), v);
      if (ec != std::errc() || ptr != col.data() + col.size() || col.empty())
        fail(source, lineNo,
             "column " +
                 std::string(a == 0   ? "x"
                             : a == 1 ? "y"
                                      : "z") +
                 ": '" + std::string(col) + "' is not a number");
      if (!std::isfinite(v))
        fail(source, lineNo, "column " + std::string(a == 0 ? "x" : a == 1 ? "y" : "z") + " is not finite");
      p[a] = v;
    }
    bool stop = false;
    if (hasStop) {
      if (cols[3] == "1")
        stop = true;
      else if (cols[3] != "0" && !cols[3].empty())
        fail(source, lineNo, "column stop: '" + std::string(cols[3]) + "' is not 0 or 1");
    }
    out.push_back({p, stop});
  }
  if (!header) fail(source, lineNo, "empty file: expected the header x,y,z[,stop]");
  if (out.empty()) fail(source, lineNo, "no points");
  out.back().stop = true;
  return out;
}

Polyline readPolylineCsv(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw FormatError({file.string() + ":0: cannot be read"});
  std::ostringstream ss;
  ss << in.rdbuf();
  return parsePolylineCsv(ss.str(), file.string());
}

void writePolylineCsv(const Polyline& p, std::ostream& out) {
  out << "x,y,z,stop\n" << std::setprecision(17);
  for (const auto& q : p) out << q.p.x() << ',' << q.p.y() << ',' << q.p.z() << ',' << (q.stop ? 1 : 0) << '\n';
}

}  // namespace ld::curriculum
