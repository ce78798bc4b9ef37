#include "sim/collision/bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

namespace ld::collision {

using Eigen::Vector3d;
using mesh::Face;

namespace {

constexpr std::size_t kStack = 96;  // > kMaxDepth + 1: DFS pushes at most one extra node per level

double halfArea(const Box& b) {
  if (b.empty()) return 0.0;
  const Vector3d e = b.max - b.min;
  return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
}

// Outward rounding to float without libm calls: step away by at least one float
// ulp (2^-23 relative) before rounding to nearest.
float roundDown(double x) { return static_cast<float>(x - (std::abs(x) * 1.2e-7 + 1e-30)); }
float roundUp(double x) { return static_cast<float>(x + (std::abs(x) * 1.2e-7 + 1e-30)); }

}  // namespace

std::int32_t TriangleBvh::newNode(std::int32_t parent) {
  nodes_.emplace_back();
  nodes_.back().parent = parent;
  HotNode h{};
  for (int k = 0; k < 3; ++k) {
    h.lo[k] = std::numeric_limits<float>::infinity();
    h.hi[k] = -std::numeric_limits<float>::infinity();
  }
  h.child[0] = h.child[1] = -1;
  hot_.push_back(h);
  return static_cast<std::int32_t>(nodes_.size() - 1);
}

void TriangleBvh::fitLeaf(const mesh::SurfaceMesh& m, std::size_t i) {
  const Node& n = nodes_[i];
  HotNode& h = hot_[i];
  h.child[0] = n.child[0];
  h.child[1] = n.child[1];
  if (n.count == 0) {
    for (int k = 0; k < 3; ++k) {
      h.lo[k] = std::numeric_limits<float>::infinity();
      h.hi[k] = -std::numeric_limits<float>::infinity();
    }
    return;
  }
  Box b;
  for (std::int32_t j = 0; j < n.count; ++j)
    for (mesh::Vertex v : m.vertices(Face(n.faces[j]))) b.extend(m.position(v));
  for (int k = 0; k < 3; ++k) {
    h.lo[k] = roundDown(b.min[k]);
    h.hi[k] = roundUp(b.max[k]);
  }
}

void TriangleBvh::fitInner(std::size_t i) {
  const Node& n = nodes_[i];
  HotNode& h = hot_[i];
  const HotNode& l = hot_[static_cast<std::size_t>(n.child[0])];
  const HotNode& r = hot_[static_cast<std::size_t>(n.child[1])];
  for (int k = 0; k < 3; ++k) {
    h.lo[k] = std::min(l.lo[k], r.lo[k]);
    h.hi[k] = std::max(l.hi[k], r.hi[k]);
  }
  h.child[0] = n.child[0];
  h.child[1] = n.child[1];
}

Box TriangleBvh::boxOf(std::size_t i) const {
  const HotNode& h = hot_[i];
  Box b;
  if (!(h.lo[0] <= h.hi[0])) return b;
  b.min = Vector3d(h.lo[0], h.lo[1], h.lo[2]);
  b.max = Vector3d(h.hi[0], h.hi[1], h.hi[2]);
  return b;
}

double TriangleBvh::effectivePad(const mesh::SurfaceMesh& m, const Tolerance& tol) {
  double scale = 0.0;
  for (mesh::Vertex v : m.vertices()) scale = std::max(scale, m.position(v).cwiseAbs().maxCoeff());
  // Twice the tolerance at the mesh's scale: the segment test grows the triangle by
  // at most its own tolerance, which is computed from the same coordinates.
  return 2.0 * effectiveTolerance(tol, scale) + 1e-300;
}

void TriangleBvh::checkMesh(const mesh::SurfaceMesh& m, const char* where) const {
  if (!built_) throw CollisionError(std::string("TriangleBvh::") + where + ": tree not built");
  // Meshes only grow between syncs (compaction needs a sync()); fewer faces than the
  // tree has seen means another mesh.
  if (m.facesSize() < seenFaces_ || m.verticesSize() < seenVertices_)
    throw CollisionError(std::string("TriangleBvh::") + where +
                         ": mesh is smaller than the tree's (another mesh, or compacted without sync())");
}

void TriangleBvh::build(const mesh::SurfaceMesh& m) {
  nodes_.clear();
  faceLeaf_.assign(m.facesSize(), -1);
  std::vector<std::uint32_t> faces;
  faces.reserve(m.nFaces());
  std::vector<Vector3d> centroid(m.facesSize());
  for (Face f : m.faces()) {
    faces.push_back(f.idx());
    const auto& vs = m.vertices(f);
    centroid[f.idx()] = (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0;
  }
  hot_.clear();
  nodes_.reserve(2 * faces.size() / kBuildLeafSize + 2);
  hot_.reserve(nodes_.capacity());
  maxDepth_ = 0;
  if (faces.empty()) {
    newNode(-1);  // an empty root leaf keeps every path simple
  } else {
    buildRange(m, faces.data(), faces.data() + faces.size(), centroid, -1, 0);
  }
  tracked_ = faces.size();
  pad_ = effectivePad(m, tol_);
  editsSinceBuild_ = 0;
  facesAtBuild_ = faces.size();
  ++builds_;
  needsRebuild_ = false;
  built_ = true;
  remember(m);
}

std::int32_t TriangleBvh::buildRange(const mesh::SurfaceMesh& m, std::uint32_t* first, std::uint32_t* last,
                                     std::vector<Vector3d>& centroid, std::int32_t parent, std::size_t depth) {
  const std::int32_t index = newNode(parent);
  maxDepth_ = std::max(maxDepth_, depth);
  const std::ptrdiff_t n = last - first;
  if (n <= kBuildLeafSize) {
    Node& node = nodes_[static_cast<std::size_t>(index)];
    node.count = static_cast<std::int32_t>(n);
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      node.faces[i] = first[i];
      faceLeaf_[first[i]] = index;
    }
    fitLeaf(m, static_cast<std::size_t>(index));
    return index;
  }
  Box cb;
  for (auto* p = first; p != last; ++p) cb.extend(centroid[*p]);
  int axis = 0;
  (cb.max - cb.min).maxCoeff(&axis);
  auto* mid = first + n / 2;
  std::nth_element(first, mid, last,
                   [&](std::uint32_t x, std::uint32_t y) { return centroid[x][axis] < centroid[y][axis]; });
  const std::int32_t l = buildRange(m, first, mid, centroid, index, depth + 1);
  const std::int32_t r = buildRange(m, mid, last, centroid, index, depth + 1);
  Node& node = nodes_[static_cast<std::size_t>(index)];
  node.child[0] = l;
  node.child[1] = r;
  fitInner(static_cast<std::size_t>(index));
  return index;
}

void TriangleBvh::remember(const mesh::SurfaceMesh& m) {
  seenVersion_ = m.topologyVersion();
  seenFaces_ = m.facesSize();
  seenVertices_ = m.verticesSize();
  seenDeletedFaces_ = m.facesSize() - m.nFaces();
  if (faceLeaf_.size() < m.facesSize()) faceLeaf_.resize(m.facesSize(), -1);
}

void TriangleBvh::refit(const mesh::SurfaceMesh& m) {
  checkMesh(m, "refit");
  // Children always have larger indices than their parent (build is preorder, local
  // splits append), so one backward pass is bottom-up.
  for (std::size_t i = nodes_.size(); i-- > 0;) fit(m, i);
}

void TriangleBvh::refitUpwards(const mesh::SurfaceMesh& m, std::vector<std::int32_t>& dirty) {
  if (dirty.empty()) return;
  // Collect each dirty node and its ancestors once (stop at an ancestor already
  // collected), then fit from the highest index down: children come after parents.
  if (mark_.size() < nodes_.size()) mark_.resize(nodes_.size(), 0);
  if (++epoch_ == 0) {
    std::fill(mark_.begin(), mark_.end(), 0);
    epoch_ = 1;
  }
  std::vector<std::int32_t> order;
  order.reserve(dirty.size() * 4);
  for (std::int32_t i : dirty) {
    while (i >= 0 && mark_[static_cast<std::size_t>(i)] != epoch_) {
      mark_[static_cast<std::size_t>(i)] = epoch_;
      order.push_back(i);
      i = nodes_[static_cast<std::size_t>(i)].parent;
    }
  }
  dirty.clear();
  std::sort(order.begin(), order.end(), std::greater<>());
  for (std::int32_t i : order) fit(m, static_cast<std::size_t>(i));
}

void TriangleBvh::refitFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  checkMesh(m, "refitFaces");
  std::vector<std::int32_t> dirty;
  dirty.reserve(faces.size());
  for (Face f : faces)
    if (tracks(f)) dirty.push_back(faceLeaf_[f.idx()]);
  refitUpwards(m, dirty);
}

