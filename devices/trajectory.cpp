#include "devices/trajectory.h"

#include "devices/csv_text.h"

#include <iomanip>
#include <ostream>

namespace ld::devices {

namespace {

constexpr const char* kHeader = "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal";
constexpr std::size_t kColumns = 14;

}  // namespace

double Trajectory::duration() const { return samples.empty() ? 0.0 : samples.back().t - samples.front().t; }

std::vector<PoseSample> Trajectory::hand(instruments::Hand h) const {
  std::vector<PoseSample> out;
  for (const auto& s : samples)
    if (s.hand == h) out.push_back(s);
  return out;
}

Trajectory parseTrajectoryCsv(std::string_view text, const std::string& name) {
  Trajectory tr;
  bool headerSeen = false;
  static const char* columnNames[kColumns] = {"t",     "hand",  "tool", "tip_x", "tip_y", "tip_z", "dir_x",
                                              "dir_y", "dir_z", "up_x", "up_y",  "up_z",  "jaw",   "pedal"};
  const long lines = csv::forEachRecord(text, [&](long lineNo, std::string_view line) {
    const auto cols = csv::splitFields(line);
    if (!headerSeen) {
      bool ok = cols.size() == kColumns;
      for (std::size_t i = 0; ok && i < kColumns; ++i) ok = cols[i] == columnNames[i];
      if (!ok) throw ParseError(name, lineNo, std::string("expected header '") + kHeader + "'");
      headerSeen = true;
      return;
    }
    if (cols.size() != kColumns)
      throw ParseError(name, lineNo,
                       "expected " + std::to_string(kColumns) + " columns, found " + std::to_string(cols.size()));
    double v[kColumns] = {};
    for (std::size_t i = 0; i < kColumns; ++i) {
      if (i == 1 || i == 2) continue;
      const auto status = csv::parseNumber(cols[i], v[i]);
      if (status != csv::NumberStatus::Ok)
        throw ParseError(name, lineNo, csv::numberProblem(columnNames[i], cols[i], status));
    }
    PoseSample s;
    s.t = v[0];
    if (!instruments::parseHand(cols[1], s.hand))
      throw ParseError(name, lineNo, "hand '" + std::string(cols[1]) + "' is not left or right");
    if (!instruments::parseTool(cols[2], s.tool))
      throw ParseError(name, lineNo, "tool '" + std::string(cols[2]) + "' is not scalpel, hook or grasper");
    s.pose.tip = {v[3], v[4], v[5]};
    Eigen::Vector3d dir(v[6], v[7], v[8]), up(v[9], v[10], v[11]);
    if (dir.norm() < 1e-9) throw ParseError(name, lineNo, "dir is a zero vector");
    if (up.norm() < 1e-9) throw ParseError(name, lineNo, "up is a zero vector");
    dir.normalize();
    // Keep up perpendicular to dir, as the instrument geometry assumes.
    up -= up.dot(dir) * dir;
    if (up.norm() < 1e-6) throw ParseError(name, lineNo, "up is parallel to dir");
    s.pose.dir = dir;
    s.pose.up = up.normalized();
    if (v[12] < 0.0 || v[12] > 1.0) throw ParseError(name, lineNo, "jaw must lie in [0, 1]");
    s.pose.jaw = v[12];
    if (v[13] != 0.0 && v[13] != 1.0) throw ParseError(name, lineNo, "pedal must be 0 or 1");
    s.pose.pedal = v[13] != 0.0;
    if (!tr.samples.empty() && s.t < tr.samples.back().t)
      throw ParseError(
          name, lineNo,
          "time goes backwards (" + std::to_string(s.t) + " after " + std::to_string(tr.samples.back().t) + ")");
    tr.samples.push_back(s);
  });
  if (!headerSeen) throw ParseError(name, lines == 0 ? 1 : lines, "empty file: no header");
  return tr;
}

Trajectory readTrajectoryCsv(const std::filesystem::path& file) {
  std::string text;
  if (!csv::readFile(file, text)) throw ParseError(file.string(), 0, "cannot open file");
  return parseTrajectoryCsv(text, file.string());
}

void writeTrajectoryCsv(const Trajectory& tr, std::ostream& out) {
  out << kHeader << '\n' << std::setprecision(17);
  for (const auto& s : tr.samples) {
    const auto& p = s.pose;
    out << s.t << ',' << instruments::toString(s.hand) << ',' << instruments::toString(s.tool) << ',' << p.tip.x()
        << ',' << p.tip.y() << ',' << p.tip.z() << ',' << p.dir.x() << ',' << p.dir.y() << ',' << p.dir.z() << ','
        << p.up.x() << ',' << p.up.y() << ',' << p.up.z() << ',' << p.jaw << ',' << (p.pedal ? 1 : 0) << '\n';
  }
}

}  // namespace ld::devices
