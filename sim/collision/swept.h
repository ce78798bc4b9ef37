#pragma once
// Swept test between two consecutive samples of one instrument segment, so that a
// fast stroke or a blade sliding in between samples misses no triangle (the limit
// the thesis notes in its 4.6).
//
// Method: the segment moves from (a0, b0) to (a1, b1) with its ends on straight
// lines; the surface it sweeps is the bilinear patch through the four points. The
// patch is cut into N strips in time (N = 1 for a planar motion; more when the
// motion twists, so that the triangles stay within `maxTwistDeviation` of the
// patch), each strip into two triangles. Every mesh edge of a face in a BVH leaf
// that a triangle meets (separating-axis test against the leaf box) is tested
// against that triangle with the same tolerant segment–triangle test, and the
// patch's boundary (the segment at both samples and the paths of both
// ends) is tested against the mesh. A mesh face touches the swept surface exactly
// when one of its edges crosses the surface or the surface's boundary crosses the
// face, so the faces reported are all the faces touched (up to the tolerance).
#include <vector>

#include <Eigen/Core>

#include "sim/collision/bvh.h"
#include "sim/collision/segment_triangle.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::collision {

struct SweptEdgeCrossing {
  mesh::Edge edge;
  double edgeT = 0.0;  // along the edge, from vertex(edge, 0) (0) to vertex(edge, 1) (1)
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double time = 0.0;      // 0 at the first sample, 1 at the second (patch coordinate)
  double along = 0.0;     // 0 at end a of the segment, 1 at end b (patch coordinate)
  bool coplanar = false;  // the edge runs in the swept surface; edgeT is where that starts
};

struct SweptContacts {
  std::vector<mesh::Face> faces;                 // every face the swept surface touches, ascending
  std::vector<SweptEdgeCrossing> edgeCrossings;  // each crossing mesh edge once, by (time, along)
  std::vector<SurfaceHit> before, after;         // segment a0->b0 and a1->b1
  std::vector<SurfaceHit> pathA, pathB;          // paths of the ends, a0->a1 and b0->b1
};

struct SweepSettings {
  Tolerance tol;
  double maxTwistDeviation = 0.05;  // mm: triangles vs. the bilinear patch
  int maxStrips = 64;
};

// With bvh == nullptr every face is a candidate (brute force, for tests).
SweptContacts sweepSegment(const mesh::SurfaceMesh& m, const TriangleBvh* bvh, const Eigen::Vector3d& a0,
                           const Eigen::Vector3d& b0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b1,
                           const SweepSettings& settings = {});

// Number of strips the patch is cut into (exposed for tests).
int sweepStrips(const Eigen::Vector3d& a0, const Eigen::Vector3d& b0, const Eigen::Vector3d& a1,
                const Eigen::Vector3d& b1, const SweepSettings& settings);

}  // namespace ld::collision