void TriangleBvh::refitVertices(const mesh::SurfaceMesh& m, std::span<const mesh::Vertex> moved) {
  checkMesh(m, "refitVertices");
  std::vector<std::int32_t> dirty;
  for (mesh::Vertex v : moved) {
    if (!m.isValid(v)) continue;
    for (mesh::Edge e : m.edges(v))
      for (int k = 0; k < 2; ++k) {
        const Face f = m.face(e, k);
        if (f.isValid() && tracks(f)) dirty.push_back(faceLeaf_[f.idx()]);
      }
  }
  refitUpwards(m, dirty);
}

std::size_t TriangleBvh::depthOf(std::int32_t node) const {
  std::size_t d = 0;
  while (nodes_[static_cast<std::size_t>(node)].parent >= 0) {
    node = nodes_[static_cast<std::size_t>(node)].parent;
    ++d;
  }
  return d;
}

std::int32_t TriangleBvh::chooseLeaf(const mesh::SurfaceMesh& m, Face f) const {
  // The cheap, local answer: the leaf of a neighbour across an edge (cutting makes
  // new faces inside or next to the face it splits).
  std::int32_t best = -1;
  for (mesh::Edge e : m.edges(f)) {
    const Face g = m.otherFace(e, f);
    if (g.isValid() && tracks(g)) {
      const std::int32_t leaf = faceLeaf_[g.idx()];
      if (best < 0 || nodes_[static_cast<std::size_t>(leaf)].count < nodes_[static_cast<std::size_t>(best)].count)
        best = leaf;
    }
  }
  if (best >= 0) return best;
  // Otherwise descend by least growth of surface area.
  Box fb;
  for (mesh::Vertex v : m.vertices(f)) fb.extend(m.position(v));
  std::int32_t i = 0;
  while (!nodes_[static_cast<std::size_t>(i)].leaf()) {
    const Node& n = nodes_[static_cast<std::size_t>(i)];
    double cost[2];
    for (int k = 0; k < 2; ++k) {
      const Box cbox = boxOf(static_cast<std::size_t>(n.child[k]));
      Box u = cbox;
      u.extend(fb);
      cost[k] = halfArea(u) - halfArea(cbox);
    }
    i = n.child[cost[1] < cost[0] ? 1 : 0];
  }
  return i;
}

