#pragma once
// A bounding-volume hierarchy (axis-aligned boxes) over the triangles of one
// SurfaceMesh, kept in step with the mesh as it deforms and as cutting edits it.
//
// The tree does not own or point to the mesh: every call takes the mesh, which must
// be the one the tree was built for (sizes are checked; misuse throws CollisionError).
//
// Keeping it current:
//  * vertices moved      -> refit() (all boxes, O(n), no allocation) or
//                           refitVertices()/refitFaces() (only the touched paths);
//  * topology edited     -> sync(): compares mesh.topologyVersion() and sizes with
//                           what the tree saw last and updates locally (new faces go
//                           into the leaf of an edge neighbour, faces around new
//                           vertices are refitted, deleted faces leave their leaf);
//                           a full rebuild when the mesh shrank or was compacted
//                           since the last sync, or when local growth made the
//                           tree too deep or it has absorbed as many edits as it
//                           had faces. garbageCollection() renumbers faces, and a
//                           compaction after deletions AND additions can leave the
//                           sizes looking like growth: after garbageCollection()
//                           call build() (CollisionWorld::rebuild) to be safe;
//  * or tell it directly -> insertFaces()/removeFaces()/refitFaces().
// Boxes are tested grown by the tolerance, so boundary hits are never culled.
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/collision/collision_error.h"
#include "sim/collision/segment_triangle.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::collision {

struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  [[nodiscard]] bool empty() const { return !(min.x() <= max.x()); }
  void extend(const Eigen::Vector3d& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const Box& b) {
    min = min.cwiseMin(b.min);
    max = max.cwiseMax(b.max);
  }
  [[nodiscard]] bool overlaps(const Box& b, double pad) const {
    return (min.array() - pad <= b.max.array()).all() && (b.min.array() <= max.array() + pad).all();
  }
};

struct BvhStats {
  std::size_t nodes = 0, leaves = 0, faces = 0, maxDepth = 0, emptyLeaves = 0;
  std::size_t editsSinceBuild = 0;  // faces inserted + removed since the last full build
  std::size_t builds = 0;           // full builds so far (1 after construction)
};

enum class SyncResult { Unchanged, Local, Rebuilt };

// Work done by one query (for benchmarks and tuning).
struct QueryCounters {
  std::size_t nodes = 0;  // boxes tested
  std::size_t faces = 0;  // triangles tested
};

class TriangleBvh {
 public:
  static constexpr int kLeafCapacity = 8;  // faces a leaf can hold before it splits
  static constexpr int kBuildLeafSize = 4;
  static constexpr std::size_t kMaxDepth = 80;  // deeper after local splits -> rebuild

  TriangleBvh() = default;
  explicit TriangleBvh(const mesh::SurfaceMesh& m, const Tolerance& tol = {}) : tol_(tol) { build(m); }

  void build(const mesh::SurfaceMesh& m);
  SyncResult sync(const mesh::SurfaceMesh& m);

