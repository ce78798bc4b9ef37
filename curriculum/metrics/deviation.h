#pragma once
// Deviation of the cut path from the drawn path (DESIGN.md, Metrics): in each
// coordinate plane, the integral of |winding number| of the loop formed by the drawn
// path forward, the segment from its end to the cut's end, the cut backward and the
// segment back to the drawn path's start. Computed exactly (no sampling of the plane).
#include <vector>

#include <Eigen/Core>

#include "curriculum/metrics/polyline.h"

namespace ld::curriculum {

struct Deviation {
  double xy = 0.0, yz = 0.0, xz = 0.0;  // mm²
  [[nodiscard]] double total() const { return xy + yz + xz; }
  [[nodiscard]] double plane(Plane p) const { return p == Plane::XY ? xy : p == Plane::YZ ? yz : xz; }
  double& plane(Plane p) { return p == Plane::XY ? xy : p == Plane::YZ ? yz : xz; }
};

struct Segment2 {
  Eigen::Vector2d a, b;
};

// ∫|w(p)| dA over the plane for the closed curve(s) made of `segs` (each loop's
// segments must close up; segments of several loops may be mixed). Exact up to
// floating-point error: the plane is cut into vertical slabs at every vertex and
// crossing abscissa; inside a slab the edges do not cross, so |w| is constant between
// neighbours and each gap is a trapezoid.
double absWindingArea(const std::vector<Segment2>& segs);

// The closed polygon `loop` (last point joined to the first).
double absWindingArea(const std::vector<Eigen::Vector2d>& loop);
void appendLoop(const std::vector<Eigen::Vector2d>& loop, std::vector<Segment2>& segs);

// Winding number of the closed polygon around p (for checks and tools).
int windingNumber(const std::vector<Eigen::Vector2d>& loop, const Eigen::Vector2d& p);

// The loop of DESIGN.md in one plane: drawn forward, cut backward (pieces joined).
std::vector<Eigen::Vector2d> deviationLoop(const Polyline& drawn, const Polyline& cut, Plane plane);

Deviation deviation(const Polyline& drawn, const Polyline& cut);

// An attempt that cut nothing. DESIGN.md's loop with an empty cut path is the drawn
// path closed by the segment from its end back to its start; that alone is zero for
// a straight path, which would read as perfect. The uncut path therefore also counts
// with the strip the band allows on both sides: per plane, the loop's ∫|w| plus
// 2 · band · (length of the drawn path's pieces projected on the plane). A cut that
// stays within the band everywhere deviates less than this in every plane.
Deviation deviationWithoutCut(const Polyline& drawn, double band);

// The thesis's method (6.2.1): triangles stitched between the two point lists in the
// way groove triangles are made, split at crossings, unsigned areas summed. Kept for
// comparison only: it depends on how the paths are sampled.
Deviation deviationThesis(const Polyline& drawn, const Polyline& cut);
double deviationThesis2d(const std::vector<Eigen::Vector2d>& d, const std::vector<Eigen::Vector2d>& a);

}  // namespace ld::curriculum
