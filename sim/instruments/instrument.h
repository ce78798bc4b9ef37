#pragma once
// Instrument poses and the fixed instrument geometry of DESIGN.md: which segments
// of each tool cut or touch tissue. Lengths in millimetres.
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace ld::instruments {

enum class Hand { Left, Right };
enum class Tool { Scalpel, Hook, Grasper };

struct Pose {
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d dir = Eigen::Vector3d(0, 0, -1);  // along the shaft, handle -> tip
  Eigen::Vector3d up = Eigen::Vector3d(1, 0, 0);    // perpendicular to dir
  double jaw = 0.0;                                 // 0 closed .. 1 open
  bool pedal = false;
};

struct Settings {
  double scalpelEdgeLength = 20.0;
  double hookElbowOffset = 4.0;  // B = tip - offset * up
  double hookFootLength = 6.0;   // second edge B - length * dir -> B
  double grasperJawLength = 10.0;
  double grasperMaxHalfAngleDeg = 30.0;
};

enum class SegmentRole { CuttingEdge, Jaw, Shaft };

struct Segment {
  Eigen::Vector3d a, b;
  SegmentRole role = SegmentRole::CuttingEdge;
};

// The segments of a tool at a pose, in the order the DESIGN.md geometry lists them.
std::vector<Segment> segments(Tool tool, const Pose& pose, const Settings& s = {});

std::string_view toString(Hand h);
std::string_view toString(Tool t);
// Returns false when the text names no hand/tool.
bool parseHand(std::string_view text, Hand& out);
bool parseTool(std::string_view text, Tool& out);

}  // namespace ld::instruments
