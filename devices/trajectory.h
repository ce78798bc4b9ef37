#pragma once
// The trajectory CSV of DESIGN.md: what the scripted device reads, what a recorded
// attempt replays and what tests feed.
//   t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal
#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "devices/device_error.h"
#include "sim/instruments/instrument.h"

namespace ld::devices {

struct PoseSample {
  double t = 0.0;  // seconds
  instruments::Hand hand = instruments::Hand::Right;
  instruments::Tool tool = instruments::Tool::Hook;
  instruments::Pose pose;
};

struct Trajectory {
  std::vector<PoseSample> samples;  // non-decreasing t
  [[nodiscard]] double duration() const;
  // Samples of one hand, in order.
  [[nodiscard]] std::vector<PoseSample> hand(instruments::Hand h) const;
};

// Throws ParseError ("file:line: reason") on a missing header, wrong column count,
// a non-number, NaN, an unknown hand or tool, decreasing time, or a zero direction.
Trajectory readTrajectoryCsv(const std::filesystem::path& file);
Trajectory parseTrajectoryCsv(std::string_view text, const std::string& sourceName);
void writeTrajectoryCsv(const Trajectory& tr, std::ostream& out);

}  // namespace ld::devices
