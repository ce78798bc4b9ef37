#pragma once
// A triangle surface mesh with typed index handles and per-element properties.
//
// Connectivity: every face stores its three vertices (counter-clockwise seen from
// outside) and its three edges (edge i joins vertex i and i+1); every edge stores
// its two end vertices and the one or two faces that use it; every vertex stores its
// incident edges. An undirected vertex pair is at most one edge. All edits are local
// (cost proportional to the valence of the touched vertices); deleted elements are
// only flagged until garbageCollection() compacts the arrays.
//
// Edits state their preconditions; an edit that cannot be done returns an invalid
// handle and leaves the mesh untouched. Misuse (a dead or foreign handle) throws
// InvalidHandleError.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sim/mesh/handles.h"
#include "sim/mesh/mesh_error.h"
#include "sim/mesh/properties.h"
#include "sim/mesh/small_vector.h"

namespace ld::mesh {

using Point = Eigen::Vector3d;
using Normal = Eigen::Vector3d;
// A vertex's incident edges: up to 10 kept in the vertex array itself (a usual
// valence after a few edits), more on the heap.
using EdgeList = SmallVector<Edge, 10>;

template <class T>
using VertexProperty = Property<Vertex, T>;
template <class T>
using EdgeProperty = Property<Edge, T>;
template <class T>
using FaceProperty = Property<Face, T>;

struct ValidationReport {
  std::vector<std::string> problems;
  [[nodiscard]] bool ok() const { return problems.empty(); }
  [[nodiscard]] std::string message() const;  // problems joined by newlines
};

// Old index -> new handle (invalid where the element was removed).
struct Compaction {
  std::vector<Vertex> vertexMap;
  std::vector<Edge> edgeMap;
  std::vector<Face> faceMap;
};

struct Components {
  int count = 0;
  std::vector<int> faceLabel;    // per face index; -1 for deleted faces
  std::vector<int> vertexLabel;  // per vertex index; -1 for deleted or isolated vertices
};

// The result of SurfaceMesh::splitComponents.
struct SplitComponents {
  int count = 0;  // components in all (as connectedComponents().count)
  // Every component but the largest, each sorted by face index, in the order of their
  // lowest face index (connectedComponents()'s label order).
  std::vector<std::vector<Face>> pieces;
  std::size_t largestFaces = 0;  // faces of the largest component (not listed)
  std::size_t facesVisited = 0;  // faces the searches reached (the work done)
};

// Workspace of splitComponents, kept by the caller between calls: its per-face marks
// grow with the mesh once and are never cleared as a whole.
struct ComponentScratch {
  std::vector<std::uint32_t> seen;   // per face index: the call that reached it
  std::vector<std::uint32_t> owner;  // per face index: the search that reached it
  std::uint32_t generation = 0;
  struct Search {
    std::vector<Face> stack, faces;
    std::uint32_t parent = 0;
    std::uint32_t minFace = 0;
    bool done = false;
  };
  std::vector<Search> searches;
  std::vector<std::uint32_t> active;
};

struct BoundingBox {
  Point min = Point::Constant(0.0);
  Point max = Point::Constant(0.0);
  [[nodiscard]] Point center() const { return 0.5 * (min + max); }
  [[nodiscard]] Point extent() const { return max - min; }
};

// An append-only list of handles (the edit journal): an append is a store and an
// increment, the growth (geometric) out of line. Moving leaves the source empty.
template <class H>
class HandleLog {
  static_assert(std::is_trivially_copyable_v<H> && std::is_trivially_destructible_v<H>);