void TriangleBvh::splitLeaf(const mesh::SurfaceMesh& m, std::int32_t leaf, std::vector<std::int32_t>& dirty) {
  // Turns a full leaf into an inner node with two leaves split at the median centroid.
  Node& n = nodes_[static_cast<std::size_t>(leaf)];
  std::array<std::uint32_t, kLeafCapacity> faces{};
  const std::int32_t count = n.count;
  std::copy(n.faces, n.faces + count, faces.begin());
  std::array<Vector3d, kLeafCapacity> c;
  Box cb;
  for (std::int32_t i = 0; i < count; ++i) {
    const auto& vs = m.vertices(Face(faces[static_cast<std::size_t>(i)]));
    c[static_cast<std::size_t>(i)] = (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0;
    cb.extend(c[static_cast<std::size_t>(i)]);
  }
  int axis = 0;
  (cb.max - cb.min).maxCoeff(&axis);
  std::array<int, kLeafCapacity> order{};
  for (int i = 0; i < count; ++i) order[static_cast<std::size_t>(i)] = i;
  for (int i = 1; i < count; ++i) {  // insertion sort: at most kLeafCapacity items
    const int x = order[static_cast<std::size_t>(i)];
    int j = i;
    for (; j > 0 && c[static_cast<std::size_t>(order[static_cast<std::size_t>(j - 1)])][axis] >
                        c[static_cast<std::size_t>(x)][axis];
         --j)
      order[static_cast<std::size_t>(j)] = order[static_cast<std::size_t>(j - 1)];
    order[static_cast<std::size_t>(j)] = x;
  }
  const std::int32_t l = newNode(leaf);
  newNode(leaf);  // may reallocate: no references into nodes_ held from here
  for (int k = 0; k < 2; ++k) {
    Node& child = nodes_[static_cast<std::size_t>(l + k)];
    const int from = k == 0 ? 0 : count / 2, to = k == 0 ? count / 2 : count;
    for (int i = from; i < to; ++i) {
      const std::uint32_t f = faces[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
      child.faces[child.count++] = f;
      faceLeaf_[f] = l + k;
    }
    fitLeaf(m, static_cast<std::size_t>(l + k));
  }
  Node& parent = nodes_[static_cast<std::size_t>(leaf)];
  parent.count = 0;
  parent.child[0] = l;
  parent.child[1] = l + 1;
  dirty.push_back(l);
  dirty.push_back(l + 1);
  const std::size_t d = depthOf(l);
  maxDepth_ = std::max(maxDepth_, d);
  if (d >= kMaxDepth) needsRebuild_ = true;
}

void TriangleBvh::insertFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  checkMesh(m, "insertFaces");
  if (faceLeaf_.size() < m.facesSize()) faceLeaf_.resize(m.facesSize(), -1);
  std::vector<std::int32_t> dirty;
  for (Face f : faces) {
    if (!m.isValid(f)) throw CollisionError("TriangleBvh::insertFaces: dead or foreign face");
    if (tracks(f)) {
      dirty.push_back(faceLeaf_[f.idx()]);
      continue;
    }
    std::int32_t leaf = chooseLeaf(m, f);
    if (nodes_[static_cast<std::size_t>(leaf)].count == kLeafCapacity) {
      splitLeaf(m, leaf, dirty);
      // Into the half whose box grows least.
      Box fb;
      for (mesh::Vertex v : m.vertices(f)) fb.extend(m.position(v));
      const Node& inner = nodes_[static_cast<std::size_t>(leaf)];
      double cost[2];
      for (int k = 0; k < 2; ++k) {
        const Box cbox = boxOf(static_cast<std::size_t>(inner.child[k]));
        Box u = cbox;
        u.extend(fb);
        cost[k] = halfArea(u) - halfArea(cbox);
      }
      leaf = inner.child[cost[1] < cost[0] ? 1 : 0];
    }
    Node& n = nodes_[static_cast<std::size_t>(leaf)];
    n.faces[n.count++] = f.idx();
    faceLeaf_[f.idx()] = leaf;
    dirty.push_back(leaf);
    ++tracked_;
    ++editsSinceBuild_;
  }
  refitUpwards(m, dirty);
  if (needsRebuild_) build(m);
}

void TriangleBvh::removeFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  checkMesh(m, "removeFaces");
  std::vector<std::int32_t> dirty;
  for (Face f : faces) {
    if (!tracks(f)) continue;
    const std::int32_t leaf = faceLeaf_[f.idx()];
    Node& n = nodes_[static_cast<std::size_t>(leaf)];
    for (std::int32_t i = 0; i < n.count; ++i)
      if (n.faces[i] == f.idx()) {
        n.faces[i] = n.faces[n.count - 1];
        --n.count;
        break;
      }
    faceLeaf_[f.idx()] = -1;
    dirty.push_back(leaf);
    --tracked_;
    ++editsSinceBuild_;
  }
  // Leaf boxes read only the faces still listed, so dead faces are never touched.
  refitUpwards(m, dirty);
}

