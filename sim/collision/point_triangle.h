#pragma once
// Closest point of a segment or a triangle to a point, and the distance from a point to a mesh's
// surface near it (through the BVH). Used where the cutter asks whether a stretch
// between two crossings already lies on the surface.
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "sim/collision/bvh.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::collision {

// The point of segment [a, b] nearest to p (a when the segment has no length).
[[nodiscard]] Eigen::Vector3d closestPointOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                                    const Eigen::Vector3d& b);

// The point of triangle (a, b, c) nearest to p (found by the region of the triangle's
// plane p projects into: a corner, an edge or the inside). A triangle without area
// gives the nearest point of its longest side.
[[nodiscard]] Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                                     const Eigen::Vector3d& b, const Eigen::Vector3d& c);

// The nearest point to p on the faces the BVH tracks within `radius` of p; an invalid
// face and an infinite distance when none is that near. `scratch` is reused between calls.
struct NearestOnSurface {
  mesh::Face face;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double distance = std::numeric_limits<double>::infinity();
};
[[nodiscard]] NearestOnSurface nearestOnSurface(const mesh::SurfaceMesh& m, const TriangleBvh& bvh,
                                                const Eigen::Vector3d& p, double radius,
                                                std::vector<mesh::Face>& scratch);

}  // namespace ld::collision