 public:
  HandleLog() = default;
  HandleLog(const HandleLog&) = delete;
  HandleLog& operator=(const HandleLog&) = delete;
  HandleLog(HandleLog&& o) noexcept
      : data_(std::exchange(o.data_, nullptr)), size_(std::exchange(o.size_, 0)), cap_(std::exchange(o.cap_, 0)) {}
  HandleLog& operator=(HandleLog&& o) noexcept {
    if (this != &o) {
      release();
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
      cap_ = std::exchange(o.cap_, 0);
    }
    return *this;
  }
  ~HandleLog() { release(); }
  void push(H h) {
    if (size_ == cap_) [[unlikely]]
      grow();
    std::construct_at(data_ + size_, h);
    ++size_;
  }
  void clear() { size_ = 0; }
  [[nodiscard]] std::span<const H> view() const { return {data_, size_}; }
  // Room for n handles in all, written once so that filling it does not page-fault.
  void reserve(std::size_t n) {
    if (n > cap_) regrow(n);
  }
  void touchReserved() {
    if (cap_ > size_) std::memset(static_cast<void*>(data_ + size_), 0, (cap_ - size_) * sizeof(H));
  }

 private:
  // Slots past size_ are raw storage (never read), so growing does not fill them.
  [[gnu::noinline]] void grow() { regrow(std::max<std::size_t>(64, 2 * cap_)); }
  void regrow(std::size_t cap) {
    H* data = std::allocator<H>().allocate(cap);
    if (size_ > 0) std::memcpy(static_cast<void*>(data), data_, size_ * sizeof(H));
    release();
    data_ = data;
    cap_ = cap;
  }
  void release() {
    if (data_) std::allocator<H>().deallocate(data_, cap_);
    data_ = nullptr;
  }
  H* data_ = nullptr;
  std::size_t size_ = 0, cap_ = 0;
};

// Iterates over the live elements of one kind.
template <class H>
class HandleRange {
 public:
  class Iterator {
   public:
    using value_type = H;
    using difference_type = std::ptrdiff_t;
    Iterator() = default;
    Iterator(typename H::Index i, const std::vector<std::uint8_t>* deleted) : i_(i), deleted_(deleted) { skip(); }
    H operator*() const { return H(i_); }
    Iterator& operator++() {
      ++i_;
      skip();
      return *this;
    }
    Iterator operator++(int) {
      Iterator t = *this;
      ++*this;
      return t;
    }
    bool operator==(const Iterator& o) const { return i_ == o.i_; }

   private:
    void skip() {
      while (deleted_ && i_ < deleted_->size() && (*deleted_)[i_] != 0) ++i_;
    }
    typename H::Index i_ = 0;
    const std::vector<std::uint8_t>* deleted_ = nullptr;
  };
  explicit HandleRange(const std::vector<std::uint8_t>* deleted) : deleted_(deleted) {}
  [[nodiscard]] Iterator begin() const { return Iterator(0, deleted_); }
  [[nodiscard]] Iterator end() const { return Iterator(static_cast<typename H::Index>(deleted_->size()), deleted_); }

 private:
  const std::vector<std::uint8_t>* deleted_;
};

class SurfaceMesh {
 public:
  SurfaceMesh();
  SurfaceMesh(const SurfaceMesh& other);
  SurfaceMesh& operator=(const SurfaceMesh& other);
  SurfaceMesh(SurfaceMesh&& other) noexcept;
  SurfaceMesh& operator=(SurfaceMesh&& other) noexcept;
  ~SurfaceMesh() = default;

  // ---- sizes -------------------------------------------------------------
  // *Size(): array lengths including deleted elements (valid index range).
  [[nodiscard]] std::size_t verticesSize() const { return vprops_.size(); }
  [[nodiscard]] std::size_t edgesSize() const { return eprops_.size(); }
  [[nodiscard]] std::size_t facesSize() const { return fprops_.size(); }
  [[nodiscard]] std::size_t nVertices() const { return verticesSize() - deletedVertices_; }
  [[nodiscard]] std::size_t nEdges() const { return edgesSize() - deletedEdges_; }
  [[nodiscard]] std::size_t nFaces() const { return facesSize() - deletedFaces_; }
  [[nodiscard]] bool isEmpty() const { return nVertices() == 0; }
  [[nodiscard]] bool hasGarbage() const { return deletedVertices_ + deletedEdges_ + deletedFaces_ > 0; }
  void clear();
  // Incremented by every edit that changes connectivity; caches (spring arrays,
  // BVHs) compare it to know when to rebuild.
  [[nodiscard]] std::uint64_t topologyVersion() const { return topologyVersion_; }