SyncResult TriangleBvh::sync(const mesh::SurfaceMesh& m) {
  if (!built_) {
    build(m);
    return SyncResult::Rebuilt;
  }
  if (m.topologyVersion() == seenVersion_ && m.facesSize() == seenFaces_ && m.verticesSize() == seenVertices_)
    return SyncResult::Unchanged;
  const std::size_t deletedNow = m.facesSize() - m.nFaces();
  // Compaction renumbers faces; a shrinking mesh is another mesh: rebuild.
  if (m.facesSize() < seenFaces_ || m.verticesSize() < seenVertices_ || deletedNow < seenDeletedFaces_) {
    build(m);
    return SyncResult::Rebuilt;
  }
  if (faceLeaf_.size() < m.facesSize()) faceLeaf_.resize(m.facesSize(), -1);
  // Faces that changed shape without a new handle all touch a new vertex (split
  // edge/face/vertex, separate edge keep the old handles for one part).
  std::vector<Face> touched;
  for (std::size_t v = seenVertices_; v < m.verticesSize(); ++v) {
    const mesh::Vertex vh(v);
    if (!m.isValid(vh)) continue;
    for (mesh::Edge e : m.edges(vh))
      for (int k = 0; k < 2; ++k) {
        const Face f = m.face(e, k);
        if (f.isValid() && f.idx() < seenFaces_) touched.push_back(f);
      }
  }
  // Removal first, so dead faces never sit in a leaf a refit reads.
  std::size_t liveNew = 0;
  for (std::size_t f = seenFaces_; f < m.facesSize(); ++f) liveNew += m.isValid(Face(f)) ? 1 : 0;
  if (tracked_ + liveNew != m.nFaces()) {
    std::vector<Face> dead;
    for (std::size_t f = 0; f < seenFaces_; ++f)
      if (faceLeaf_[f] >= 0 && m.isDeleted(Face(f))) dead.push_back(Face(f));
    removeFaces(m, dead);
  }
  std::erase_if(touched, [&](Face f) { return !m.isValid(f); });
  refitFaces(m, touched);
  std::vector<Face> added;
  for (std::size_t f = seenFaces_; f < m.facesSize(); ++f)
    if (m.isValid(Face(f))) added.push_back(Face(f));
  insertFaces(m, added);
  remember(m);
  if (needsRebuild_ || editsSinceBuild_ > std::max<std::size_t>(facesAtBuild_, 64)) {
    build(m);
    return SyncResult::Rebuilt;
  }
  return SyncResult::Local;
}

