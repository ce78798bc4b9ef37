#include "curriculum/authoring.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/collision/segment_triangle.h"

namespace ld::curriculum {

std::optional<SurfaceLocation> castRay(const mesh::SurfaceMesh& m, const Ray& ray, double* tOut) {
  if (m.nFaces() == 0 || !(ray.dir.squaredNorm() > 0)) return std::nullopt;
  const mesh::BoundingBox bb = m.bounds();
  // A segment long enough to leave the model's box from the ray origin.
  const double reach = (bb.center() - ray.origin).norm() + bb.extent().norm() + 1.0;
  const double len = reach / ray.dir.norm();
  const Eigen::Vector3d b = ray.origin + len * ray.dir;
  std::optional<SurfaceLocation> best;
  double bestT = std::numeric_limits<double>::infinity();
  for (mesh::Face f : m.faces()) {
    const auto& v = m.vertices(f);
    const collision::SegTriResult r =
        collision::intersectSegmentTriangle(ray.origin, b, m.position(v[0]), m.position(v[1]), m.position(v[2]));
    if (!r.hit() || r.t >= bestT) continue;
    bestT = r.t;
    Eigen::Vector3d bary = r.bary.cwiseMax(0.0);
    const double s = bary.sum();
    bary = s > 0 ? Eigen::Vector3d(bary / s) : Eigen::Vector3d(1, 0, 0);
    best = SurfaceLocation{f, bary};
  }
  if (best && tOut) *tOut = bestT * len;
  return best;
}

Polyline projectOntoSurface(const mesh::SurfaceMesh& m, const std::vector<Ray>& rays) {
  Polyline out;
  for (const Ray& r : rays) {
    auto hit = castRay(m, r);
    if (!hit) {
      if (!out.empty()) out.back().stop = true;
      continue;
    }
    out.push_back({position(m, *hit), false});
  }
  if (!out.empty()) out.back().stop = true;
  return out;
}

Polyline resamplePath(const Polyline& path, double spacing) {
  Polyline out;
  for (const auto& piece : pieces(path)) {
    std::vector<double> s(piece.size(), 0.0);
    for (std::size_t i = 1; i < piece.size(); ++i) s[i] = s[i - 1] + (piece[i] - piece[i - 1]).norm();
    const double L = s.back();
    const int n = spacing > 0 && L > 0 ? std::max(1, static_cast<int>(std::ceil(L / spacing - 1e-9))) : 1;
    std::size_t seg = 0;
    for (int k = 0; k <= n; ++k) {
      const double target = L * k / n;
      while (seg + 2 < piece.size() && s[seg + 1] < target) ++seg;
      Eigen::Vector3d p = piece[seg];
      if (piece.size() > 1) {
        const double l = s[seg + 1] - s[seg];
        const double u = l > 0 ? std::clamp((target - s[seg]) / l, 0.0, 1.0) : 0.0;
        p = piece[seg] + u * (piece[seg + 1] - piece[seg]);
      }
      if (k == n) p = piece.back();
      out.push_back({p, false});
      if (piece.size() == 1) break;
    }
    out.back().stop = true;
  }
  return out;
}

Polyline smoothPath(const Polyline& path, int iterations, double lambda) {
  Polyline out;
  for (const auto& piece : pieces(path)) {
    std::vector<Eigen::Vector3d> p = piece;
    for (int it = 0; it < iterations; ++it) {
      std::vector<Eigen::Vector3d> q = p;
      for (std::size_t i = 1; i + 1 < p.size(); ++i) q[i] = p[i] + lambda * (0.5 * (p[i - 1] + p[i + 1]) - p[i]);
      p = std::move(q);
    }
    for (const auto& x : p) out.push_back({x, false});
    out.back().stop = true;
  }
  return out;
}

Polyline snapToSurface(const mesh::SurfaceMesh& m, const Polyline& path) {
  Polyline out = path;
  mesh::Face hint;
  for (auto& q : out) {
    double d = 0;
    SurfaceLocation loc = closestLocationNear(m, hint, q.p, 3, &d);
    double dAll = d;
    if (d > 1.0) loc = closestLocation(m, q.p, &dAll);
    hint = loc.face;
    q.p = position(m, loc);
  }
  return out;
}

}  // namespace ld::curriculum