  // ---- edit journal ----------------------------------------------------------
  // Caches that follow a mesh through many small edits (spring arrays, BVHs, paths
  // embedded in faces) update locally from the journal instead of rebuilding: every
  // edit appends the handles it created, deleted, or re-set (a face's corners; an
  // edge's ends, faces or properties; a vertex split), in edit order, repeats allowed.
  // Remember layoutVersion() and the three journal sizes; while layoutVersion() is
  // unchanged, the handles from those sizes on are what changed since. A new
  // layoutVersion() (garbage collection, clear, copy or assignment: indices or
  // contents replaced) empties the journal: rebuild. Moving a mesh keeps it.
  // The journal grows by a few handles per edit until the next layout change.
  [[nodiscard]] std::uint64_t layoutVersion() const { return layoutVersion_; }
  [[nodiscard]] std::span<const Vertex> editedVertices() const { return journalV_.view(); }
  [[nodiscard]] std::span<const Edge> editedEdges() const { return journalE_.view(); }
  [[nodiscard]] std::span<const Face> editedFaces() const { return journalF_.view(); }

  // Room for nv vertices, ne edges and nf faces (every property array, the edits'
  // per-face scratch, and the journal for the edits that add them) before an array is
  // reallocated.
  void reserve(std::size_t nv, std::size_t ne, std::size_t nf);
  // Writes the reserved room of every property array once (nothing changes), so that
  // the edits that fill it later do not page-fault on fresh memory (a real-time loop
  // reserves and touches when an object is loaded, not in its step).
  void touchReserved();

  [[nodiscard]] bool isDeleted(Vertex v) const { return vdeleted_[v] != 0; }
  [[nodiscard]] bool isDeleted(Edge e) const { return edeleted_[e] != 0; }
  [[nodiscard]] bool isDeleted(Face f) const { return fdeleted_[f] != 0; }
  // In range and not deleted.
  [[nodiscard]] bool isValid(Vertex v) const { return v.isValid() && v.idx() < verticesSize() && vdeleted_[v] == 0; }
  [[nodiscard]] bool isValid(Edge e) const { return e.isValid() && e.idx() < edgesSize() && edeleted_[e] == 0; }
  [[nodiscard]] bool isValid(Face f) const { return f.isValid() && f.idx() < facesSize() && fdeleted_[f] == 0; }

  [[nodiscard]] HandleRange<Vertex> vertices() const { return HandleRange<Vertex>(&vdeleted_.vector()); }
  [[nodiscard]] HandleRange<Edge> edges() const { return HandleRange<Edge>(&edeleted_.vector()); }
  [[nodiscard]] HandleRange<Face> faces() const { return HandleRange<Face>(&fdeleted_.vector()); }

  // ---- construction and edits ---------------------------------------------
  Vertex addVertex(const Point& p);

  // Adds triangle (a, b, c), counter-clockwise.
  // Pre: a, b, c live and distinct. Returns an invalid face (mesh unchanged) when an
  // edge of the triangle already has two faces, or already has one face that runs
  // it in the same direction (inconsistent orientation).
  Face addFace(Vertex a, Vertex b, Vertex c);
  // The same with the sides already looked up: sides[i] is findEdge of corners i and
  // i + 1 ((a,b), (b,c), (c,a)), invalid where there is no such edge (a caller that tries
  // both orientations of one triangle looks its edges up once). Pre as addFace and the
  // sides as stated (not checked); same result as addFace(a, b, c).
  Face addFace(Vertex a, Vertex b, Vertex c, const std::array<Edge, 3>& sides);

  // Pre: f live. Post: f deleted; edges left without a face are deleted; vertices
  // stay (they may become isolated).
  void deleteFace(Face f);

  // Pre: v live. Post: v and every face and edge around it deleted.
  void deleteVertex(Vertex v);

  // Inserts a vertex at p on edge e and splits each of its one or two faces in two.
  // Pre: e live. Post: e is replaced by two edges (a,m), (m,b) that inherit e's
  // properties; each split face keeps its handle for the half next to e's first
  // vertex and a new face inherits its properties. Returns m; an invalid handle, the
  // mesh unchanged, when e's two faces have the same opposite vertex (they are then
  // a closed two-triangle pillow): the edge from m to it would have four faces.
  Vertex splitEdge(Edge e, const Point& p);