void TriangleBvh::facesOverlapping(const Box& box, std::vector<Face>& out) const {
  if (hot_.empty()) return;
  const Vector3d lo = box.min.array() - pad_, hi = box.max.array() + pad_;
  std::array<std::int32_t, kStack> stack;
  std::size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::int32_t i = stack[--top];
    const HotNode& h = hot_[static_cast<std::size_t>(i)];
    if (h.lo[0] > hi[0] || h.lo[1] > hi[1] || h.lo[2] > hi[2] || lo[0] > h.hi[0] || lo[1] > h.hi[1] || lo[2] > h.hi[2])
      continue;
    if (h.child[0] < 0) {
      const Node& n = nodes_[static_cast<std::size_t>(i)];
      for (std::int32_t k = 0; k < n.count; ++k) out.push_back(Face(n.faces[k]));
    } else {
      stack[top++] = h.child[1];
      stack[top++] = h.child[0];
    }
  }
}

namespace {

// Separating-axis test of a triangle against boxes (after Akenine-Moller): the box
// axes (the caller's AABB test), the triangle's normal and the nine edge x axis
// cross products. The triangle's projections on the ten axes are computed once.
struct TriangleSat {
  Vector3d axis[10];
  double lo[10], hi[10];
  int n = 0;
  explicit TriangleSat(const Vector3d* t) {
    const Vector3d e[3] = {t[1] - t[0], t[2] - t[1], t[0] - t[2]};
    add(e[0].cross(e[1]), t);
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) add(Vector3d::Unit(k).cross(e[i]), t);
  }
  void add(const Vector3d& a, const Vector3d* t) {
    if (a.squaredNorm() == 0.0) return;  // parallel to a box axis: covered by the AABB test
    const double p0 = a.dot(t[0]), p1 = a.dot(t[1]), p2 = a.dot(t[2]);
    axis[n] = a;
    lo[n] = std::min({p0, p1, p2});
    hi[n] = std::max({p0, p1, p2});
    ++n;
  }
  // Plane only (cheap, for inner nodes) or all axes (leaves).
  [[nodiscard]] bool meets(const Vector3d& c, const Vector3d& h, bool all) const {
    const int count = all ? n : std::min(n, 1);
    for (int i = 0; i < count; ++i) {
      const double p = axis[i].dot(c), r = h.dot(axis[i].cwiseAbs());
      if (lo[i] - p > r || hi[i] - p < -r) return false;
    }
    return true;
  }
};

}  // namespace

