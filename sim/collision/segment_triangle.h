#pragma once
// Segment–triangle intersection with explicit tolerances (Möller–Trumbore
// formulation: the segment parameter from the two end heights over the triangle's
// plane, barycentric coordinates from the triple products of the hit point).
//
// Contract:
//  * `tol` is a distance (mm). Effective tolerance = tol.absolute + tol.relative *
//    (largest |coordinate| of the five points), so it follows float precision.
//  * Coplanar: both segment ends lie within tol of the triangle's plane. Then the
//    result is Coplanar with the overlap [t, tExit] of the segment with the
//    triangle (grown by tol), or None when they do not overlap. Never a random hit.
//  * Otherwise the segment hits when it reaches the plane (an end within tol of
//    the plane counts: endTouch says which) at a point within tol of the triangle.
//    The point is classified by its in-plane distances to the three edges: all
//    farther than tol -> Interior; one within tol -> OnEdge; two -> OnVertex.
//  * Local indices follow ld::mesh: edge i joins corner i and corner (i+1)%3.
//  * A triangle with (almost) zero area (twice area <= tol * longest edge) gives
//    None, with degenerate = true unless the segment is clearly off its plane.
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "sim/mesh/surface_mesh.h"

namespace ld::collision {

struct Tolerance {
  double absolute = 1e-9;   // mm
  double relative = 1e-12;  // times the largest |coordinate| involved
};

enum class HitKind : std::uint8_t { None, Interior, OnEdge, OnVertex, Coplanar };

enum class EndTouch : std::uint8_t { None, Start, End };  // which segment end lies on the plane

struct SegTriResult {
  HitKind kind = HitKind::None;
  int local = -1;                                   // OnEdge: edge index 0..2; OnVertex: corner index 0..2; else -1
  double t = 0.0;                                   // along a->b in [0,1]; Coplanar: start of the overlap
  double tExit = 0.0;                               // Coplanar: end of the overlap; else equal to t
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();   // weights of corners 0,1,2 at `point` (may be
                                                    // slightly outside [0,1], by at most tol/altitude)
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // a + t (b - a), on the segment
  int direction = 0;                                // +1 segment goes from the front (normal side) to the back, -1 the
                                                    // reverse, 0 touching only (an end on the plane) or coplanar
  EndTouch endTouch = EndTouch::None;
  bool degenerate = false;  // zero-area triangle (kind is None)

  [[nodiscard]] bool hit() const { return kind != HitKind::None; }
};

// Segment a->b against triangle (v0, v1, v2) (counter-clockwise seen from the front).
// A zero-length segment is a point: hit when within tol of the triangle (t = 0).
SegTriResult intersectSegmentTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& v0,
                                      const Eigen::Vector3d& v1, const Eigen::Vector3d& v2, const Tolerance& tol = {});

// One contact of a segment with a mesh.
struct SurfaceHit {
  mesh::Face face;                                 // the face the hit was computed on
  HitKind kind = HitKind::None;                    // never None
  int local = -1;                                  // as SegTriResult, relative to `face`
  mesh::Edge edge;                                 // OnEdge: the mesh edge
  mesh::Vertex vertex;                             // OnVertex: the mesh vertex
  double t = 0.0;                                  // along a->b
  double tExit = 0.0;                              // Coplanar: end of the overlap
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();  // relative to mesh.vertices(face)
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  int direction = 0;
  EndTouch endTouch = EndTouch::None;
};

// Sorts hits by t and merges duplicates that come from faces sharing an edge or a
// vertex, so that every geometric contact is reported once:
//  * an OnVertex contact is reported once per mesh vertex (on the lowest-index face
//    around it), an OnEdge contact once per mesh edge (on the lower-index face);
//  * an Interior or OnEdge hit whose face/edge touches a vertex (or an Interior hit
//    whose face has an edge) that is also hit within `mergeDistance` of it is
//    dropped in favour of the lower-dimensional feature (this removes double
//    reports when the tolerance bands of two neighbouring faces disagree);
//  * Coplanar hits are kept, one per face (each face's own overlap interval).
// Deterministic: the same input hits in any order give the same output.
void canonicalizeHits(const mesh::SurfaceMesh& m, std::vector<SurfaceHit>& hits, double mergeDistance);

// Every contact of segment a->b with the live faces of m, sorted by t, canonical as
// above (mergeDistance = defaultMergeDistance(a, b, tol)). Brute force: O(faces). For tests and as a
// fallback; the BVH gives the same answer faster.
std::vector<SurfaceHit> intersectSegment(const mesh::SurfaceMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                         const Tolerance& tol = {});

// The result of the exact test on face f as a SurfaceHit (edge/vertex filled in from
// the face); kind None when r is no hit.
SurfaceHit toSurfaceHit(const mesh::SurfaceMesh& m, mesh::Face f, const SegTriResult& r);

// Hit of one face as a SurfaceHit (kind None when no hit); fills edge/vertex.
SurfaceHit intersectSegmentFace(const mesh::SurfaceMesh& m, mesh::Face f, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const Tolerance& tol = {});

// Default merge distance used by intersectSegment: 16 x the effective tolerance at
// the segment's coordinates, and at least 1e-7 of the segment length.
double defaultMergeDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Tolerance& tol);

// Effective tolerance for points of magnitude up to `scale` (largest |coordinate|).
inline double effectiveTolerance(const Tolerance& tol, double scale) { return tol.absolute + tol.relative * scale; }

}  // namespace ld::collision