  // Inserts a vertex at p inside f and splits f into three (f keeps one part, two new
  // faces inherit its properties). Pre: f live. Returns the new vertex.
  Vertex splitFace(Face f, const Point& p);

  // Moves the faces in `fan` (any subset of v's faces, connected around v or not) from
  // v onto a new vertex at v's position with v's properties. An edge at v whose faces
  // are all in the fan moves with them (same handle and properties, its end re-set to
  // the new vertex); an edge shared by a fan face and a non-fan face is duplicated (the
  // copy, for the fan face, inherits its properties). Cost linear in v's valence (times
  // the fan's size). Numbering: the new vertex is the next vertex index, the copies the
  // next edge indices in the order of v's edge list (see surface_mesh.cpp).
  // Pre: v live; fan non-empty, faces live, distinct and incident to v, and not all
  // faces around v. Returns the new vertex, or invalid (mesh unchanged) otherwise.
  Vertex splitVertex(Vertex v, std::span<const Face> fan);

  // Removes interior edge e by merging its end other than `keep` into `keep` (which
  // keeps its position): e's two faces go, the other faces of the removed vertex move to
  // `keep` (same handles and properties), and its edges to vertices that `keep` has no
  // edge to move with them (copies with their properties). Pre: e live, keep an end of
  // e. Returns keep, or an invalid handle (mesh unchanged) when the result would not be
  // a manifold: e or an edge at the removed vertex is a boundary edge, the two ends share
  // a neighbour other than e's two opposite corners (link condition), or an opposite
  // corner has only three edges (a tetrahedron would fold onto itself).
  Vertex collapseEdge(Edge e, Vertex keep);

  // Disconnects the two faces of interior edge e from each other, duplicating an end
  // vertex whose face fan opens up once e is cut (a boundary vertex, or one on an
  // earlier cut), and the other end too if the two sides would otherwise meet only
  // there. Pre: e live with two faces. Returns the new edge (the copy that the
  // second face now uses), or invalid (mesh unchanged) when neither end vertex can
  // be split without a slit closed at both ends.
  Edge separateEdge(Edge e);

  // Removes deleted elements, renumbering the rest in order. Handles held outside
  // the mesh must be remapped with the returned maps.
  Compaction garbageCollection();

  // ---- connectivity queries -----------------------------------------------
  [[nodiscard]] const std::array<Vertex, 3>& vertices(Face f) const { return fverts_[f]; }
  [[nodiscard]] const std::array<Edge, 3>& edges(Face f) const { return fedges_[f]; }
  [[nodiscard]] Vertex vertex(Edge e, int i) const { return everts_[e][static_cast<std::size_t>(i)]; }
  // i = 0 is always a live face; i = 1 is invalid for a boundary edge.
  [[nodiscard]] Face face(Edge e, int i) const { return efaces_[e][static_cast<std::size_t>(i)]; }
  [[nodiscard]] const EdgeList& edges(Vertex v) const { return vedges_[v]; }
  [[nodiscard]] std::vector<Face> faces(Vertex v) const;  // incident faces, each once
  // The same into a caller's buffer (cleared first), so that a loop need not allocate.
  void faces(Vertex v, std::vector<Face>& out) const;
  [[nodiscard]] std::size_t valence(Vertex v) const { return vedges_[v].size(); }
  [[nodiscard]] bool isIsolated(Vertex v) const { return vedges_[v].empty(); }
  [[nodiscard]] bool isBoundary(Edge e) const { return !efaces_[e][1].isValid(); }
  [[nodiscard]] bool isBoundary(Vertex v) const;
  [[nodiscard]] Edge findEdge(Vertex a, Vertex b) const;
  [[nodiscard]] Vertex otherVertex(Edge e, Vertex v) const;
  [[nodiscard]] Face otherFace(Edge e, Face f) const;  // across e; invalid on the boundary
  [[nodiscard]] Vertex oppositeVertex(Face f, Edge e) const;
  [[nodiscard]] Edge oppositeEdge(Face f, Vertex v) const;
  [[nodiscard]] int localIndex(Face f, Vertex v) const;  // 0..2, or -1
  [[nodiscard]] int localIndex(Face f, Edge e) const;    // 0..2, or -1
  [[nodiscard]] bool isClosed() const;                   // no boundary edge and not empty

