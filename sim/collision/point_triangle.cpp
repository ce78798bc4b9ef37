#include "sim/collision/point_triangle.h"

#include <algorithm>
#include <limits>

namespace ld::collision {

using Eigen::Vector3d;

Vector3d closestPointOnSegment(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double l2 = ab.squaredNorm();
  if (!(l2 > 0.0)) return a;
  return a + std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) * ab;
}

Vector3d closestPointOnTriangle(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  // Without area the regions below are not defined: take the sides.
  const double l2 = std::max(ab.squaredNorm(), ac.squaredNorm());
  if (!(ab.cross(ac).squaredNorm() > 1e-24 * l2 * l2)) {
    const Vector3d candidates[3] = {closestPointOnSegment(p, a, b), closestPointOnSegment(p, b, c),
                                    closestPointOnSegment(p, c, a)};
    return *std::min_element(std::begin(candidates), std::end(candidates), [&](const Vector3d& x, const Vector3d& y) {
      return (x - p).squaredNorm() < (y - p).squaredNorm();
    });
  }
  // Corner regions first, then edge regions (by the signs of the projections), else
  // the inside, from the barycentric coordinates of the projection.
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double sum = va + vb + vc;
  return a + (vb / sum) * ab + (vc / sum) * ac;
}

NearestOnSurface nearestOnSurface(const mesh::SurfaceMesh& m, const TriangleBvh& bvh, const Vector3d& p, double radius,
                                  std::vector<mesh::Face>& scratch) {
  Box box;
  box.extend(p - Vector3d::Constant(radius));
  box.extend(p + Vector3d::Constant(radius));
  scratch.clear();
  bvh.facesOverlapping(box, scratch);
  NearestOnSurface best;
  for (const mesh::Face f : scratch) {
    if (m.isDeleted(f)) continue;
    const auto& v = m.vertices(f);
    const Vector3d q = closestPointOnTriangle(p, m.position(v[0]), m.position(v[1]), m.position(v[2]));
    if (const double d = (q - p).norm(); d < best.distance) best = {f, q, d};
  }
  return best.distance <= radius ? best : NearestOnSurface{};
}

}  // namespace ld::collision
