#pragma once
// Paths on tissue (thesis 6.3): the drawn path and the cut path as points embedded
// in the surface mesh (a face and barycentric coordinates), so they move with the
// tissue as it deforms; re-embedded without moving when their triangles are
// subdivided; the drawn path is broken (a stop) where the cut crosses it.
#include <cstdint>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "curriculum/metrics/polyline.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::curriculum {

struct SurfaceLocation {
  mesh::Face face;
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();  // weights of mesh.vertices(face)
};

Eigen::Vector3d position(const mesh::SurfaceMesh& m, const SurfaceLocation& loc);
// Closest point of triangle (a, b, c) to p, as barycentric weights.
Eigen::Vector3d closestBarycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& c);
// Closest point of the surface to p (every live face; O(faces)). Invalid face for an
// empty mesh. `distance` receives the distance.
SurfaceLocation closestLocation(const mesh::SurfaceMesh& m, const Eigen::Vector3d& p, double* distance = nullptr);
// Closest point searched from `start` over faces reachable through shared vertices,
// up to `rings` rings; falls back to the whole mesh when start is not live.
SurfaceLocation closestLocationNear(const mesh::SurfaceMesh& m, mesh::Face start, const Eigen::Vector3d& p, int rings,
                                    double* distance = nullptr);

// Face property naming the original triangle a face comes from (split faces inherit
// it), so that "one piece per original triangle" survives subdivision.
inline constexpr const char* kOriginFaceProp = "f:ld_origin";
// Tags every live face with its own index (call once when a task starts).
void tagOriginalFaces(mesh::SurfaceMesh& m);
std::int64_t originalFace(const mesh::SurfaceMesh& m, mesh::Face f);

class TissuePath {
 public:
  struct Point {
    SurfaceLocation loc;
    bool stop = false;  // ends a piece as drawn
    bool cut = false;   // the cut crossed the path right after this point
    // On a piece the cut freed from this mesh: no longer embedded here; keeps the
    // world position it had when freed (positions() report it there).
    bool freed = false;
  };

  // Embeds world points; throws PathError when a point is farther than maxDistance
  // from the surface.
  static TissuePath embed(const mesh::SurfaceMesh& m, const Polyline& world, double maxDistance = 1.0);

  // Current positions; a crossing cut ends a piece too.
  [[nodiscard]] Polyline positions(const mesh::SurfaceMesh& m) const;
  // The path as drawn (pieces as authored, ignoring the cut's breaks).
  [[nodiscard]] Polyline drawnPositions(const mesh::SurfaceMesh& m) const;
  [[nodiscard]] const std::vector<Point>& points() const { return pts_; }

  // After topology edits: `before` are the world positions taken just before
  // (positions(m) of the old mesh). Each point is found again in its old face or
  // around it, at the same place.
  void reembed(const mesh::SurfaceMesh& m, const std::vector<Eigen::Vector3d>& before);
  [[nodiscard]] std::vector<Eigen::Vector3d> worldPoints(const mesh::SurfaceMesh& m) const;
  // After garbageCollection().
  void remap(const mesh::Compaction& c);

  // Follows the topology edits of `m` since embed() or the last call, read from the
  // mesh's edit journal: only points whose face was edited are embedded again, at
  // the world position they had (cached), in the edited faces or the two rings
  // around their old face; the cost depends on the edit, not on the path or mesh
  // size. A new layout (garbage collection, as a separation does) keeps every point
  // on the descendants of its original triangle (kOriginFaceProp, which survives
  // compaction): one pass over the faces, then a few faces per point; points whose
  // triangle no longer holds them went with a freed piece and are marked `freed`.
  // Without the origin tags a new layout re-embeds by a global search. Call
  // refreshWorld() after the tissue moved (physics) and before the next edit.
  // Returns the number of points embedded again (or freed).
  std::size_t followEdits(const mesh::SurfaceMesh& m);
  void refreshWorld(const mesh::SurfaceMesh& m);
  // Points that needed a search of the whole mesh (layout changes, lost points).
  [[nodiscard]] std::size_t globalSearches() const { return global_; }
  // Points now on freed pieces.
  [[nodiscard]] std::size_t freedPoints() const;

  // The cut moved from a to b on the surface (normal n there): every path segment it
  // crosses is broken (thesis 6.3.3). Returns the number of crossings.
  int cutAcross(const mesh::SurfaceMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                const Eigen::Vector3d& n, double maxGap = 1.0);
  // The same on the tissue at rest: a and b are cut points in the tissue's rest frame
  // (the model as loaded), compared with the path where it was drawn (the positions
  // embed() found), whatever the tissue's motion since. A path drawn on the tissue is
  // crossed where the blade crosses it on the tissue, not in the world.
  int cutAcrossAtRest(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& n,
                      double maxGap = 1.0);
  // The path segments (index of their first point) the same cut crosses at rest, in
  // path order, none marked: the caller decides which crossings stand (markCut).
  [[nodiscard]] std::vector<std::size_t> crossingsAtRest(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                                         const Eigen::Vector3d& n, double maxGap = 1.0) const;
  void markCut(std::size_t segment);
  // Distance of p to the path's segments that cutAcross / cutAcrossAtRest test (a cut
  // point on the path touches it; whether the cut crossed is known when it leaves).
  [[nodiscard]] double distance(const mesh::SurfaceMesh& m, const Eigen::Vector3d& p) const;
  [[nodiscard]] double distanceAtRest(const Eigen::Vector3d& p) const;

 private:
  void startTracking(const mesh::SurfaceMesh& m);
  void relocate(const mesh::SurfaceMesh& m, std::size_t i, std::span<const mesh::Face> edited);
  std::size_t relayout(const mesh::SurfaceMesh& m);
  [[nodiscard]] Eigen::Vector3d pointAt(const mesh::SurfaceMesh& m, std::size_t i) const;

  template <class At>
  [[nodiscard]] std::vector<std::size_t> crossedWith(const At& at, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                                     const Eigen::Vector3d& n, double maxGap) const;

  template <class At>
  [[nodiscard]] double distanceWith(const At& at, const Eigen::Vector3d& p) const;

  std::vector<Point> pts_;
  std::vector<Eigen::Vector3d> rest_;  // where each point was drawn (embed's positions)
  // Edit following: cached world positions, the points of each face, the journal cursor.
  std::vector<Eigen::Vector3d> world_;
  std::vector<std::int64_t> origin_;  // original triangle of each point's face
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> byFace_;
  std::uint64_t layout_ = 0;
  std::size_t journalFaces_ = 0, global_ = 0;
};

// Records the cut path (thesis 6.3.1): the points where the cutting edge meets the
// surface, simplified to one straight piece per original triangle (its first and
// last point there), with a stop at every loss of contact.
class CutPathRecorder {
 public:
  void contact(const mesh::SurfaceMesh& m, mesh::Face f, const Eigen::Vector3d& p);
  void loseContact();
  [[nodiscard]] const Polyline& path() const { return path_; }
  // The path including the pending last point (for display while cutting).
  [[nodiscard]] Polyline currentPath() const;

 private:
  Polyline path_;
  bool open_ = false, pending_ = false;
  std::int64_t origin_ = -1;
  Eigen::Vector3d last_ = Eigen::Vector3d::Zero();
};

// 2-D proper crossing of two segments projected on the plane normal to n.
bool segmentsCross(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& d, const Eigen::Vector3d& n, double maxGap);

}  // namespace ld::curriculum