  // ---- geometry --------------------------------------------------------------
  [[nodiscard]] Point& position(Vertex v) { return points_[v]; }
  [[nodiscard]] const Point& position(Vertex v) const { return points_[v]; }
  // Indexed by vertex index, deleted slots included.
  [[nodiscard]] std::vector<Point>& positions() { return points_.vector(); }
  [[nodiscard]] const std::vector<Point>& positions() const { return points_.vector(); }
  [[nodiscard]] Normal faceNormal(Face f) const;  // unit, or zero for a degenerate face
  [[nodiscard]] double faceArea(Face f) const;
  [[nodiscard]] Point centroid(Face f) const;
  [[nodiscard]] double edgeLength(Edge e) const;
  // Area-weighted unit vertex normals, indexed by vertex index.
  [[nodiscard]] std::vector<Normal> vertexNormals() const;
  [[nodiscard]] double area() const;
  [[nodiscard]] BoundingBox bounds() const;

  // ---- global structure ----------------------------------------------------
  [[nodiscard]] Components connectedComponents() const;
  // The same split by searching outwards from `seeds` alone, one search per seed,
  // advanced in turn one face at a time (searches that meet merge): it stops once a
  // single search is open and the faces left for it outnumber every finished
  // component, so the largest component is never walked to its end and the cost is in
  // proportion to the other components (times the searches running at once), not to
  // the mesh. Pre: every component holds a seed face (e.g. the faces and the faces of
  // the edges an edit touched, in a mesh that was connected before it: see
  // editedFaces()/editedEdges()). Dead or repeated seeds are ignored. The largest
  // component is chosen as connectedComponents() labels would (most faces; ties: the
  // one with the lowest face index).
  [[nodiscard]] SplitComponents splitComponents(std::span<const Face> seeds, ComponentScratch& scratch) const;
  // The same from the full labelling (O(mesh)), for a mesh with no seeds to go by.
  [[nodiscard]] SplitComponents splitComponents() const;
  // A new mesh of `faces` (live, each once), the edges and vertices they use and all
  // their properties, in their old relative order (as if every other face and the
  // elements left unused were deleted and the copy compacted), at a cost in proportion
  // to the part, not to this mesh. A vertex shared with faces not listed keeps only
  // the listed faces' edges.
  [[nodiscard]] SurfaceMesh extract(std::span<const Face> faces) const;
  // Each loop lists its vertices in order, walking boundary edges opposite to the
  // direction of their face (so the loop runs around the hole counter-clockwise).
  [[nodiscard]] std::vector<std::vector<Vertex>> boundaryLoops() const;
  [[nodiscard]] ValidationReport validate() const;

