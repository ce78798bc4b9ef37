#pragma once
// Several tissue objects (each a SurfaceMesh with its own BVH) and the queries the
// simulation loop asks per step: every hit of every instrument segment on every
// object and layer, and the swept contacts between two samples.
//
// The world does not own the meshes: add() keeps a pointer, so a mesh must stay
// where it is while registered (keep tissue objects in unique_ptr or a stable
// container), or be rebound with rebind() after it moved. A freed piece from
// cutting is simply added as a new object.
//
// Topology follows automatically: every query first brings each object's tree up
// to date from its mesh's edit journal (TriangleBvh::sync, local per edited face)
// when the mesh's topology changed. Vertex motion is not versioned: call refit()
// (all boxes, O(n)) or refitVertices() after the physics moved vertices. Queries
// are const but may update the trees this way, so a world is not to be queried
// from several threads at once.
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "sim/collision/bvh.h"
#include "sim/collision/collision_error.h"
#include "sim/collision/segment_triangle.h"
#include "sim/collision/swept.h"
#include "sim/instruments/instrument.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::collision {

using ObjectId = std::uint32_t;

struct ObjectHit {
  ObjectId object = 0;
  SurfaceHit hit;
};

struct SegmentContacts {
  std::size_t index = 0;  // position in instruments::segments(tool, pose)
  instruments::Segment segment;
  std::vector<ObjectHit> hits;  // all objects, all layers, by t along segment.a -> segment.b
};

struct ObjectSweep {
  ObjectId object = 0;
  SweptContacts contacts;
};

struct SegmentSweep {
  std::size_t index = 0;
  instruments::Segment before, after;
  std::vector<ObjectSweep> objects;  // only objects the swept surface touches, by id
};

class CollisionWorld {
 public:
  explicit CollisionWorld(const Tolerance& tol = {}) : tol_(tol) {}

  ObjectId add(const mesh::SurfaceMesh& m);
  void remove(ObjectId id);
  // The same mesh, moved to another address (no rebuild; the next sync() catches up).
  void rebind(ObjectId id, const mesh::SurfaceMesh& m);
  [[nodiscard]] bool contains(ObjectId id) const;
  [[nodiscard]] std::vector<ObjectId> objects() const;
  [[nodiscard]] const mesh::SurfaceMesh& mesh(ObjectId id) const;
  [[nodiscard]] const TriangleBvh& bvh(ObjectId id) const;
  [[nodiscard]] TriangleBvh& bvh(ObjectId id);

  // Per step, after physics moved vertices and cutting edited topology:
  void sync();   // topology of every object (local; see TriangleBvh::sync); queries do it too
  void refit();  // boxes of every object, O(triangles), no allocation
  void update() { sync(), refit(); }
  // Only the boxes around these vertices of one object (an active region).
  void refitVertices(ObjectId id, std::span<const mesh::Vertex> moved);
  void refitVertices(ObjectId id, std::span<const std::uint32_t> moved);  // vertex indices
  // Fat boxes for an object that moves a little every step (TriangleBvh::setMotionMargin),
  // then refitMoved(id) after each step instead of refit().
  void setMotionMargin(ObjectId id, double margin);
  std::size_t refitMoved(ObjectId id, double maxMove = std::numeric_limits<double>::infinity());
  // After mesh.garbageCollection() returned `c`: the tree renumbered through c's maps
  // (TriangleBvh::remap), no full rebuild unless most faces went.
  SyncResult remap(ObjectId id, const mesh::Compaction& c);
  // Full rebuild of one object's tree.
  void rebuild(ObjectId id);

  void intersectSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b, std::vector<ObjectHit>& out) const;
  [[nodiscard]] std::vector<ObjectHit> intersectSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
    std::vector<ObjectHit> out;
    intersectSegment(a, b, out);
    return out;
  }
  // The first contact along a->b over all objects: intersectSegment(a, b).front()
  // (lowest object id on a tie), found near-to-far with pruning.
  [[nodiscard]] std::optional<ObjectHit> firstHit(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  // Whether a->b touches any object (stops at the first triangle hit).
  [[nodiscard]] bool anyHit(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  // Every segment of the tool at the pose (DESIGN.md geometry), with its hits.
  [[nodiscard]] std::vector<SegmentContacts> query(instruments::Tool tool, const instruments::Pose& pose,
                                                   const instruments::Settings& settings = {}) const;
  // Swept contacts of every segment between two consecutive poses of one tool
  // (sweepSettings.tol is replaced by the world's tolerance).
  [[nodiscard]] std::vector<SegmentSweep> sweep(instruments::Tool tool, const instruments::Pose& before,
                                                const instruments::Pose& after,
                                                const instruments::Settings& settings = {},
                                                const SweepSettings& sweepSettings = {}) const;

 private:
  struct Entry {
    ObjectId id = 0;
    const mesh::SurfaceMesh* mesh = nullptr;
    mutable TriangleBvh bvh;  // brought up to date by const queries (see above)
    const TriangleBvh& current() const {
      if (bvh.needsSync(*mesh)) bvh.sync(*mesh);
      return bvh;
    }
  };
  [[nodiscard]] const Entry& entry(ObjectId id) const;
  Entry& entry(ObjectId id);

  Tolerance tol_;
  std::vector<Entry> entries_;  // by ascending id
  ObjectId next_ = 1;
};

}  // namespace ld::collision
