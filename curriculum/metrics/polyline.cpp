#include "curriculum/metrics/polyline.h"

#include <algorithm>
#include <cmath>

namespace ld::curriculum {

std::vector<std::vector<Eigen::Vector3d>> pieces(const Polyline& path) {
  std::vector<std::vector<Eigen::Vector3d>> out;
  std::vector<Eigen::Vector3d> cur;
  for (const PathPoint& q : path) {
    cur.push_back(q.p);
    if (q.stop) {
      out.push_back(std::move(cur));
      cur.clear();
    }
  }
  if (!cur.empty()) out.push_back(std::move(cur));
  return out;
}

std::vector<Eigen::Vector3d> joinedPoints(const Polyline& path) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(path.size());
  for (const PathPoint& q : path) out.push_back(q.p);
  return out;
}

double piecesLength(const Polyline& path) {
  double len = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i)
    if (!path[i - 1].stop) len += (path[i].p - path[i - 1].p).norm();
  return len;
}

Eigen::Vector2d project(const Eigen::Vector3d& p, Plane plane) {
  switch (plane) {
    case Plane::XY:
      return {p.x(), p.y()};
    case Plane::YZ:
      return {p.y(), p.z()};
    case Plane::XZ:
      break;
  }
  return {p.x(), p.z()};
}

Polyline makePolyline(const std::vector<Eigen::Vector3d>& pts) {
  Polyline out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.push_back({p, false});
  if (!out.empty()) out.back().stop = true;
  return out;
}

Polyline densify(const Polyline& path, double spacing) {
  Polyline out;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (i > 0 && !path[i - 1].stop) {
      const Eigen::Vector3d a = path[i - 1].p, b = path[i].p;
      const double len = (b - a).norm();
      const int n = spacing > 0 ? static_cast<int>(std::ceil(len / spacing)) : 1;
      for (int k = 1; k < n; ++k) out.push_back({a + (b - a) * (double(k) / n), false});
    }
    out.push_back(path[i]);
  }
  return out;
}

}  // namespace ld::curriculum