  // ---- properties --------------------------------------------------------------
  template <class T>
  VertexProperty<T> addVertexProperty(const std::string& name, T def = T()) {
    VertexProperty<T> prop(vprops_.add<T>(name, std::move(def)));
    newPropertySet();
    return prop;
  }
  template <class T>
  VertexProperty<T> getVertexProperty(std::string_view name) const {
    return VertexProperty<T>(vprops_.get<T>(name));
  }
  template <class T>
  VertexProperty<T> vertexProperty(std::string_view name, T def = T()) {
    auto p = getVertexProperty<T>(name);
    return p ? p : addVertexProperty<T>(std::string(name), std::move(def));
  }
  template <class T>
  EdgeProperty<T> addEdgeProperty(const std::string& name, T def = T()) {
    EdgeProperty<T> prop(eprops_.add<T>(name, std::move(def)));
    newPropertySet();
    return prop;
  }
  template <class T>
  EdgeProperty<T> getEdgeProperty(std::string_view name) const {
    return EdgeProperty<T>(eprops_.get<T>(name));
  }
  template <class T>
  EdgeProperty<T> edgeProperty(std::string_view name, T def = T()) {
    auto p = getEdgeProperty<T>(name);
    return p ? p : addEdgeProperty<T>(std::string(name), std::move(def));
  }
  template <class T>
  FaceProperty<T> addFaceProperty(const std::string& name, T def = T()) {
    FaceProperty<T> prop(fprops_.add<T>(name, std::move(def)));
    newPropertySet();
    return prop;
  }
  template <class T>
  FaceProperty<T> getFaceProperty(std::string_view name) const {
    return FaceProperty<T>(fprops_.get<T>(name));
  }
  template <class T>
  FaceProperty<T> faceProperty(std::string_view name, T def = T()) {
    auto p = getFaceProperty<T>(name);
    return p ? p : addFaceProperty<T>(std::string(name), std::move(def));
  }
  void removeVertexProperty(const std::string& name);
  void removeEdgeProperty(const std::string& name);
  void removeFaceProperty(const std::string& name);
  // A new value whenever the mesh's set of property arrays may have changed: a property
  // added or removed, or the arrays replaced (copy, assignment, clear, moved from).
  // Views taken while it holds stay valid and name the same properties, so a caller that
  // looks properties up once per edit can keep them across edits (unique across meshes;
  // a mesh moved to a new object keeps its arrays and this value).
  [[nodiscard]] std::uint64_t propertySetVersion() const { return propertySetVersion_; }

 private:
  void initBuiltins();
  void bindProperties();
  // Inline tests, the throws out of line.
  void check(Vertex v, const char* where) const {
    if (!isValid(v)) [[unlikely]]
      throwInvalid(v, where);
  }
  void check(Edge e, const char* where) const {
    if (!isValid(e)) [[unlikely]]
      throwInvalid(e, where);
  }
  void check(Face f, const char* where) const {
    if (!isValid(f)) [[unlikely]]
      throwInvalid(f, where);
  }
  [[noreturn]] static void throwInvalid(Vertex v, const char* where);
  [[noreturn]] static void throwInvalid(Edge e, const char* where);
  [[noreturn]] static void throwInvalid(Face f, const char* where);
  Edge newEdge(Vertex a, Vertex b);
  Face newFace();
  Edge newEdgeCopy(Edge from, Vertex a, Vertex b);
  Face newFaceCopy(Face from);
  Edge linkNewEdge(Vertex a, Vertex b);  // the tail of newEdge / newEdgeCopy
  Face journalNewFace();
  void addEdgeToVertex(Vertex v, Edge e) { vedges_[v].push_back(e); }
  template <class H>
  static void record(HandleLog<H>& journal, H h) {
    journal.push(h);
  }
  // Low-level helpers: remove a face from its edges' face lists (edges may be left
  // empty) and give it new vertices, finding or creating its edges (`known`: the
  // edges already found for (a,b), (b,c), (c,a), invalid where not looked up).
  void detachFace(Face f);
  // (`missingAreNew`: an edge not in `known` does not exist yet; no search.)
  void attachFace(Face f, Vertex a, Vertex b, Vertex c, std::array<Edge, 3> known = {}, bool missingAreNew = false);
  // addFace's tail: a, b, c live and distinct, `found` their sides as findEdge gives them.
  Face addFaceOnSides(Vertex a, Vertex b, Vertex c, const std::array<Edge, 3>& found);
  void deleteEmptyEdge(Edge e);
  void removeEdgeFromVertex(Vertex v, Edge e);
  [[nodiscard]] bool runsForward(Face f, Edge e) const;  // f traverses e from vertex 0 to 1
  // Per face of `around` (the faces of v): into `group`, a label shared by faces
  // connected through edges at v other than `ignore`.
  void fanGroups(Vertex v, const std::vector<Face>& around, Edge ignore, std::vector<int>& group) const;
  Vertex splitOff(Vertex v, Face f0, Face f1, Edge ignore);

