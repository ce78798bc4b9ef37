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

float roundDown(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
float roundUp(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

}  // namespace

void TriangleBvh::writeHot(std::size_t i) {
  if (hot_.size() < nodes_.size()) hot_.resize(nodes_.size());
  const Node& n = nodes_[i];
  HotNode& h = hot_[i];
  for (int k = 0; k < 3; ++k) {
    h.lo[k] = n.box.empty() ? std::numeric_limits<float>::infinity() : roundDown(n.box.min[k]);
    h.hi[k] = n.box.empty() ? -std::numeric_limits<float>::infinity() : roundUp(n.box.max[k]);
  }
  h.child[0] = n.child[0];
  h.child[1] = n.child[1];
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

void TriangleBvh::leafBox(const mesh::SurfaceMesh& m, Node& n) const {
  Box b;
  for (std::int32_t i = 0; i < n.count; ++i) {
    for (mesh::Vertex v : m.vertices(Face(n.faces[i]))) b.extend(m.position(v));
  }
  n.box = b;
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
  nodes_.reserve(2 * faces.size() / kBuildLeafSize + 2);
  maxDepth_ = 0;
  if (faces.empty()) {
    nodes_.emplace_back();  // an empty root leaf keeps every path simple
  } else {
    buildRange(m, faces.data(), faces.data() + faces.size(), centroid, -1, 0);
  }
  hot_.assign(nodes_.size(), HotNode{});
  for (std::size_t i = 0; i < nodes_.size(); ++i) writeHot(i);
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
  const auto index = static_cast<std::int32_t>(nodes_.size());
  nodes_.emplace_back();
  nodes_[static_cast<std::size_t>(index)].parent = parent;
  maxDepth_ = std::max(maxDepth_, depth);
  const std::ptrdiff_t n = last - first;
  if (n <= kBuildLeafSize) {
    Node& node = nodes_[static_cast<std::size_t>(index)];
    node.count = static_cast<std::int32_t>(n);
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      node.faces[i] = first[i];
      faceLeaf_[first[i]] = index;
    }
    leafBox(m, node);
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
  node.box = nodes_[static_cast<std::size_t>(l)].box;
  node.box.extend(nodes_[static_cast<std::size_t>(r)].box);
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
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    Node& n = nodes_[i];
    if (n.leaf()) {
      leafBox(m, n);
    } else {
      n.box = nodes_[static_cast<std::size_t>(n.child[0])].box;
      n.box.extend(nodes_[static_cast<std::size_t>(n.child[1])].box);
    }
    writeHot(i);
  }
}

void TriangleBvh::refitUpwards(const mesh::SurfaceMesh& m, std::vector<std::int32_t>& dirty) {
  // Process nodes from the highest index down; parents always come after children.
  std::sort(dirty.begin(), dirty.end(), std::greater<>());
  dirty.erase(std::unique(dirty.begin(), dirty.end()), dirty.end());
  std::make_heap(dirty.begin(), dirty.end());
  std::int32_t last = -1;
  while (!dirty.empty()) {
    std::pop_heap(dirty.begin(), dirty.end());
    const std::int32_t i = dirty.back();
    dirty.pop_back();
    if (i == last) continue;
    last = i;
    Node& n = nodes_[static_cast<std::size_t>(i)];
    if (n.leaf()) {
      leafBox(m, n);
    } else {
      n.box = nodes_[static_cast<std::size_t>(n.child[0])].box;
      n.box.extend(nodes_[static_cast<std::size_t>(n.child[1])].box);
    }
    writeHot(static_cast<std::size_t>(i));
    if (n.parent >= 0) {
      dirty.push_back(n.parent);
      std::push_heap(dirty.begin(), dirty.end());
    }
  }
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
      const Node& c = nodes_[static_cast<std::size_t>(n.child[k])];
      Box u = c.box;
      u.extend(fb);
      cost[k] = halfArea(u) - halfArea(c.box);
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
  const auto l = static_cast<std::int32_t>(nodes_.size());
  nodes_.emplace_back();
  nodes_.emplace_back();  // may reallocate: no references into nodes_ held from here
  for (int k = 0; k < 2; ++k) {
    Node& child = nodes_[static_cast<std::size_t>(l + k)];
    child.parent = leaf;
    const int from = k == 0 ? 0 : count / 2, to = k == 0 ? count / 2 : count;
    for (int i = from; i < to; ++i) {
      const std::uint32_t f = faces[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
      child.faces[child.count++] = f;
      faceLeaf_[f] = l + k;
    }
    leafBox(m, child);
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
        const Box& cbox = nodes_[static_cast<std::size_t>(inner.child[k])].box;
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
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& n = nodes_[i];
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
          if ((p.array() < n.box.min.array()).any() || (p.array() > n.box.max.array()).any())
            why << "leaf " << i << " box misses a corner of " << f << "\n";
        }
      }
    } else {
      for (int k = 0; k < 2; ++k) {
        const Node& c = nodes_[static_cast<std::size_t>(n.child[k])];
        if (c.parent != static_cast<std::int32_t>(i)) why << "node " << n.child[k] << " has a wrong parent\n";
        if (n.child[k] <= static_cast<std::int32_t>(i)) why << "child index not after its parent\n";
        if (!c.box.empty() &&
            ((c.box.min.array() < n.box.min.array()).any() || (c.box.max.array() > n.box.max.array()).any()))
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