void TriangleBvh::facesNearTriangle(const Vector3d& p0, const Vector3d& p1, const Vector3d& p2,
                                    std::vector<Face>& out) const {
  if (hot_.empty()) return;
  const Vector3d tri[3] = {p0, p1, p2};
  const TriangleSat sat(tri);
  Box tb;
  for (const Vector3d& p : tri) tb.extend(p);
  std::array<std::int32_t, kStack> stack;
  std::size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::int32_t i = stack[--top];
    const HotNode& h = hot_[static_cast<std::size_t>(i)];
    const Vector3d lo = Vector3d(h.lo[0], h.lo[1], h.lo[2]).array() - pad_;
    const Vector3d hi = Vector3d(h.hi[0], h.hi[1], h.hi[2]).array() + pad_;
    if (!(lo.array() <= hi.array()).all()) continue;  // empty leaf
    if ((lo.array() > tb.max.array()).any() || (hi.array() < tb.min.array()).any()) continue;
    const bool leaf = h.child[0] < 0;
    if (!sat.meets(0.5 * (lo + hi), 0.5 * (hi - lo), leaf)) continue;
    if (leaf) {
      const Node& n = nodes_[static_cast<std::size_t>(i)];
      for (std::int32_t k = 0; k < n.count; ++k) out.push_back(Face(n.faces[k]));
    } else {
      stack[top++] = h.child[1];
      stack[top++] = h.child[0];
    }
  }
}