  void refit(const mesh::SurfaceMesh& m);
  void refitFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);
  void refitVertices(const mesh::SurfaceMesh& m, std::span<const mesh::Vertex> moved);
  // Faces must be live; already tracked faces are refitted instead.
  void insertFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);
  // Untracked faces are ignored. Faces may already be deleted in the mesh.
  void removeFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);

  // All contacts of segment a->b, sorted and canonical exactly as the brute-force
  // ld::collision::intersectSegment returns them. `out` is cleared first.
  void intersectSegment(const mesh::SurfaceMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        std::vector<SurfaceHit>& out, QueryCounters* counters = nullptr) const;
  [[nodiscard]] std::vector<SurfaceHit> intersectSegment(const mesh::SurfaceMesh& m, const Eigen::Vector3d& a,
                                                         const Eigen::Vector3d& b) const {
    std::vector<SurfaceHit> out;
    intersectSegment(m, a, b, out);
    return out;
  }
  // Appends every tracked face whose box (grown by the tolerance) overlaps `box`.
  void facesOverlapping(const Box& box, std::vector<mesh::Face>& out) const;
  // Appends every tracked face in a leaf whose box (grown by the tolerance) meets
  // triangle (p0, p1, p2) (separating-axis test), for swept queries.
  void facesNearTriangle(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                         std::vector<mesh::Face>& out) const;

  [[nodiscard]] bool tracks(mesh::Face f) const { return f.idx() < faceLeaf_.size() && faceLeaf_[f.idx()] >= 0; }
  // Root box (float precision, rounded outwards).
  [[nodiscard]] Box bounds() const { return nodes_.empty() ? Box{} : boxOf(0); }
  [[nodiscard]] const Tolerance& tolerance() const { return tol_; }
  [[nodiscard]] double pad() const { return pad_; }
  [[nodiscard]] BvhStats stats() const;
  // Invariants against the mesh: every live face in exactly one leaf, no dead face
  // tracked, every box contains its faces and children. Empty string when fine.
  [[nodiscard]] std::string check(const mesh::SurfaceMesh& m) const;

 private:
  // Structure and leaf contents; the boxes live only in hot_ (floats rounded
  // outwards), which keeps refits to one small array.
  struct Node {
    std::int32_t child[2] = {-1, -1};
    std::int32_t parent = -1;
    std::int32_t count = 0;  // faces in a leaf
    std::uint32_t faces[kLeafCapacity] = {};
    [[nodiscard]] bool leaf() const { return child[0] < 0; }
  };
  // The traversal copy of a node: float box rounded outwards, 32 bytes, two per
  // cache line. Written from Node by writeHot() whenever a box is fitted.
  struct HotNode {
    float lo[3], hi[3];
    std::int32_t child[2];
  };
  std::int32_t newNode(std::int32_t parent);
  void fitLeaf(const mesh::SurfaceMesh& m, std::size_t i);
  void fitInner(std::size_t i);
  void fit(const mesh::SurfaceMesh& m, std::size_t i) {
    if (nodes_[i].leaf()) {
      fitLeaf(m, i);
    } else {
      fitInner(i);
    }
  }
  [[nodiscard]] Box boxOf(std::size_t i) const;

  std::int32_t buildRange(const mesh::SurfaceMesh& m, std::uint32_t* first, std::uint32_t* last,
                          std::vector<Eigen::Vector3d>& centroid, std::int32_t parent, std::size_t depth);
  void refitUpwards(const mesh::SurfaceMesh& m, std::vector<std::int32_t>& dirtyLeaves);
  std::int32_t chooseLeaf(const mesh::SurfaceMesh& m, mesh::Face f) const;
  void splitLeaf(const mesh::SurfaceMesh& m, std::int32_t leaf, std::vector<std::int32_t>& dirty);
  std::size_t depthOf(std::int32_t node) const;
  void remember(const mesh::SurfaceMesh& m);
  void checkMesh(const mesh::SurfaceMesh& m, const char* where) const;
  static double effectivePad(const mesh::SurfaceMesh& m, const Tolerance& tol);

  Tolerance tol_;
  double pad_ = 0.0;
  std::vector<Node> nodes_;
  std::vector<HotNode> hot_;
  std::vector<std::uint32_t> mark_;  // refitUpwards scratch: node visited in this epoch
  std::uint32_t epoch_ = 0;
  std::vector<std::int32_t> faceLeaf_;  // per face index: its leaf node, or -1
  std::size_t tracked_ = 0;             // live faces in the tree
  std::size_t editsSinceBuild_ = 0, facesAtBuild_ = 0, builds_ = 0;
  std::size_t maxDepth_ = 0;
  bool needsRebuild_ = false;
  // What the mesh looked like at the last build/sync.
  std::uint64_t seenVersion_ = 0;
  std::size_t seenFaces_ = 0, seenVertices_ = 0, seenDeletedFaces_ = 0;
  bool built_ = false;
};

}  // namespace ld::collision
