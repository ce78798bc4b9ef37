#include "sim/instruments/instrument.h"

#include <cmath>
#include <numbers>

namespace ld::instruments {

std::vector<Segment> segments(Tool tool, const Pose& p, const Settings& s) {
  std::vector<Segment> out;
  switch (tool) {
    case Tool::Scalpel:
      out.push_back({p.tip, p.tip - s.scalpelEdgeLength * p.dir, SegmentRole::CuttingEdge});
      break;
    case Tool::Hook: {
      const Eigen::Vector3d elbow = p.tip - s.hookElbowOffset * p.up;
      out.push_back({elbow, p.tip, SegmentRole::CuttingEdge});
      out.push_back({elbow - s.hookFootLength * p.dir, elbow, SegmentRole::CuttingEdge});
      break;
    }
    case Tool::Grasper: {
      // Jaws open symmetrically in the dir/up plane about the pivot; closed, both end at tip.
      const Eigen::Vector3d pivot = p.tip - s.grasperJawLength * p.dir;
      const double half = std::clamp(p.jaw, 0.0, 1.0) * s.grasperMaxHalfAngleDeg * std::numbers::pi / 180.0;
      for (double sign : {1.0, -1.0}) {
        const Eigen::Vector3d d = std::cos(half) * p.dir + sign * std::sin(half) * p.up;
        out.push_back({pivot, pivot + s.grasperJawLength * d, SegmentRole::Jaw});
      }
      break;
    }
  }
  return out;
}

std::string_view toString(Hand h) { return h == Hand::Left ? "left" : "right"; }

std::string_view toString(Tool t) {
  switch (t) {
    case Tool::Scalpel:
      return "scalpel";
    case Tool::Hook:
      return "hook";
    case Tool::Grasper:
      return "grasper";
  }
  return "?";
}

bool parseHand(std::string_view text, Hand& out) {
  if (text == "left") return out = Hand::Left, true;
  if (text == "right") return out = Hand::Right, true;
  return false;
}

bool parseTool(std::string_view text, Tool& out) {
  if (text == "scalpel") return out = Tool::Scalpel, true;
  if (text == "hook") return out = Tool::Hook, true;
  if (text == "grasper") return out = Tool::Grasper, true;
  return false;
}

}  // namespace ld::instruments