void TriangleBvh::intersectSegment(const mesh::SurfaceMesh& m, const Vector3d& a, const Vector3d& b,
                                   std::vector<SurfaceHit>& out, QueryCounters* counters) const {
  checkMesh(m, "intersectSegment");
  out.clear();
  if (hot_.empty()) return;
  const Vector3d d = b - a;
  // Slab test against boxes grown by pad; axes the segment does not move along are
  // a plain interval test.
  double inv[3];
  bool moves[3];
  for (int k = 0; k < 3; ++k) {
    moves[k] = d[k] != 0.0;
    inv[k] = moves[k] ? 1.0 / d[k] : 0.0;
  }
  std::array<std::int32_t, kStack> stack;
  std::size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::int32_t i = stack[--top];
    const HotNode& h = hot_[static_cast<std::size_t>(i)];
    if (counters) ++counters->nodes;
    double t0 = 0.0, t1 = 1.0;
    bool hit = true;
    for (int k = 0; k < 3 && hit; ++k) {
      const double mn = static_cast<double>(h.lo[k]) - pad_, mx = static_cast<double>(h.hi[k]) + pad_;
      if (!moves[k]) {
        hit = a[k] >= mn && a[k] <= mx;
        continue;
      }
      double u = (mn - a[k]) * inv[k], w = (mx - a[k]) * inv[k];
      if (u > w) std::swap(u, w);
      t0 = std::max(t0, u);
      t1 = std::min(t1, w);
      hit = t0 <= t1;
    }
    if (!hit) continue;
    if (h.child[0] < 0) {
      const Node& n = nodes_[static_cast<std::size_t>(i)];
      if (counters) counters->faces += static_cast<std::size_t>(n.count);
      for (std::int32_t k = 0; k < n.count; ++k) {
        SurfaceHit sh = intersectSegmentFace(m, Face(n.faces[k]), a, b, tol_);
        if (sh.kind != HitKind::None) out.push_back(sh);
      }
    } else {
      stack[top++] = h.child[1];
      stack[top++] = h.child[0];
    }
  }
  if (out.size() > 1) canonicalizeHits(m, out, defaultMergeDistance(a, b, tol_));
}

BvhStats TriangleBvh::stats() const {
  BvhStats s;
  s.nodes = nodes_.size();
  for (const Node& n : nodes_)
    if (n.leaf()) {
      ++s.leaves;
      s.faces += static_cast<std::size_t>(n.count);
      if (n.count == 0) ++s.emptyLeaves;
    }
  s.maxDepth = maxDepth_;
  s.editsSinceBuild = editsSinceBuild_;
  s.builds = builds_;
  return s;
}

std::string TriangleBvh::check(const mesh::SurfaceMesh& m) const {
  std::ostringstream why;
  std::vector<int> seen(m.facesSize(), 0);
  if (hot_.size() != nodes_.size()) why << "hot array out of step\n";
  for (std::size_t i = 0; i < nodes_.size() && hot_.size() == nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    const Box nb = boxOf(i);
    if (hot_[i].child[0] != n.child[0] || hot_[i].child[1] != n.child[1]) why << "hot children of " << i << " stale\n";
    if (n.leaf()) {
      for (std::int32_t k = 0; k < n.count; ++k) {
        const Face f(n.faces[k]);
        if (f.idx() >= m.facesSize() || !m.isValid(f)) {
          why << "leaf " << i << " holds dead face " << f << "\n";
          continue;
        }
        ++seen[f.idx()];
        if (faceLeaf_[f.idx()] != static_cast<std::int32_t>(i)) why << "faceLeaf of " << f << " is wrong\n";
        for (mesh::Vertex v : m.vertices(f)) {
          const Vector3d& p = m.position(v);
          if ((p.array() < nb.min.array()).any() || (p.array() > nb.max.array()).any())
            why << "leaf " << i << " box misses a corner of " << f << "\n";
        }
      }
    } else {
      for (int k = 0; k < 2; ++k) {
        const Node& c = nodes_[static_cast<std::size_t>(n.child[k])];
        if (c.parent != static_cast<std::int32_t>(i)) why << "node " << n.child[k] << " has a wrong parent\n";
        if (n.child[k] <= static_cast<std::int32_t>(i)) why << "child index not after its parent\n";
        const Box cb = boxOf(static_cast<std::size_t>(n.child[k]));
        if (!cb.empty() && ((cb.min.array() < nb.min.array()).any() || (cb.max.array() > nb.max.array()).any()))
          why << "node " << i << " box misses child " << n.child[k] << "\n";
      }
    }
  }
  std::size_t live = 0;
  for (Face f : m.faces()) {
    ++live;
    if (seen[f.idx()] != 1) why << "face " << f << " is in " << seen[f.idx()] << " leaves\n";
  }
  if (live != tracked_) why << "tracked count " << tracked_ << " != live faces " << live << "\n";
  return why.str();
}

}  // namespace ld::collision
