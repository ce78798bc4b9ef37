#pragma once
// A bounding-volume hierarchy (axis-aligned boxes) over the triangles of one
// SurfaceMesh, kept in step with the mesh as it deforms and as cutting edits it.
//
// The tree does not own or point to the mesh: every call takes the mesh, which must
// be the one the tree was built for (sizes are checked; misuse throws CollisionError).
//
// Layout (see README.md): 32-byte nodes (float box rounded outwards and grown by
// the tolerance pad, then one index and one count), the two children of a node
// adjacent; leaves of at most 4 faces whose references (face and its three vertex
// indices, 16 bytes each) fill one 64-byte block, so a leaf test reads one cache
// line of indices plus the vertex positions. Binned-SAH build.
//
// Keeping it current:
//  * vertices moved      -> refit() (all boxes, O(n), no allocation) or
//                           refitVertices()/refitFaces() (only the touched paths);
//  * topology edited     -> sync(): compares the mesh's versions and sizes with what
//                           the tree saw last and updates locally (new faces go into
//                           a free slot of the leaf of an edge neighbour, a full leaf
//                           splits in two, faces whose corners changed are re-read
//                           and refitted, deleted faces leave their leaf); a full
//                           rebuild only when the mesh was compacted or shrank, the
//                           tree became too deep, or the local edits since the last
//                           build exceed kRebuildFraction of its faces;
//  * or tell it directly -> insertFaces()/removeFaces()/refitFaces().
// After garbageCollection() sync() notices and rebuilds (build() is always safe).
// Boxes are tested grown by the tolerance, so boundary hits are never culled.
#include <cfloat>
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
  std::size_t editsSinceBuild = 0;  // faces inserted + removed + re-read since the last full build
  std::size_t builds = 0;           // full builds so far (1 after construction)
  std::size_t bytes = 0;            // memory of nodes, leaf blocks and maps
};

enum class SyncResult { Unchanged, Local, Rebuilt };

// Work done by one query (for benchmarks and tuning).
struct QueryCounters {
  std::size_t nodes = 0;  // boxes tested
  std::size_t faces = 0;  // triangles tested (cheap rejection included)
  std::size_t exact = 0;  // triangles that needed the full tolerant test
};

class TriangleBvh {
 public:
  static constexpr int kLeafCapacity = 4;  // faces per leaf block (one cache line)
  static constexpr int kBuildLeafSize = 4;
  static constexpr std::size_t kMaxDepth = 80;     // deeper after local splits -> rebuild
  static constexpr double kRebuildFraction = 0.5;  // local edits / faces at build -> rebuild

  TriangleBvh() = default;
  explicit TriangleBvh(const mesh::SurfaceMesh& m, const Tolerance& tol = {}) : tol_(tol) { build(m); }

  void build(const mesh::SurfaceMesh& m);
  SyncResult sync(const mesh::SurfaceMesh& m);
  // True when the mesh's topology differs from what the tree last saw (cheap).
  [[nodiscard]] bool needsSync(const mesh::SurfaceMesh& m) const;