  PropertyContainer vprops_, eprops_, fprops_;
  VertexProperty<Point> points_;
  VertexProperty<EdgeList> vedges_;
  VertexProperty<std::uint8_t> vdeleted_;  // bytes, not bits: read on every isValid()
  EdgeProperty<std::array<Vertex, 2>> everts_;
  EdgeProperty<std::array<Face, 2>> efaces_;
  EdgeProperty<std::uint8_t> edeleted_;
  FaceProperty<std::array<Vertex, 3>> fverts_;
  FaceProperty<std::array<Edge, 3>> fedges_;
  FaceProperty<std::uint8_t> fdeleted_;
  std::size_t deletedVertices_ = 0, deletedEdges_ = 0, deletedFaces_ = 0;
  std::uint64_t topologyVersion_ = 0;
  std::uint64_t layoutVersion_;
  std::uint64_t propertySetVersion_;
  HandleLog<Vertex> journalV_;
  HandleLog<Edge> journalE_;
  HandleLog<Face> journalF_;
  void newLayout();
  void newPropertySet();

  // Scratch buffers of the edits (never copied with the mesh, moved with it: their
  // capacity is what the edits need; only non-const edits use them), so that edits in
  // steady state do not allocate. splitVertex and
  // separateEdge have their own, since separateEdge passes its fan to splitVertex.
  struct EdgeSwap {
    Face face;
    Edge from, to;
  };
  struct Scratch {
    std::vector<Face> around;
    std::vector<EdgeSwap> swaps;
    std::vector<Face> sepAround;
    std::vector<int> sepGroup;
    std::vector<Face> sepFan;
    // splitVertex's fan membership: per face index, the stamp of the call that listed
    // it (grows with the mesh, cleared only when the stamp wraps).
    std::vector<std::uint32_t> fanMark;
    std::uint32_t fanStamp = 0;
  };
  Scratch scratch_;
};

// Small connectivity queries, inline: the cutter and the collision code call them in
// their inner loops.
inline Edge SurfaceMesh::findEdge(Vertex a, Vertex b) const {
  const auto& ea = vedges_[a];
  const auto& eb = vedges_[b];
  // Every edge in a vertex's list has that vertex as an end (validate() checks it), so
  // the two ends xor the vertex give the other end: one comparison per edge.
  const bool fromA = ea.size() <= eb.size();
  const auto& shorter = fromA ? ea : eb;
  const Vertex::Index here = fromA ? a.idx() : b.idx(), there = fromA ? b.idx() : a.idx();
  for (Edge e : shorter) {
    const auto& ev = everts_[e];
    if ((ev[0].idx() ^ ev[1].idx() ^ here) == there) return e;
  }
  return Edge();
}

inline bool SurfaceMesh::isBoundary(Vertex v) const {
  for (Edge e : vedges_[v])
    if (isBoundary(e)) return true;
  return false;
}

inline Vertex SurfaceMesh::otherVertex(Edge e, Vertex v) const {
  const auto& ev = everts_[e];
  return ev[0] == v ? ev[1] : (ev[1] == v ? ev[0] : Vertex());
}

inline Face SurfaceMesh::otherFace(Edge e, Face f) const {
  const auto& ef = efaces_[e];
  return ef[0] == f ? ef[1] : (ef[1] == f ? ef[0] : Face());
}

inline Vertex SurfaceMesh::oppositeVertex(Face f, Edge e) const {
  const int i = localIndex(f, e);
  return i < 0 ? Vertex() : fverts_[f][static_cast<std::size_t>((i + 2) % 3)];
}

inline Edge SurfaceMesh::oppositeEdge(Face f, Vertex v) const {
  const int i = localIndex(f, v);
  return i < 0 ? Edge() : fedges_[f][static_cast<std::size_t>((i + 1) % 3)];
}

inline int SurfaceMesh::localIndex(Face f, Vertex v) const {
  for (int i = 0; i < 3; ++i)
    if (fverts_[f][static_cast<std::size_t>(i)] == v) return i;
  return -1;
}

inline int SurfaceMesh::localIndex(Face f, Edge e) const {
  for (int i = 0; i < 3; ++i)
    if (fedges_[f][static_cast<std::size_t>(i)] == e) return i;
  return -1;
}

}  // namespace ld::mesh