  // Every box from the current positions: one pass over the leaf blocks (each reads
  // the distinct corners cached with it, not the mesh's connectivity) and one over
  // the inner nodes, children before parents. O(nodes + corners), no allocation.
  void refit(const mesh::SurfaceMesh& m);
  void refitFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);
  // Only the leaves around the moved vertices and their ancestors, each once, in
  // proportion to the region (no sort, no pass over the tree). The index overload
  // takes a vertex index list as is (e.g. physics' awake list in active-region mode).
  void refitVertices(const mesh::SurfaceMesh& m, std::span<const mesh::Vertex> moved);
  void refitVertices(const mesh::SurfaceMesh& m, std::span<const std::uint32_t> moved);

  // Fat boxes for tissue that moves a little every step (physics without an active
  // region): with a margin > 0 every leaf box is fitted around the positions its
  // corners had when they were last anchored, and a vertex is re-anchored (its leaves
  // refitted) only once it has moved farther than the margin from its anchor (per
  // coordinate). Queries grow every box by how far the vertices may have moved since
  // (tracked from the passes and the callers' bounds; at most the margin, 0 right after
  // a full refit). Queries stay exact (they test the true positions); only the pruning
  // boxes are larger. Default 0: tight boxes, behaviour unchanged. Takes effect at
  // once (a full refit).
  void setMotionMargin(const mesh::SurfaceMesh& m, double margin);
  [[nodiscard]] double motionMargin() const { return margin_; }
  [[nodiscard]] std::size_t motionPasses() const { return motionPasses_; }  // refitMoved calls that read the vertices
  // Every vertex may have moved: with a margin, one pass over the vertices re-anchors
  // those that moved farther than half the margin (or the whole margin when maxMove
  // is not finite) and refits their leaves; when `maxMove`, a bound on how far (per
  // coordinate) any vertex moved since the last call, fits in the slack the last pass
  // left, nothing is read at all. Without a margin: refit(). Returns the vertices
  // re-anchored (all of them for a refit()).
  std::size_t refitMoved(const mesh::SurfaceMesh& m, double maxMove = std::numeric_limits<double>::infinity());
  // For tissue whose physics sums each vertex group's moves (physics::Dynamics::
  // groupTravel(): per group of `groupSize` consecutive vertices (v in group
  // v / groupSize), a bound on how far any of them moved, per coordinate, since the
  // entry was last set; `past`: the groups whose entry went past travelLimit() since
  // the last call). A vertex stays within kTravelReach of the margin plus its group's
  // entry from its anchor, so only the listed groups (and the vertices past the groups)
  // are looked at: one farther than the reach is re-anchored, and the entry restarts
  // at (the farthest of the others) - reach, at most 0. No pass over all the vertices,
  // no scan of all the entries. The first call, the first after any other refit, a
  // build or a renumbering, and a call with over a quarter of the vertices listed make
  // one pass instead, which brings every vertex within the reach and sets every entry.
  // Meanwhile queries grow boxes by the whole margin. Every step between two calls must
  // have been summed into `travel` (else: refitMoved, with an infinite bound when
  // unknown). Throws for groupSize 0. Returns the vertices re-anchored (all of them for
  // a refit()).
  std::size_t refitTravelled(const mesh::SurfaceMesh& m, std::span<double> travel, std::span<const std::uint32_t> past,
                             std::size_t groupSize);
  // Only the listed vertices moved since the last refit (physics' awake list in
  // active-region mode, vertices a caller moved; repeats allowed): with a margin, those
  // farther than half the margin from their anchors are re-anchored and their leaves
  // refitted, the others' boxes still hold. An active region of ~1500 vertices that
  // moves a little every step then costs a read of each, not a refit of each one's
  // leaves. In refitTravelled's mode a short list is anchored where it is (as
  // refitVertices) and keeps the mode; a longer one ends it (every vertex is within
  // the margin then, if refitTravelled took every group past the limit: call it
  // first). Without a margin: refitVertices. Returns the vertices re-anchored; throws
  // CollisionError for an index out of range (before any change).
  std::size_t refitListed(const mesh::SurfaceMesh& m, std::span<const std::uint32_t> moved);
  static constexpr std::size_t kFewListed = 64;  // refitListed in the travelled mode: anchored at once
  static constexpr double kTravelReach = 0.5;
  // For the physics that sums the moves: the entry past which a group is listed (the
  // margin's share beyond the reach; +inf without a margin), and the room to add each
  // step for the rounding of x + dx.
  [[nodiscard]] double travelLimit() const {
    return margin_ > 0.0 ? (1.0 - kTravelReach) * margin_ : std::numeric_limits<double>::infinity();
  }
  [[nodiscard]] double travelPad() const { return 4.0 * DBL_EPSILON * padScale_; }
  // After m.garbageCollection() (which returned `c`): renumbers the tree's faces and
  // corners through c.faceMap instead of rebuilding; faces the compaction dropped
  // leave their leaves. Also for a copy of a tree whose mesh was copied and then cut
  // down to one component (separation): every face not kept leaves the tree. The tree
  // must have been in sync with the mesh before the edits that preceded the
  // compaction; faces created since are inserted locally. Rebuilds (cheaply) when
  // fewer than kRebuildFraction of the tracked faces survive. Returns what it did.
  SyncResult remap(const mesh::SurfaceMesh& m, const mesh::Compaction& c);
  // Faces must be live; already tracked faces are re-read (corners) and refitted.
  void insertFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);
  // Untracked faces are ignored. Faces may already be deleted in the mesh.
  void removeFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);
  // The same for faces that leave with a freed piece (separation): not counted toward
  // a rebuild (kRebuildFraction), since removing faces never loosens the boxes of the
  // faces that stay; remap() rebuilds when a compaction leaves few of them.
  void releaseFaces(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces);

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
  // The first contact along a->b: exactly intersectSegment(m, a, b).front(), found
  // near-to-far with pruning. False (out untouched) when there is none.
  bool firstHit(const mesh::SurfaceMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b, SurfaceHit& out,
                QueryCounters* counters = nullptr) const;
  // Whether a->b touches the surface at all (stops at the first triangle hit).
  [[nodiscard]] bool anyHit(const mesh::SurfaceMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            QueryCounters* counters = nullptr) const;

  // Appends every tracked face whose box (grown by the tolerance) overlaps `box`.
  void facesOverlapping(const Box& box, std::vector<mesh::Face>& out) const;
  // Appends every tracked face in a leaf whose box (grown by the tolerance) meets
  // triangle (p0, p1, p2) (separating-axis test), for swept queries.
  void facesNearTriangle(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                         std::vector<mesh::Face>& out) const;

  [[nodiscard]] bool tracks(mesh::Face f) const { return f.idx() < faceSlot_.size() && faceSlot_[f.idx()] != kNone; }
  // Root box (float precision, rounded outwards, grown by pad()).
  // With a motion margin, grown by how far the vertices may have moved from the anchors
  // the boxes were fitted around (at most the margin).
  [[nodiscard]] Box bounds() const {
    if (nodes_.empty()) return Box{};
    Box b = boxOf(0);
    if (!b.empty()) {
      b.min.array() -= motionGrow();
      b.max.array() += motionGrow();
    }
    return b;
  }
  [[nodiscard]] const Tolerance& tolerance() const { return tol_; }
  [[nodiscard]] double pad() const { return pad_; }
  [[nodiscard]] BvhStats stats() const;
  // Invariants against the mesh: every live face in exactly one leaf with its
  // current corners, no dead face tracked, every box contains its faces and
  // children. Empty string when fine.
  [[nodiscard]] std::string check(const mesh::SurfaceMesh& m) const;

 private:
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  static constexpr std::uint32_t kInner = std::numeric_limits<std::uint32_t>::max();
  // 32 bytes, two per cache line; lo and hi each fill one 16-byte lane group (with
  // index and count as fourth lanes) so a refit loads and combines them whole.
  // Inner: count == kInner, children index, index+1. Leaf: count faces (0..4) in
  // block `index`.
  struct alignas(32) Node {
    float lo[3];
    std::uint32_t index;
    float hi[3];
    std::uint32_t count;
    [[nodiscard]] bool leaf() const { return count != kInner; }
  };
  static Node emptyNode();
  void removeTracked(const mesh::SurfaceMesh& m, std::span<const mesh::Face> faces, bool countAsEdits);
  struct TriRef {
    std::uint32_t face, v[3];
  };
  struct alignas(64) Block {
    TriRef tri[kLeafCapacity];
  };
  // The distinct corners of a block's faces (about 6 for 4 neighbouring triangles,
  // instead of 12 corners): what a refit reads.
  struct BlockVerts {
    std::uint32_t n;
    std::uint32_t v[3 * kLeafCapacity];
  };

  template <class NodeTest, class LeafVisit>
  void traverse(NodeTest&& test, LeafVisit&& visit) const;
  template <class NodeTest, class LeafVisit>
  void traverseOrdered(NodeTest&& test, LeafVisit&& visit) const;

  std::uint32_t newPair(std::uint32_t parent);
  std::uint32_t newBlock(std::uint32_t leaf);
  void makeLeaf(std::uint32_t node, const std::uint32_t* faces, std::size_t count, const mesh::SurfaceMesh& m);
  void fitLeaf(const mesh::SurfaceMesh& m, std::uint32_t i) {
    if (margin_ > 0.0 && anchor_.size() < m.verticesSize()) growAnchors(m);
    fitBlock(m.positions().data(), nodes_[i].index);
  }
  void growAnchors(const mesh::SurfaceMesh& m);
  // One pass over every vertex: those farther than theta from their anchor are
  // re-anchored (or all, by a refit(), when many are); the slack is what the farthest
  // of the others leaves.
  std::size_t motionPass(const mesh::SurfaceMesh& m, double theta);
  // Anchors the vertices where they are and refits their leaves; returns how many. Up
  // to kFewReanchors vertices: leaf by leaf, each climbing only while boxes change.
  std::size_t reanchor(const mesh::SurfaceMesh& m, const std::vector<std::uint32_t>& vertices);
  static constexpr std::size_t kFewReanchors = 16;
  // A vertex someone else moved, in refitTravelled's mode: anchored where it is (its
  // group's entry may be below 0, less than its move).
  void anchorMoved(const mesh::SurfaceMesh& m, std::uint32_t v);
  // One leaf refitted, then its ancestors while their boxes change.
  void fitUpwards(const mesh::SurfaceMesh& m, std::uint32_t leaf);
  static bool sameBox(const Node& a, const Node& b);
  void fitRound(const mesh::SurfaceMesh& m);
  void fitBlock(const Eigen::Vector3d* P, std::uint32_t block);
  // The box of a block's corners read from P (positions, or the float anchors), grown
  // by the pad (no anchor test).
  template <class Point>
  void boxBlock(const Point* P, std::uint32_t block);
  void fitInner(std::uint32_t i);
  void fit(const mesh::SurfaceMesh& m, std::uint32_t i) {
    if (nodes_[i].leaf()) {
      fitLeaf(m, i);
    } else {
      fitInner(i);
    }
  }
  void updateBlockVerts(std::uint32_t block);
  void listInner();
  // Upward refit from a set of start nodes: beginRefit(), addDirty() per node (once
  // each; ancestors are collected and counted on the way up), finishRefit() fits
  // every start whose children are done and climbs while a parent's last child is.
  void beginRefit();
  void addDirty(std::uint32_t node);
  void finishRefit(const mesh::SurfaceMesh& m);
  void addVertexLeaves(const mesh::SurfaceMesh& m, mesh::Vertex v);
  // visit(leaf) for each leaf holding a face around v (a leaf once per face).
  template <class Visit>
  void forEachLeafOf(const mesh::SurfaceMesh& m, mesh::Vertex v, Visit&& visit) const;
  [[nodiscard]] Box boxOf(std::size_t i) const;
  // Every tracked vertex is within this of its anchor (per coordinate): queries grow
  // the boxes (fitted around the anchors) by it. 0 without a margin.
  [[nodiscard]] double motionGrow() const { return margin_ - slack_; }
  [[nodiscard]] std::uint32_t leafOf(mesh::Face f) const { return blockLeaf_[faceSlot_[f.idx()] / kLeafCapacity]; }

  struct BuildItem;
  void makeLeaf(std::uint32_t node, const BuildItem* first, const BuildItem* last, const mesh::SurfaceMesh& m);
  void buildNode(const mesh::SurfaceMesh& m, std::uint32_t node, BuildItem* first, BuildItem* last, std::size_t depth);
  void buildMorton(const mesh::SurfaceMesh& m, std::uint32_t node, const std::uint64_t* keys, BuildItem* first,
                   BuildItem* last, std::size_t depth);
  void buildSweep(const mesh::SurfaceMesh& m, std::uint32_t node, BuildItem* first, BuildItem* last, std::size_t depth);
  void refitUpwards(const mesh::SurfaceMesh& m, std::vector<std::uint32_t>& dirtyLeaves);
  std::uint32_t chooseLeaf(const mesh::SurfaceMesh& m, mesh::Face f) const;
  void splitLeaf(const mesh::SurfaceMesh& m, std::uint32_t leaf, std::vector<std::uint32_t>& dirty);
  void reread(const mesh::SurfaceMesh& m, mesh::Face f);
  std::size_t depthOf(std::uint32_t node) const;
  void remember(const mesh::SurfaceMesh& m);
  void checkMesh(const mesh::SurfaceMesh& m, const char* where) const;
  [[nodiscard]] double queryGrow(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  static double effectivePad(double scale, const Tolerance& tol);

  Tolerance tol_;
  double pad_ = 0.0;
  double padScale_ = 0.0;  // coordinate scale pad_ was computed for
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> parent_;  // per node; kNone for the root
  std::vector<Block> blocks_;
  std::vector<std::uint32_t> blockLeaf_;  // per block: its leaf node
  std::vector<std::uint32_t> faceSlot_;   // per face index: block * 4 + position, or kNone
  std::vector<BlockVerts> blockVerts_;    // per block: distinct corners
  std::vector<double> sweepArea_;         // build scratch
  std::vector<std::uint32_t> inner_;      // inner nodes of the last build, children before parents
  std::vector<std::uint32_t> innerLate_;  // leaves split since (fitted first, highest index first)
  bool innerLateSorted_ = true;
  std::vector<std::uint32_t> mark_;               // refitUpwards scratch: node visited in this epoch
  std::vector<std::uint8_t> pending_;             // refitUpwards scratch: children still to fit
  std::vector<std::uint32_t> scratch_;            // refitUpwards scratch: start nodes
  std::vector<std::uint32_t> dirty_, dirtySync_;  // leaves to refit (kept to avoid allocation)
  std::vector<mesh::Face> removed_, added_;       // sync scratch
  std::vector<std::uint32_t> faceMark_;           // sync scratch: face seen in this epoch
  std::uint32_t faceEpoch_ = 0;
  std::uint32_t epoch_ = 0;
  std::size_t tracked_ = 0;  // live faces in the tree
  std::size_t editsSinceBuild_ = 0, facesAtBuild_ = 0, builds_ = 0;
  std::size_t maxDepth_ = 0;
  bool needsRebuild_ = false;
  // What the mesh looked like at the last build/sync.
  std::uint64_t seenVersion_ = 0, seenLayout_ = 0;
  std::size_t seenJournal_ = 0;  // editedFaces() entries already applied
  std::size_t seenFaces_ = 0, seenVertices_ = 0;
  bool built_ = false;
  // Fat boxes (setMotionMargin): per vertex the position its leaves were fitted
  // around, rounded to float (the pass reads 36 bytes a vertex instead of 48; boxes
  // are widened by the rounding, see kAnchorRel); every vertex is within margin_ -
  // slack_ of it (per coordinate) beyond that rounding.
  double margin_ = 0.0, slack_ = 0.0;
  std::size_t motionPasses_ = 0;
  std::vector<Eigen::Vector3f> anchor_;
  std::vector<std::uint32_t> stale_, staleWork_;  // re-anchored in a fit: their other leaves follow
  std::vector<std::uint32_t> moving_;             // refitTravelled scratch
  std::vector<std::uint32_t> fewLeaves_, fewStale_;  // reanchor scratch
  // refitTravelled's mode: slack_ is 0 (queries grow by the whole margin), every vertex
  // is within the reach plus its group's entry of its anchor, and a fit re-anchors a
  // corner past the reach. Any other refit, a build or a renumbering ends it.
  bool travelling_ = false;
  // How far a corner may be from its anchor before a fit re-anchors it.
  [[nodiscard]] double anchorReach() const { return travelling_ ? kTravelReach * margin_ : margin_ - slack_; }
};

}  // namespace ld::collision
