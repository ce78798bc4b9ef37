#include "sim/collision/bvh.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <type_traits>

#include "sim/collision/motion_scan.h"
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace ld::collision {

using Eigen::Vector3d;
using mesh::Face;
using mesh::Vertex;

namespace {

constexpr std::size_t kStack = 128;         // > deepest tree (build caps SAH depth, local splits cap at kMaxDepth)
constexpr std::size_t kSahDepthLimit = 48;  // below this depth the build splits at the median (log depth)
constexpr int kBins = 12;
// Inputs of at least kMortonMin faces are built from their Morton order (sorted in
// O(n), split at the highest differing code bit) down to ranges of kSweepMax faces,
// which are split where the surface-area cost along that order is lowest: 45-70 ms
// of binned SAH at 100k faces become a few ms, with about the same query cost.
constexpr std::size_t kMortonMin = 4096;
constexpr std::ptrdiff_t kSweepMax = 16;
constexpr double kMortonAspect = 8.0;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Outward rounding to float without libm calls: step away by at least one float
// ulp (2^-23 relative) before rounding to nearest.
[[maybe_unused]] float roundDown(double x) { return static_cast<float>(x - (std::abs(x) * 1.2e-7 + 1e-30)); }
[[maybe_unused]] float roundUp(double x) { return static_cast<float>(x + (std::abs(x) * 1.2e-7 + 1e-30)); }

double maxAbs(const Vector3d& p) { return p.cwiseAbs().maxCoeff(); }

// Float anchors: a = float(x) (to nearest) is within 2^-24 |a| of x (2^-150 in the
// subnormal range). Boxes fitted around anchors are widened by twice that (room for the
// double arithmetic around it), so they hold the positions the anchors were rounded
// from, and the distance tracked in the slack is the distance beyond that rounding: a
// vertex just anchored has none, and a full refit leaves no grow (tight queries).
constexpr double kAnchorRel = 0x1p-23, kAnchorAbs = 0x1p-140;

// False only when intersectSegmentTriangle(a, b, p0, p1, p2, tol) certainly reports
// no hit: both ends clearly on one side of the plane, or a clear crossing clearly
// outside an edge. It repeats the exact test's first steps (same expressions, so the
// same roundings) and compares squares with a margin instead of taking roots;
// everything else goes to the exact test, so results stay bit-identical.
inline bool mayHit(const Vector3d& a, const Vector3d& b, double segScale, const Vector3d& p0, const Vector3d& p1,
                   const Vector3d& p2, const Tolerance& tol) {
  const double scale = std::max({segScale, maxAbs(p0), maxAbs(p1), maxAbs(p2)});
  const double eps = effectiveTolerance(tol, scale);
  const Vector3d e0 = p1 - p0, e1 = p2 - p1, e2 = p0 - p2;
  const Vector3d n = e0.cross(-e2);
  const double nn = n.squaredNorm();
  const double H0 = n.dot(a - p0), H1 = n.dot(b - p0);
  // |H| > eps |n| (the exact test's lim), with a relative margin for its roundings.
  const double lim2 = eps * eps * nn * (1.0 + 1e-9);
  const bool far0 = H0 * H0 > lim2, far1 = H1 * H1 > lim2;
  if (far0 && far1 && (H0 > 0) == (H1 > 0)) return false;
  if (!(far0 && far1)) return true;  // an end near the plane (or NaN): exact test
  // A clear crossing: the only possible contact is where the line meets the plane.
  const Vector3d q = a + (H0 / (H0 - H1)) * (b - a);
  // Unnormalised in-plane distance to edge i: (n x e_i).(q - c_i) = s_i |n| |e_i|.
  // Miss when some s_i < -(eps + margin); the margin covers the difference between
  // this crossing point and the exact test's (a few ulps of the coordinates).
  const double thr = eps + 1e-13 * (scale + 1.0);
  const double thr2 = thr * thr * nn * (1.0 + 1e-9);
  const Vector3d* c[3] = {&p0, &p1, &p2};
  const Vector3d* e[3] = {&e0, &e1, &e2};
  for (int i = 0; i < 3; ++i) {
    const double w = n.cross(*e[i]).dot(q - *c[i]);
    if (w < 0 && w * w > thr2 * e[i]->squaredNorm()) return false;
  }
  return true;
}

// Segment a->b against boxes: slab test with the inverse direction precomputed and
// the near/far planes chosen by its signs. An axis the segment does not move along
// has inv = +-inf: the products are +-inf (outside) or NaN (on the plane), and NaN
// never tightens the interval, so the test stays conservative without branches.
struct SegmentSlab {
  double a[3], inv[3];
  bool neg[3];
  double grow = 0.0;  // extra growth when the segment's tolerance exceeds the boxes' pad
  SegmentSlab(const Vector3d& pa, const Vector3d& pb, double g) : grow(g) {
    for (int k = 0; k < 3; ++k) {
      a[k] = pa[k];
      inv[k] = 1.0 / (pb[k] - pa[k]);
      neg[k] = std::signbit(inv[k]);
    }
  }
  // Entry parameter in [0, 1], or +inf when the segment misses the box.
  template <bool Grow>
  [[nodiscard]] double enter(const float* lo, const float* hi) const {
    double t0 = 0.0, t1 = 1.0;
    for (int k = 0; k < 3; ++k) {
      double l = lo[k], h = hi[k];
      if constexpr (Grow) {
        l -= grow;
        h += grow;
      }
      const double tn = ((neg[k] ? h : l) - a[k]) * inv[k], tf = ((neg[k] ? l : h) - a[k]) * inv[k];
      t0 = tn > t0 ? tn : t0;
      t1 = tf < t1 ? tf : t1;
    }
    return t0 <= t1 ? t0 : std::numeric_limits<double>::infinity();
  }
};

}  // namespace

// ---- traversal ----------------------------------------------------------------

// The one depth-first walk every query uses. test(node) -> bool; visit(leaf node)
// -> bool (true stops the walk).
template <class NodeTest, class LeafVisit>
void TriangleBvh::traverse(NodeTest&& test, LeafVisit&& visit) const {
  if (nodes_.empty()) return;
  std::array<std::uint32_t, kStack> stack;
  std::size_t top = 0;
  std::uint32_t i = 0;
  for (;;) {
    const Node& n = nodes_[i];
    if (test(n)) {
      if (!n.leaf()) {
        stack[top++] = n.index + 1;
        i = n.index;
        continue;
      }
      if (visit(n)) return;
    }
    if (top == 0) return;
    i = stack[--top];
  }
}

// Near-to-far: enter(node) -> entry parameter (+inf: miss); visit(leaf) -> the
// bound beyond which nodes are skipped (may shrink as hits are found).
template <class NodeTest, class LeafVisit>
void TriangleBvh::traverseOrdered(NodeTest&& enter, LeafVisit&& visit) const {
  if (nodes_.empty()) return;
  struct Item {
    std::uint32_t node;
    double t;
  };
  std::array<Item, kStack> stack;
  std::size_t top = 0;
  double bound = std::numeric_limits<double>::infinity();
  const double t0 = enter(nodes_[0]);
  if (t0 == std::numeric_limits<double>::infinity()) return;
  stack[top++] = {0, t0};
  while (top > 0) {
    const Item it = stack[--top];
    if (it.t > bound) continue;
    const Node& n = nodes_[it.node];
    if (n.leaf()) {
      bound = std::min(bound, visit(n));
      continue;
    }
    const double tl = enter(nodes_[n.index]), tr = enter(nodes_[n.index + 1]);
    const bool leftFirst = tl <= tr;
    const Item nearI{leftFirst ? n.index : n.index + 1, leftFirst ? tl : tr};
    const Item farI{leftFirst ? n.index + 1 : n.index, leftFirst ? tr : tl};
    // A missed box (+inf) is never pushed: before the first hit the bound is +inf too,
    // and inf <= inf would walk every missed subtree.
    constexpr double kMiss = std::numeric_limits<double>::infinity();
    if (farI.t != kMiss && farI.t <= bound) stack[top++] = farI;
    if (nearI.t != kMiss && nearI.t <= bound) stack[top++] = nearI;
  }
}

// ---- storage --------------------------------------------------------------------

TriangleBvh::Node TriangleBvh::emptyNode() {
  Node n{};
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = kInf;
    n.hi[k] = -kInf;
  }
  return n;
}

std::uint32_t TriangleBvh::newPair(std::uint32_t parent) {
  const auto i = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back(emptyNode());
  nodes_.push_back(emptyNode());
  parent_.push_back(parent);
  parent_.push_back(parent);
  return i;
}

std::uint32_t TriangleBvh::newBlock(std::uint32_t leaf) {
  blocks_.emplace_back();
  blockLeaf_.push_back(leaf);
  blockVerts_.push_back(BlockVerts{});
  return static_cast<std::uint32_t>(blocks_.size() - 1);
}

void TriangleBvh::makeLeaf(std::uint32_t node, const std::uint32_t* faces, std::size_t count,
                           const mesh::SurfaceMesh& m) {
  const std::uint32_t b = newBlock(node);
  Block& blk = blocks_[b];
  for (std::size_t i = 0; i < count; ++i) {
    const auto& vs = m.vertices(Face(faces[i]));
    blk.tri[i] = {faces[i], {vs[0].idx(), vs[1].idx(), vs[2].idx()}};
    faceSlot_[faces[i]] = b * kLeafCapacity + static_cast<std::uint32_t>(i);
  }
  nodes_[node].index = b;
  nodes_[node].count = static_cast<std::uint32_t>(count);
  updateBlockVerts(b);
}

void TriangleBvh::updateBlockVerts(std::uint32_t b) {
  BlockVerts& bv = blockVerts_[b];
  const Block& blk = blocks_[b];
  const std::uint32_t count = nodes_[blockLeaf_[b]].count;
  bv.n = 0;
  for (std::uint32_t j = 0; j < count; ++j)
    for (std::uint32_t v : blk.tri[j].v) {
      bool seen = false;
      for (std::uint32_t k = 0; k < bv.n; ++k) seen = seen || bv.v[k] == v;
      if (!seen) bv.v[bv.n++] = v;
    }
}

void TriangleBvh::fitBlock(const Vector3d* X, std::uint32_t b) {
  if (margin_ > 0.0) {
    // Fat box around the anchors; a corner that left its anchor's reach is
    // re-anchored here, and its other leaves are refitted after this round.
    const BlockVerts& bv = blockVerts_[b];
    const double limit = anchorReach();
    for (std::uint32_t j = 0; j < bv.n; ++j) {
      const std::uint32_t v = bv.v[j];
      const Vector3d a = anchor_[v].cast<double>();
      if (!((X[v] - a).cwiseAbs().array() <= limit + kAnchorRel * a.cwiseAbs().array() + kAnchorAbs).all()) {
        anchor_[v] = X[v].cast<float>();
        stale_.push_back(v);
      }
    }
    boxBlock(anchor_.data(), b);
  } else {
    boxBlock(X, b);
  }
}

namespace {
#if defined(__SSE2__)
// Min and max of n > 0 points P[v[j]], as doubles: (x, y) and z.
struct Extent {
  __m128d lxy, hxy, lz, hz;
};
inline Extent extentOf(const Vector3d* P, const std::uint32_t* v, std::uint32_t n) {
  const double* p = P[v[0]].data();
  Extent e{_mm_loadu_pd(p), _mm_loadu_pd(p), _mm_load_sd(p + 2), _mm_load_sd(p + 2)};
  for (std::uint32_t j = 1; j < n; ++j) {
    p = P[v[j]].data();
    const __m128d xy = _mm_loadu_pd(p), z = _mm_load_sd(p + 2);
    e.lxy = _mm_min_pd(e.lxy, xy);
    e.hxy = _mm_max_pd(e.hxy, xy);
    e.lz = _mm_min_sd(e.lz, z);
    e.hz = _mm_max_sd(e.hz, z);
  }
  return e;
}
// Float points (the anchors): min and max in float, widened once (exact, monotonic: the
// same as the extent of the widened points).
inline Extent extentOf(const Eigen::Vector3f* P, const std::uint32_t* v, std::uint32_t n) {
  const auto load = [&](std::uint32_t j, __m128& xy, __m128& z) {
    const float* p = P[v[j]].data();
    xy = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
    z = _mm_load_ss(p + 2);
  };
  __m128 lxy, lz;
  load(0, lxy, lz);
  __m128 hxy = lxy, hz = lz;
  for (std::uint32_t j = 1; j < n; ++j) {
    __m128 xy, z;
    load(j, xy, z);
    lxy = _mm_min_ps(lxy, xy);
    hxy = _mm_max_ps(hxy, xy);
    lz = _mm_min_ss(lz, z);
    hz = _mm_max_ss(hz, z);
  }
  const __m128d zero = _mm_setzero_pd();
  Extent e{_mm_cvtps_pd(lxy), _mm_cvtps_pd(hxy), _mm_cvtss_sd(zero, lz), _mm_cvtss_sd(zero, hz)};
  // Widened by the rounding bound (x - rho(x) and x + rho(x) are monotonic: the extreme
  // anchors give the extreme positions).
  const __m128d rel = _mm_set1_pd(kAnchorRel), abs0 = _mm_set1_pd(kAnchorAbs);
  const __m128d absMask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffffLL));
  const auto rho = [&](__m128d x) { return _mm_add_pd(_mm_mul_pd(_mm_and_pd(x, absMask), rel), abs0); };
  e.lxy = _mm_sub_pd(e.lxy, rho(e.lxy));
  e.hxy = _mm_add_pd(e.hxy, rho(e.hxy));
  e.lz = _mm_sub_sd(e.lz, rho(e.lz));
  e.hz = _mm_add_sd(e.hz, rho(e.hz));
  return e;
}
#endif
}  // namespace

template <class Point>
void TriangleBvh::boxBlock(const Point* P, std::uint32_t b) {
  Node& n = nodes_[blockLeaf_[b]];
  const BlockVerts& bv = blockVerts_[b];
  if (bv.n == 0) {
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = kInf;
      n.hi[k] = -kInf;
    }
    return;
  }
#if defined(__SSE2__)
  const auto [lxy, hxy, lz, hz] = extentOf(P, bv.v, bv.n);
  // roundDown / roundUp of (value -+ pad), two lanes at a time.
  const __m128d pad = _mm_set1_pd(pad_), rel = _mm_set1_pd(1.2e-7), tiny = _mm_set1_pd(1e-30);
  const __m128d absMask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffffLL));
  const auto down = [&](__m128d x) {
    x = _mm_sub_pd(x, pad);
    return _mm_cvtpd_ps(_mm_sub_pd(x, _mm_add_pd(_mm_mul_pd(_mm_and_pd(x, absMask), rel), tiny)));
  };
  const auto up = [&](__m128d x) {
    x = _mm_add_pd(x, pad);
    return _mm_cvtpd_ps(_mm_add_pd(x, _mm_add_pd(_mm_mul_pd(_mm_and_pd(x, absMask), rel), tiny)));
  };
  const __m128 lz4 = down(lz), hz4 = up(hz);
  _mm_storel_pi(reinterpret_cast<__m64*>(n.lo), down(lxy));
  _mm_store_ss(n.lo + 2, lz4);
  _mm_storel_pi(reinterpret_cast<__m64*>(n.hi), up(hxy));
  _mm_store_ss(n.hi + 2, hz4);
#else
  Eigen::Array3d lo = P[bv.v[0]].template cast<double>().array(), hi = lo;
  for (std::uint32_t j = 1; j < bv.n; ++j) {
    lo = lo.min(P[bv.v[j]].template cast<double>().array());
    hi = hi.max(P[bv.v[j]].template cast<double>().array());
  }
  if constexpr (std::is_same_v<Point, Eigen::Vector3f>) {  // widened as extentOf does
    lo -= kAnchorRel * lo.abs() + kAnchorAbs;
    hi += kAnchorRel * hi.abs() + kAnchorAbs;
  }
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = roundDown(lo[k] - pad_);
    n.hi[k] = roundUp(hi[k] + pad_);
  }
#endif
}

inline void TriangleBvh::fitInner(std::uint32_t i) {
  Node& n = nodes_[i];
  const Node& l = nodes_[n.index];
  const Node& r = nodes_[n.index + 1];
#if defined(__SSE2__)
  // Whole 16-byte groups (the fourth lane, index or count, is combined too but never
  // stored).
  const float* lf = reinterpret_cast<const float*>(&l);
  const float* rf = reinterpret_cast<const float*>(&r);
  const __m128 lo = _mm_min_ps(_mm_load_ps(lf), _mm_load_ps(rf));
  const __m128 hi = _mm_max_ps(_mm_load_ps(lf + 4), _mm_load_ps(rf + 4));
  _mm_storel_pi(reinterpret_cast<__m64*>(n.lo), lo);
  _mm_store_ss(n.lo + 2, _mm_movehl_ps(lo, lo));
  _mm_storel_pi(reinterpret_cast<__m64*>(n.hi), hi);
  _mm_store_ss(n.hi + 2, _mm_movehl_ps(hi, hi));
#else
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = std::min(l.lo[k], r.lo[k]);
    n.hi[k] = std::max(l.hi[k], r.hi[k]);
  }
#endif
}

Box TriangleBvh::boxOf(std::size_t i) const {
  const Node& n = nodes_[i];
  Box b;
  if (!(n.lo[0] <= n.hi[0])) return b;
  b.min = Vector3d(n.lo[0], n.lo[1], n.lo[2]);
  b.max = Vector3d(n.hi[0], n.hi[1], n.hi[2]);
  return b;
}

double TriangleBvh::effectivePad(double scale, const Tolerance& tol) {
  // The exact test accepts points up to eps outside every edge line, which near a
  // sharp corner reaches eps / sin(angle / 2) from it: 1024 eps covers corners down
  // to about 0.1 degree (thinner slivers are degenerate for the cutter anyway) and
  // is still nanometres at millimetre scale.
  return 1024.0 * effectiveTolerance(tol, scale) + 1e-300;
}

double TriangleBvh::queryGrow(const Vector3d& a, const Vector3d& b) const {
  // Boxes carry pad_ for coordinates up to padScale_; a segment (or a mesh moved)
  // far beyond that needs a larger pad at query time.
  const Box root = bounds();
  const double rootScale = root.empty() ? 0.0 : std::max(maxAbs(root.min), maxAbs(root.max));
  const double scale = std::max({maxAbs(a), maxAbs(b), rootScale});
  if (scale <= padScale_) return 0.0;
  return std::max(0.0, effectivePad(scale, tol_) - pad_);
}

void TriangleBvh::checkMesh(const mesh::SurfaceMesh& m, const char* where) const {
  if (!built_) throw CollisionError(std::string("TriangleBvh::") + where + ": tree not built");
  // Meshes only grow between syncs (compaction needs a sync()); fewer faces than the
  // tree has seen means another mesh.
  if (m.facesSize() < seenFaces_ || m.verticesSize() < seenVertices_)
    throw CollisionError(std::string("TriangleBvh::") + where +
                         ": mesh is smaller than the tree's (another mesh, or compacted without sync())");
}

// ---- build ----------------------------------------------------------------------

struct TriangleBvh::BuildItem {
  float lo[3], hi[3], c[3];
  std::uint32_t face;
};

namespace {

struct BinBox {
  float lo[3] = {kInf, kInf, kInf}, hi[3] = {-kInf, -kInf, -kInf};
  void extend(const float* l, const float* h) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], l[k]);
      hi[k] = std::max(hi[k], h[k]);
    }
  }
  [[nodiscard]] double halfArea() const {
    if (!(lo[0] <= hi[0])) return 0.0;
    const double x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
    return x * y + y * z + z * x;
  }
};

double halfArea(const Box& b) {
  if (b.empty()) return 0.0;
  const Vector3d e = b.max - b.min;
  return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
}

}  // namespace

void TriangleBvh::makeLeaf(std::uint32_t node, const BuildItem* first, const BuildItem* last,
                           const mesh::SurfaceMesh& m) {
  std::array<std::uint32_t, kLeafCapacity> faces{};
  const auto n = static_cast<std::size_t>(last - first);
  for (std::size_t i = 0; i < n; ++i) faces[i] = first[i].face;
  makeLeaf(node, faces.data(), n, m);
}

void TriangleBvh::buildNode(const mesh::SurfaceMesh& m, std::uint32_t node, BuildItem* first, BuildItem* last,
                            std::size_t depth) {
  maxDepth_ = std::max(maxDepth_, depth);
  const std::ptrdiff_t n = last - first;
  if (n <= kBuildLeafSize) return makeLeaf(node, first, last, m);
  float clo[3] = {kInf, kInf, kInf}, chi[3] = {-kInf, -kInf, -kInf};
  for (auto* p = first; p != last; ++p)
    for (int k = 0; k < 3; ++k) {
      clo[k] = std::min(clo[k], p->c[k]);
      chi[k] = std::max(chi[k], p->c[k]);
    }
  int bestAxis = -1, bestSplit = 0;
  double bestCost = std::numeric_limits<double>::infinity();
  if (depth < kSahDepthLimit) {
    // Binned SAH over the three axes: cost nL A(L) + nR A(R) (the constant terms do
    // not change which split is best).
    for (int k = 0; k < 3; ++k) {
      const float ext = chi[k] - clo[k];
      if (!(ext > 0)) continue;
      const float scale = static_cast<float>(kBins) / ext;
      BinBox bins[kBins];
      std::size_t count[kBins] = {};
      for (auto* p = first; p != last; ++p) {
        const int bi = std::min(kBins - 1, static_cast<int>((p->c[k] - clo[k]) * scale));
        bins[bi].extend(p->lo, p->hi);
        ++count[bi];
      }
      double rightArea[kBins];
      std::size_t rightCount[kBins];
      BinBox acc;
      std::size_t cnt = 0;
      for (int i = kBins - 1; i > 0; --i) {
        acc.extend(bins[i].lo, bins[i].hi);
        cnt += count[i];
        rightArea[i] = acc.halfArea();
        rightCount[i] = cnt;
      }
      BinBox left;
      std::size_t lc = 0;
      for (int i = 1; i < kBins; ++i) {  // split before bin i
        left.extend(bins[i - 1].lo, bins[i - 1].hi);
        lc += count[i - 1];
        if (lc == 0 || rightCount[i] == 0) continue;
        const double cost =
            static_cast<double>(lc) * left.halfArea() + static_cast<double>(rightCount[i]) * rightArea[i];
        if (cost < bestCost) {
          bestCost = cost;
          bestAxis = k;
          bestSplit = i;
        }
      }
    }
  }
  BuildItem* mid = nullptr;
  if (bestAxis >= 0) {
    const int k = bestAxis;
    const float scale = static_cast<float>(kBins) / (chi[k] - clo[k]);
    mid = std::partition(first, last, [&](const BuildItem& it) {
      return std::min(kBins - 1, static_cast<int>((it.c[k] - clo[k]) * scale)) < bestSplit;
    });
  }
  if (mid == nullptr || mid == first || mid == last) {
    // Median on the widest centroid axis (also for identical centroids).
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
    mid = first + n / 2;
    std::nth_element(first, mid, last,
                     [axis](const BuildItem& x, const BuildItem& y) { return x.c[axis] < y.c[axis]; });
  }
  const std::uint32_t c = newPair(node);
  nodes_[node].index = c;
  nodes_[node].count = kInner;
  buildNode(m, c, first, mid, depth + 1);
  buildNode(m, c + 1, mid, last, depth + 1);
}

void TriangleBvh::build(const mesh::SurfaceMesh& m) {
  travelling_ = false;
  nodes_.clear();
  parent_.clear();
  blocks_.clear();
  blockLeaf_.clear();
  blockVerts_.clear();
  inner_.clear();
  innerLate_.clear();
  innerLateSorted_ = true;
  faceSlot_.assign(m.facesSize(), kNone);
  std::vector<BuildItem> items;
  items.reserve(m.nFaces());
  double scale = 0.0;
  const Vector3d* P = m.positions().data();
  for (Face f : m.faces()) {
    const auto& vs = m.vertices(f);
    BuildItem it{};
    it.face = f.idx();
    Vector3d lo = P[vs[0].idx()], hi = lo;
    for (int c = 1; c < 3; ++c) {
      lo = lo.cwiseMin(P[vs[c].idx()]);
      hi = hi.cwiseMax(P[vs[c].idx()]);
    }
    for (int k = 0; k < 3; ++k) {
      it.lo[k] = static_cast<float>(lo[k]);
      it.hi[k] = static_cast<float>(hi[k]);
      it.c[k] = static_cast<float>(0.5 * (lo[k] + hi[k]));
    }
    scale = std::max({scale, maxAbs(lo), maxAbs(hi)});
    items.push_back(it);
  }
  // Headroom: the tissue may move and stretch before the next build.
  padScale_ = 2.0 * scale;
  pad_ = effectivePad(padScale_, tol_);
  nodes_.reserve(items.size() / 2 + 2);
  parent_.reserve(nodes_.capacity());
  blocks_.reserve(items.size() / 3 + 1);
  blockLeaf_.reserve(blocks_.capacity());
  blockVerts_.reserve(blocks_.capacity());
  maxDepth_ = 0;
  nodes_.push_back(emptyNode());
  parent_.push_back(kNone);
  if (items.size() < kMortonMin) {
    buildNode(m, 0, items.data(), items.data() + items.size(), 0);
  } else {
    // 30-bit Morton codes of the centroids in the centroids' bounding cube, sorted
    // with the item index by three 10-bit radix passes.
    float clo[3] = {kInf, kInf, kInf}, chi[3] = {-kInf, -kInf, -kInf};
    for (const BuildItem& it : items)
      for (int k = 0; k < 3; ++k) {
        clo[k] = std::min(clo[k], it.c[k]);
        chi[k] = std::max(chi[k], it.c[k]);
      }
    // Each axis on its own scale, but none finer than kMortonAspect x the widest: a
    // thin axis (the thickness of a layered tissue) splits a few levels below the
    // root, so parallel layers never share a leaf, while long thin objects keep
    // cells of bounded aspect. (Thinnest-axis-first and a larger aspect were tried:
    // near queries through both layers then test more boxes.)
    const double ext = std::max({chi[0] - clo[0], chi[1] - clo[1], chi[2] - clo[2]});
    double q[3];
    for (int k = 0; k < 3; ++k) {
      const double e = std::max(static_cast<double>(chi[k] - clo[k]), ext / kMortonAspect);
      q[k] = e > 0 ? 1023.0 / e : 0.0;
    }
    const auto spread = [](std::uint32_t x) {  // 10 bits -> every third bit
      x = (x | (x << 16)) & 0x030000FFu;
      x = (x | (x << 8)) & 0x0300F00Fu;
      x = (x | (x << 4)) & 0x030C30C3u;
      x = (x | (x << 2)) & 0x09249249u;
      return x;
    };
    std::vector<std::uint64_t> keys(items.size()), tmp(items.size());
    for (std::size_t i = 0; i < items.size(); ++i) {
      std::uint32_t code = 0;
      for (int k = 0; k < 3; ++k) {
        const double t = (static_cast<double>(items[i].c[k]) - static_cast<double>(clo[k])) * q[k];
        const auto cell = static_cast<std::uint32_t>(std::clamp(t, 0.0, 1023.0));
        code |= spread(cell) << (2 - k);
      }
      keys[i] = (static_cast<std::uint64_t>(code) << 32) | i;
    }
    for (int pass = 0; pass < 3; ++pass) {
      const int shift = 32 + 10 * pass;
      std::array<std::uint32_t, 1025> start{};
      for (std::uint64_t key : keys) ++start[((key >> shift) & 1023u) + 1];
      for (std::size_t b = 0; b < 1024; ++b) start[b + 1] += start[b];
      for (std::uint64_t key : keys) tmp[start[(key >> shift) & 1023u]++] = key;
      keys.swap(tmp);
    }
    std::vector<BuildItem> sorted(items.size());
    for (std::size_t i = 0; i < items.size(); ++i) sorted[i] = items[keys[i] & 0xffffffffu];
    buildMorton(m, 0, keys.data(), sorted.data(), sorted.data() + sorted.size(), 0);
  }
  listInner();
  tracked_ = items.size();
  editsSinceBuild_ = 0;
  facesAtBuild_ = items.size();
  ++builds_;
  needsRebuild_ = false;
  built_ = true;
  remember(m);
  refit(m);
}

void TriangleBvh::buildMorton(const mesh::SurfaceMesh& m, std::uint32_t node, const std::uint64_t* keys,
                              BuildItem* first, BuildItem* last, std::size_t depth) {
  const std::ptrdiff_t n = last - first;
  if (n <= kSweepMax) {
    buildSweep(m, node, first, last, depth);
    return;
  }
  maxDepth_ = std::max(maxDepth_, depth);
  const std::uint32_t c0 = static_cast<std::uint32_t>(keys[0] >> 32);
  const std::uint32_t c1 = static_cast<std::uint32_t>(keys[n - 1] >> 32);
  std::ptrdiff_t mid = n / 2;  // equal codes: median
  if (c0 != c1) {
    // The codes share every bit above the highest one that differs: the range splits
    // where that bit turns on.
    const int bit = 31 - std::countl_zero(c0 ^ c1);
    mid = std::partition_point(keys, keys + n, [bit](std::uint64_t k) { return ((k >> (32 + bit)) & 1u) == 0; }) - keys;
  }
  const std::uint32_t c = newPair(node);
  nodes_[node].index = c;
  nodes_[node].count = kInner;
  buildMorton(m, c, keys, first, first + mid, depth + 1);
  buildMorton(m, c + 1, keys + mid, first + mid, last, depth + 1);
}

void TriangleBvh::buildSweep(const mesh::SurfaceMesh& m, std::uint32_t node, BuildItem* first, BuildItem* last,
                             std::size_t depth) {
  maxDepth_ = std::max(maxDepth_, depth);
  const std::ptrdiff_t n = last - first;
  if (n <= kBuildLeafSize) return makeLeaf(node, first, last, m);
  // The split along the (Morton) order with the lowest cost nL A(L) + nR A(R).
  std::vector<double>& rightArea = sweepArea_;
  rightArea.resize(static_cast<std::size_t>(n));
  BinBox acc;
  for (std::ptrdiff_t i = n - 1; i > 0; --i) {
    acc.extend(first[i].lo, first[i].hi);
    rightArea[static_cast<std::size_t>(i)] = acc.halfArea();
  }
  BinBox left;
  std::ptrdiff_t best = n / 2;
  double bestCost = std::numeric_limits<double>::infinity();
  for (std::ptrdiff_t i = 1; i < n; ++i) {
    left.extend(first[i - 1].lo, first[i - 1].hi);
    const double cost =
        static_cast<double>(i) * left.halfArea() + static_cast<double>(n - i) * rightArea[static_cast<std::size_t>(i)];
    if (cost < bestCost) {
      bestCost = cost;
      best = i;
    }
  }
  const std::uint32_t c = newPair(node);
  nodes_[node].index = c;
  nodes_[node].count = kInner;
  buildSweep(m, c, first, first + best, depth + 1);
  buildSweep(m, c + 1, first + best, last, depth + 1);
}

void TriangleBvh::listInner() {
  inner_.clear();
  for (std::size_t i = nodes_.size(); i-- > 0;)
    if (!nodes_[i].leaf()) inner_.push_back(static_cast<std::uint32_t>(i));
  innerLate_.clear();
  innerLateSorted_ = true;
}

void TriangleBvh::remember(const mesh::SurfaceMesh& m) {
  seenVersion_ = m.topologyVersion();
  seenLayout_ = m.layoutVersion();
  seenJournal_ = m.editedFaces().size();
  seenFaces_ = m.facesSize();
  seenVertices_ = m.verticesSize();
  if (faceSlot_.size() < m.facesSize()) faceSlot_.resize(m.facesSize(), kNone);
}

// ---- refit ----------------------------------------------------------------------

void TriangleBvh::refit(const mesh::SurfaceMesh& m) {
  checkMesh(m, "refit");
  // Leaf boxes block by block (sequential reads of the distinct corners), then the
  // inner nodes from lists ordered children first: no recursion, no test per node.
  const Vector3d* P = m.positions().data();
  const auto nb = static_cast<std::uint32_t>(blocks_.size());
  // In double, rounded outwards once per box exactly as the local refits do. A float
  // path (positions converted once, boxes widened by ~2 ulps: slightly larger boxes)
  // was about 1.4x faster, but with it the cutter's cut-through tests crashed (in the
  // cutter's point location; cause not found yet), so it is not used. With a margin
  // the anchors are the positions (just copied): the boxes are fitted from the
  // anchors just written (the positions rounded to float; the rounding is the only
  // grow left), without fitBlock's per-corner anchor test (which cannot fire here and
  // was about half of the refit's time).
  travelling_ = false;
  if (margin_ > 0.0) {  // every vertex anchored where it is
    static_assert(sizeof(Vector3d) == 3 * sizeof(double) && sizeof(Eigen::Vector3f) == 3 * sizeof(float));
    anchor_.resize(m.verticesSize());
    slack_ = margin_;
    if (!anchor_.empty())
      detail::anchorCoordinates(activeScanKernel(), P[0].data(), anchor_[0].data(), 3 * anchor_.size());
    for (std::uint32_t b = 0; b < nb; ++b) boxBlock(anchor_.data(), b);
  } else {
    for (std::uint32_t b = 0; b < nb; ++b) boxBlock(P, b);
  }
  if (!innerLateSorted_) {
    std::sort(innerLate_.begin(), innerLate_.end(), std::greater<>());
    innerLateSorted_ = true;
  }
  // Leaves split after the build (all their descendants are such too) before the
  // build's inner nodes; each list from the highest index down.
  for (std::uint32_t i : innerLate_) fitInner(i);
  for (std::uint32_t i : inner_) fitInner(i);
  stale_.clear();  // (nothing to follow: every vertex was just anchored)
}

void TriangleBvh::beginRefit() {
  if (mark_.size() < nodes_.size()) {
    mark_.resize(nodes_.size(), 0);
    pending_.resize(nodes_.size(), 0);
  }
  if (++epoch_ == 0) {
    std::fill(mark_.begin(), mark_.end(), 0);
    epoch_ = 1;
  }
  scratch_.clear();
}

void TriangleBvh::addDirty(std::uint32_t i) {
  if (mark_[i] == epoch_) return;
  mark_[i] = epoch_;
  pending_[i] = 0;
  scratch_.push_back(i);
  // Count, per ancestor, its children in the set; stop at one already collected.
  for (std::uint32_t p = parent_[i]; p != kNone; p = parent_[p]) {
    if (mark_[p] == epoch_) {
      ++pending_[p];
      return;
    }
    mark_[p] = epoch_;
    pending_[p] = 1;
  }
}

template <class Visit>
void TriangleBvh::forEachLeafOf(const mesh::SurfaceMesh& m, Vertex v, Visit&& visit) const {
  if (!m.isValid(v)) return;
  const std::uint32_t* slot = faceSlot_.data();
  const std::size_t nSlots = faceSlot_.size();
  for (mesh::Edge e : m.edges(v))
    for (int k = 0; k < 2; ++k) {
      const Face f = m.face(e, k);  // invalid (all ones) beyond nSlots
      if (f.idx() >= nSlots || slot[f.idx()] == kNone) continue;
      visit(blockLeaf_[slot[f.idx()] / kLeafCapacity]);
    }
}

void TriangleBvh::finishRefit(const mesh::SurfaceMesh& m) {
  fitRound(m);
  // Vertices re-anchored in that round: their other leaves still hold boxes around the
  // old anchor. Each round re-anchors only vertices not re-anchored before, so it ends.
  while (!stale_.empty()) {
    staleWork_.swap(stale_);
    stale_.clear();
    beginRefit();
    for (std::uint32_t v : staleWork_) addVertexLeaves(m, Vertex(v));
    fitRound(m);
  }
}

void TriangleBvh::growAnchors(const mesh::SurfaceMesh& m) {
  // Vertices the tree has not seen yet are anchored where they are.
  const auto& X = m.positions();
  const std::size_t v = anchor_.size();
  anchor_.resize(X.size());
  if (v < X.size())  // rounded as refit() rounds them all
    detail::anchorCoordinates(activeScanKernel(), X[v].data(), anchor_[v].data(), 3 * (X.size() - v));
}

void TriangleBvh::setMotionMargin(const mesh::SurfaceMesh& m, double margin) {
  if (!(margin >= 0.0) || !std::isfinite(margin))
    throw CollisionError("TriangleBvh::setMotionMargin: margin must be finite and >= 0");
  margin_ = margin;
  slack_ = margin;
  travelling_ = false;
  if (margin_ == 0.0) {
    anchor_.clear();
    anchor_.shrink_to_fit();
  }
  refit(m);
}

std::size_t TriangleBvh::refitMoved(const mesh::SurfaceMesh& m, double maxMove) {
  checkMesh(m, "refitMoved");
  travelling_ = false;  // (slack_ is 0 then: the bound below finds no room)
  if (margin_ <= 0.0) {
    refit(m);
    return m.nVertices();
  }
  // Nobody moved farther than the slack the last pass left: every box still holds.
  // (The caller's bound may miss the rounding of x + dx: a few ulps of the coordinates.)
  const double move = maxMove + 4.0 * DBL_EPSILON * padScale_;
  if (move <= slack_) {
    slack_ -= move;
    return 0;
  }
  if (anchor_.size() < m.verticesSize()) growAnchors(m);
  // With a bound from the caller, re-anchor at half the margin so the next steps fit
  // in the slack; without one, only what must be.
  return motionPass(m, std::isfinite(maxMove) ? 0.5 * margin_ : margin_);
}

std::size_t TriangleBvh::refitTravelled(const mesh::SurfaceMesh& m, std::span<double> travel,
                                        std::span<const std::uint32_t> past, std::size_t groupSize) {
  checkMesh(m, "refitTravelled");
  if (groupSize == 0) throw CollisionError("TriangleBvh::refitTravelled: groupSize must be > 0");
  if (margin_ <= 0.0) {
    refit(m);
    return m.nVertices();
  }
  if (anchor_.size() < m.verticesSize()) growAnchors(m);
  const std::size_t nv = m.verticesSize();
  const std::size_t groups = std::min(travel.size(), (nv + groupSize - 1) / groupSize);
  const std::size_t covered = std::min(nv, groups * groupSize);
  const double reach = kTravelReach * margin_;
  // Coming into the mode (the entries may hold anything: sums from before another
  // refit, or none of the moves since), or with many groups listed (a drop, a
  // renumbering): one pass brings every vertex within the reach, and every entry starts
  // from what the farthest of them left.
  if (!travelling_ || past.size() * groupSize > nv / 4) {
    travelling_ = false;
    const std::size_t anchored = motionPass(m, reach);
    std::fill(travel.begin(), travel.begin() + static_cast<std::ptrdiff_t>(groups), (margin_ - slack_) - reach);
    travelling_ = true;
    slack_ = 0.0;
    return anchored;
  }
  const Vector3d* X = m.positions().data();
  std::vector<std::uint32_t>& moving = moving_;
  moving.clear();
  // The farthest vertex of [v0, v1) that stays; those past the reach are re-anchored.
  const auto look = [&](std::size_t v0, std::size_t v1) {
    double worst = 0.0;
    for (std::size_t v = v0; v < v1; ++v) {
      const double d = (X[v] - anchor_[v].cast<double>()).cwiseAbs().maxCoeff();
      if (d <= reach)
        worst = std::max(worst, d);
      else
        moving.push_back(static_cast<std::uint32_t>(v));
    }
    return worst;
  };
  // The listed groups are cold (the step streamed the whole mesh since): their loads
  // are started together rather than one miss after another.
  for (std::uint32_t g : past) {
    if (g >= groups) continue;
    const auto* x = reinterpret_cast<const char*>(X + g * groupSize);
    const auto* a = reinterpret_cast<const char*>(anchor_.data() + g * groupSize);
    for (std::size_t o = 0; o < groupSize * sizeof(Vector3d); o += 64) __builtin_prefetch(x + o);
    for (std::size_t o = 0; o < groupSize * sizeof(Eigen::Vector3f); o += 64) __builtin_prefetch(a + o);
  }
  // A group that swung back and forth moved less than its entry says: the entry
  // restarts below 0, by what the farthest of its vertices has left of the reach.
  for (std::uint32_t g : past)
    if (g < groups) travel[g] = look(g * groupSize, std::min(nv, (g + 1) * groupSize)) - reach;
  look(covered, nv);
  return reanchor(m, moving);
}

bool TriangleBvh::sameBox(const Node& a, const Node& b) {
  return std::memcmp(a.lo, b.lo, sizeof a.lo) == 0 && std::memcmp(a.hi, b.hi, sizeof a.hi) == 0;
}

void TriangleBvh::fitUpwards(const mesh::SurfaceMesh& m, std::uint32_t leaf) {
  Node before = nodes_[leaf];
  fitLeaf(m, leaf);
  // An ancestor whose box comes out as it was: the ones above it hold as they are.
  for (std::uint32_t i = leaf; !sameBox(before, nodes_[i]);) {
    i = parent_[i];
    if (i == kNone) return;
    before = nodes_[i];
    fitInner(i);
  }
}

std::size_t TriangleBvh::reanchor(const mesh::SurfaceMesh& m, const std::vector<std::uint32_t>& vertices) {
  if (vertices.empty()) return 0;
  const Vector3d* X = m.positions().data();
  if (vertices.size() <= kFewReanchors) {
    // A few vertices (the steps of refitTravelled): each of their leaves is fitted and
    // its ancestors only while their boxes change. A vertex moved by less than the
    // margin seldom changes a box many levels up, and the climb to the root (cold
    // nodes, each a miss) was most of the cost. Leaves shared by several vertices are
    // fitted once a round.
    std::vector<std::uint32_t>& leaves = fewLeaves_;
    const auto collect = [&](std::uint32_t v) {
      forEachLeafOf(m, Vertex(v), [&](std::uint32_t leaf) {
        if (std::find(leaves.begin(), leaves.end(), leaf) == leaves.end()) leaves.push_back(leaf);
      });
    };
    leaves.clear();
    for (std::uint32_t v : vertices) {
      anchor_[v] = X[v].cast<float>();
      collect(v);
    }
    while (!leaves.empty()) {
      for (std::uint32_t leaf : leaves) fitUpwards(m, leaf);
      // Corners the fits re-anchored: their other leaves follow (each round re-anchors
      // only vertices not re-anchored before, so it ends).
      leaves.clear();
      fewStale_.swap(stale_);  // (not staleWork_: `vertices` may be it)
      stale_.clear();
      for (std::uint32_t v : fewStale_) collect(v);
    }
    return vertices.size();
  }
  beginRefit();
  for (std::uint32_t v : vertices) {
    anchor_[v] = X[v].cast<float>();
    addVertexLeaves(m, Vertex(v));
  }
  finishRefit(m);
  return vertices.size();
}

std::size_t TriangleBvh::motionPass(const mesh::SurfaceMesh& m, double theta) {
  ++motionPasses_;
  const Vector3d* X = m.positions().data();
  const Eigen::Vector3f* A = anchor_.data();
  const std::size_t nv = m.verticesSize();
  std::vector<std::uint32_t>& moving = staleWork_;  // (free here: finishRefit uses it later)
  moving.clear();
  // A vertex's leaves cost ~50x a vertex of the full refit (the faces around it, the
  // climb to the root): past a few percent of the vertices (a sag or a drift of the
  // whole tissue) one refit() of everything is cheaper, and leaves the full slack. The
  // scan stops as soon as that many are found (the count only grows).
  const std::size_t cutoff = nv / 32;
  double worst = 0.0;
  // Blocks of 8 vertices as 24 flat coordinates (SIMD, the widest build the CPU has);
  // only a block with a coordinate past theta is looked at vertex by vertex.
  const ScanKernel kernel = activeScanKernel();
  const std::size_t nb = nv / 8;
  const auto vertexByVertex = [&](std::size_t v0, std::size_t v1) {
    for (std::size_t v = v0; v < v1; ++v) {
      const double dv = (X[v] - A[v].cast<double>()).cwiseAbs().maxCoeff();
      if (dv <= theta) {
        worst = std::max(worst, dv);
        continue;
      }
      moving.push_back(static_cast<std::uint32_t>(v));
    }
    return moving.size() > cutoff;
  };
  for (std::size_t b = 0;; ++b) {
    if (nv > 0) b = detail::scanQuietBlocks(kernel, X[0].data(), A[0].data(), b, nb, theta, worst);
    if (vertexByVertex(8 * b, std::min(8 * b + 8, nv))) {
      refit(m);
      return m.nVertices();
    }
    if (b >= nb) break;
  }
  slack_ = margin_ - worst;
  return reanchor(m, moving);
}

void TriangleBvh::fitRound(const mesh::SurfaceMesh& m) {
  // Only the starts none of whose children is in the set; the others are fitted on
  // the way up, by the last of their children.
  std::size_t w = 0;
  for (std::uint32_t i : scratch_)
    if (pending_[i] == 0) scratch_[w++] = i;
  scratch_.resize(w);
  for (std::uint32_t i : scratch_) {
    fit(m, i);
    for (std::uint32_t p = parent_[i]; p != kNone && --pending_[p] == 0; p = parent_[p]) fitInner(p);
  }
}

void TriangleBvh::refitUpwards(const mesh::SurfaceMesh& m, std::vector<std::uint32_t>& dirty) {
  if (dirty.empty()) return;
  beginRefit();
  for (std::uint32_t i : dirty) addDirty(i);
  dirty.clear();
  finishRefit(m);
}

void TriangleBvh::reread(const mesh::SurfaceMesh& m, Face f) {
  const std::uint32_t s = faceSlot_[f.idx()];
  TriRef& r = blocks_[s / kLeafCapacity].tri[s % kLeafCapacity];
  const auto& vs = m.vertices(f);
  for (int c = 0; c < 3; ++c) r.v[c] = vs[static_cast<std::size_t>(c)].idx();
  updateBlockVerts(s / kLeafCapacity);
}

void TriangleBvh::refitFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  checkMesh(m, "refitFaces");
  dirty_.clear();
  for (Face f : faces)
    if (tracks(f) && m.isValid(f)) {
      reread(m, f);
      dirty_.push_back(leafOf(f));
    }
  refitUpwards(m, dirty_);
}

inline void TriangleBvh::addVertexLeaves(const mesh::SurfaceMesh& m, Vertex v) {
  forEachLeafOf(m, v, [&](std::uint32_t leaf) { addDirty(leaf); });
}

void TriangleBvh::anchorMoved(const mesh::SurfaceMesh& m, std::uint32_t v) {
  // In refitTravelled's mode a group's entry may be below 0, less than a vertex
  // moved by someone else could be from its anchor: such a vertex is anchored anew.
  if (anchor_.size() < m.verticesSize()) growAnchors(m);
  if (v < anchor_.size()) anchor_[v] = m.positions()[v].cast<float>();
}

void TriangleBvh::refitVertices(const mesh::SurfaceMesh& m, std::span<const Vertex> moved) {
  checkMesh(m, "refitVertices");
  if (travelling_)
    for (Vertex v : moved) anchorMoved(m, v.idx());
  beginRefit();
  for (Vertex v : moved) addVertexLeaves(m, v);
  finishRefit(m);
}

void TriangleBvh::refitVertices(const mesh::SurfaceMesh& m, std::span<const std::uint32_t> moved) {
  static_assert(sizeof(Vertex) == sizeof(std::uint32_t));
  checkMesh(m, "refitVertices");
  if (travelling_)
    for (std::uint32_t v : moved) anchorMoved(m, v);
  beginRefit();
  for (std::uint32_t i : moved) addVertexLeaves(m, Vertex(i));
  finishRefit(m);
}

std::size_t TriangleBvh::refitListed(const mesh::SurfaceMesh& m, std::span<const std::uint32_t> moved) {
  checkMesh(m, "refitListed");
  const std::size_t nv = m.verticesSize();
  for (std::uint32_t v : moved)
    if (v >= nv) throw CollisionError("TriangleBvh::refitListed: vertex index " + std::to_string(v) + " out of range");
  // In the travelled mode a vertex's bound depends on its group's entry, which only
  // the physics knows: a few vertices are anchored anew and keep the mode.
  if (margin_ <= 0.0 || (travelling_ && moved.size() <= kFewListed)) {
    refitVertices(m, moved);
    return moved.size();
  }
  if (anchor_.size() < m.verticesSize()) growAnchors(m);
  const double theta = 0.5 * margin_;
  const Vector3d* X = m.positions().data();
  std::vector<std::uint32_t>& moving = moving_;
  moving.clear();
  double worst = 0.0;
  for (std::uint32_t v : moved) {
    const double d = (X[v] - anchor_[v].cast<double>()).cwiseAbs().maxCoeff();
    if (d <= theta)
      worst = std::max(worst, d);
    else
      moving.push_back(v);  // (a repeat is anchored twice, its leaves fitted once)
  }
  // No group is past the travel limit between syncs: every vertex is within the margin.
  if (travelling_) {
    travelling_ = false;
    slack_ = 0.0;
  }
  // The others are where they were: the bound on them holds; the listed add theirs.
  slack_ = std::min(slack_, margin_ - worst);
  return reanchor(m, moving);
}

// ---- local topology updates -----------------------------------------------------

std::size_t TriangleBvh::depthOf(std::uint32_t node) const {
  std::size_t d = 0;
  while (parent_[node] != kNone) {
    node = parent_[node];
    ++d;
  }
  return d;
}

std::uint32_t TriangleBvh::chooseLeaf(const mesh::SurfaceMesh& m, Face f) const {
  // The cheap, local answer: the leaf of a neighbour across an edge (cutting makes
  // new faces inside or next to the face it splits), preferring one with room.
  std::uint32_t best = kNone;
  for (mesh::Edge e : m.edges(f)) {
    const Face g = m.otherFace(e, f);
    if (g.isValid() && tracks(g)) {
      const std::uint32_t leaf = leafOf(g);
      if (best == kNone || nodes_[leaf].count < nodes_[best].count) best = leaf;
    }
  }
  if (best != kNone) return best;
  // Otherwise descend by least growth of surface area.
  Box fb;
  for (Vertex v : m.vertices(f)) fb.extend(m.position(v));
  std::uint32_t i = 0;
  while (!nodes_[i].leaf()) {
    const Node& n = nodes_[i];
    double cost[2];
    for (int k = 0; k < 2; ++k) {
      const Box cbox = boxOf(n.index + static_cast<std::uint32_t>(k));
      Box u = cbox;
      u.extend(fb);
      cost[k] = halfArea(u) - halfArea(cbox);
    }
    i = n.index + (cost[1] < cost[0] ? 1u : 0u);
  }
  return i;
}

void TriangleBvh::splitLeaf(const mesh::SurfaceMesh& m, std::uint32_t leaf, std::vector<std::uint32_t>& dirty) {
  // A full leaf becomes an inner node over two leaves split at the median centroid
  // of its faces; the left child keeps the block, the right one gets a new block.
  const std::uint32_t oldBlock = nodes_[leaf].index;
  const std::uint32_t count = nodes_[leaf].count;
  std::array<TriRef, kLeafCapacity> tris{};
  std::copy(blocks_[oldBlock].tri, blocks_[oldBlock].tri + count, tris.begin());
  const Vector3d* P = m.positions().data();
  std::array<Vector3d, kLeafCapacity> c;
  Box cb;
  for (std::uint32_t i = 0; i < count; ++i) {
    c[i] = (P[tris[i].v[0]] + P[tris[i].v[1]] + P[tris[i].v[2]]) / 3.0;
    cb.extend(c[i]);
  }
  int axis = 0;
  (cb.max - cb.min).maxCoeff(&axis);
  std::array<std::uint32_t, kLeafCapacity> order{};
  for (std::uint32_t i = 0; i < count; ++i) order[i] = i;
  for (std::uint32_t i = 1; i < count; ++i) {  // insertion sort of at most 4 (std::sort trips -Warray-bounds)
    const std::uint32_t x = order[i];
    std::uint32_t j = i;
    for (; j > 0 && c[order[j - 1]][axis] > c[x][axis]; --j) order[j] = order[j - 1];
    order[j] = x;
  }
  const std::uint32_t l = newPair(leaf);
  const std::uint32_t newB = newBlock(l + 1);
  blockLeaf_[oldBlock] = l;
  const std::uint32_t half = count / 2;
  for (int k = 0; k < 2; ++k) {
    const std::uint32_t child = l + static_cast<std::uint32_t>(k);
    const std::uint32_t blk = k == 0 ? oldBlock : newB;
    const std::uint32_t from = k == 0 ? 0 : half, to = k == 0 ? half : count;
    for (std::uint32_t i = from; i < to; ++i) {
      const TriRef& r = tris[order[i]];
      blocks_[blk].tri[i - from] = r;
      faceSlot_[r.face] = blk * kLeafCapacity + (i - from);
    }
    nodes_[child].index = blk;
    nodes_[child].count = to - from;
    updateBlockVerts(blk);
    fitLeaf(m, child);
    dirty.push_back(child);
  }
  nodes_[leaf].index = l;
  nodes_[leaf].count = kInner;
  innerLate_.push_back(leaf);
  innerLateSorted_ = false;
  const std::size_t d = depthOf(l);
  maxDepth_ = std::max(maxDepth_, d);
  if (d >= kMaxDepth) needsRebuild_ = true;
}

void TriangleBvh::insertFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  checkMesh(m, "insertFaces");
  if (faceSlot_.size() < m.facesSize()) faceSlot_.resize(m.facesSize(), kNone);
  dirty_.clear();
  for (Face f : faces) {
    if (!m.isValid(f)) throw CollisionError("TriangleBvh::insertFaces: dead or foreign face");
    if (tracks(f)) {
      reread(m, f);
      dirty_.push_back(leafOf(f));
      continue;
    }
    std::uint32_t leaf = chooseLeaf(m, f);
    if (nodes_[leaf].count == kLeafCapacity) {
      splitLeaf(m, leaf, dirty_);
      // Into the half whose box grows least.
      Box fb;
      for (Vertex v : m.vertices(f)) fb.extend(m.position(v));
      const std::uint32_t c = nodes_[leaf].index;
      double cost[2];
      for (int k = 0; k < 2; ++k) {
        const Box cbox = boxOf(c + static_cast<std::uint32_t>(k));
        Box u = cbox;
        u.extend(fb);
        cost[k] = halfArea(u) - halfArea(cbox);
      }
      leaf = c + (cost[1] < cost[0] ? 1u : 0u);
    }
    Node& n = nodes_[leaf];
    const auto& vs = m.vertices(f);
    blocks_[n.index].tri[n.count] = {f.idx(), {vs[0].idx(), vs[1].idx(), vs[2].idx()}};
    faceSlot_[f.idx()] = n.index * kLeafCapacity + n.count;
    ++n.count;
    updateBlockVerts(n.index);
    dirty_.push_back(leaf);
    ++tracked_;
    ++editsSinceBuild_;
  }
  refitUpwards(m, dirty_);
  if (needsRebuild_) build(m);
}

void TriangleBvh::removeFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  removeTracked(m, faces, true);
}

void TriangleBvh::releaseFaces(const mesh::SurfaceMesh& m, std::span<const Face> faces) {
  removeTracked(m, faces, false);
}

void TriangleBvh::removeTracked(const mesh::SurfaceMesh& m, std::span<const Face> faces, bool countAsEdits) {
  checkMesh(m, "removeFaces");
  dirty_.clear();
  for (Face f : faces) {
    if (!tracks(f)) continue;
    const std::uint32_t s = faceSlot_[f.idx()];
    const std::uint32_t b = s / kLeafCapacity, pos = s % kLeafCapacity;
    const std::uint32_t leaf = blockLeaf_[b];
    Node& n = nodes_[leaf];
    // Swap the last face of the block into the hole.
    const std::uint32_t last = n.count - 1;
    if (pos != last) {
      blocks_[b].tri[pos] = blocks_[b].tri[last];
      faceSlot_[blocks_[b].tri[pos].face] = s;
    }
    --n.count;
    updateBlockVerts(b);
    faceSlot_[f.idx()] = kNone;
    dirty_.push_back(leaf);
    --tracked_;
    if (countAsEdits) ++editsSinceBuild_;
  }
  // Leaf boxes read only the faces still listed, so dead faces are never touched.
  refitUpwards(m, dirty_);
}

SyncResult TriangleBvh::remap(const mesh::SurfaceMesh& m, const mesh::Compaction& c) {
  travelling_ = false;  // renumbered: the groups hold other vertices
  // Already on this layout (synced since): the maps are stale, the tree is not.
  if (built_ && m.layoutVersion() == seenLayout_) return sync(m);
  // Maps from a mesh other than the one the tree knew: start over.
  if (!built_ || c.faceMap.size() < seenFaces_) {
    build(m);
    return SyncResult::Rebuilt;
  }
  const auto newFace = [&](std::uint32_t old) {
    const Face f = old < c.faceMap.size() ? c.faceMap[old] : Face();
    return m.isValid(f) ? f : Face();
  };
  std::size_t kept = 0;
  for (std::size_t b = 0; b < blocks_.size(); ++b) {
    const Node& n = nodes_[blockLeaf_[b]];
    for (std::uint32_t j = 0; j < n.count; ++j) kept += newFace(blocks_[b].tri[j].face).isValid() ? 1 : 0;
  }
  if (static_cast<double>(kept) < kRebuildFraction * static_cast<double>(tracked_)) {
    build(m);  // a small piece of a large tree: its own tree is cheaper to query
    return SyncResult::Rebuilt;
  }
  // Faces and corners renumbered in place; dropped faces leave their blocks.
  faceSlot_.assign(m.facesSize(), kNone);
  for (std::uint32_t b = 0; b < blocks_.size(); ++b) {
    Node& n = nodes_[blockLeaf_[b]];
    Block& blk = blocks_[b];
    std::uint32_t w = 0;
    for (std::uint32_t j = 0; j < n.count; ++j) {
      const Face f = newFace(blk.tri[j].face);
      if (!f.isValid() || faceSlot_[f.idx()] != kNone) continue;
      const auto& vs = m.vertices(f);
      blk.tri[w] = {f.idx(), {vs[0].idx(), vs[1].idx(), vs[2].idx()}};
      faceSlot_[f.idx()] = b * kLeafCapacity + w;
      ++w;
    }
    n.count = w;
    updateBlockVerts(b);
  }
  editsSinceBuild_ += tracked_ - kept;
  tracked_ = kept;
  remember(m);
  // Faces made after the last sync survive as faces the tree never saw.
  added_.clear();
  for (Face f : m.faces())
    if (!tracks(f)) added_.push_back(f);
  refit(m);
  const std::size_t buildsBefore = builds_;
  insertFaces(m, added_);
  if (builds_ != buildsBefore) return SyncResult::Rebuilt;
  return SyncResult::Local;
}

bool TriangleBvh::needsSync(const mesh::SurfaceMesh& m) const {
  return !built_ || m.layoutVersion() != seenLayout_ || m.editedFaces().size() != seenJournal_ ||
         m.facesSize() != seenFaces_;
}

SyncResult TriangleBvh::sync(const mesh::SurfaceMesh& m) {
  if (!needsSync(m)) {
    seenVersion_ = m.topologyVersion();
    seenVertices_ = m.verticesSize();
    return SyncResult::Unchanged;
  }
  // A new layout (compaction, clear, assignment) renumbers or replaces elements.
  if (!built_ || m.layoutVersion() != seenLayout_ || m.editedFaces().size() < seenJournal_ ||
      m.facesSize() < seenFaces_) {
    build(m);
    return SyncResult::Rebuilt;
  }
  if (faceSlot_.size() < m.facesSize()) faceSlot_.resize(m.facesSize(), kNone);
  // Every face created, deleted or re-set since the last sync, once each; its final
  // state decides: dead -> out, tracked -> re-read corners, new -> inserted.
  const auto journal = m.editedFaces().subspan(seenJournal_);
  if (faceMark_.size() < m.facesSize()) faceMark_.resize(m.facesSize(), 0);
  if (++faceEpoch_ == 0) {
    std::fill(faceMark_.begin(), faceMark_.end(), 0);
    faceEpoch_ = 1;
  }
  removed_.clear();
  added_.clear();
  std::vector<std::uint32_t>& dirty = dirtySync_;
  dirty.clear();
  for (Face f : journal) {
    if (f.idx() >= faceMark_.size() || faceMark_[f.idx()] == faceEpoch_) continue;
    faceMark_[f.idx()] = faceEpoch_;
    if (!m.isValid(f)) {
      if (tracks(f)) removed_.push_back(f);
    } else if (tracks(f)) {
      reread(m, f);
      dirty.push_back(leafOf(f));
    } else {
      added_.push_back(f);
    }
  }
  // Faces appended without a journal entry cannot exist, but be safe about sizes.
  for (std::size_t f = seenFaces_; f < m.facesSize(); ++f)
    if (faceMark_[f] != faceEpoch_ && m.isValid(Face(f)) && !tracks(Face(f))) added_.push_back(Face(f));
  refitUpwards(m, dirty);
  const std::size_t buildsBefore = builds_;
  removeFaces(m, removed_);
  insertFaces(m, added_);
  remember(m);
  if (builds_ != buildsBefore) return SyncResult::Rebuilt;
  if (needsRebuild_ ||
      static_cast<double>(editsSinceBuild_) > std::max(kRebuildFraction * static_cast<double>(facesAtBuild_), 64.0)) {
    build(m);
    return SyncResult::Rebuilt;
  }
  return SyncResult::Local;
}

// ---- queries --------------------------------------------------------------------

void TriangleBvh::facesOverlapping(const Box& box, std::vector<Face>& out) const {
  // Boxes already carry the pad; grow the query box by the same amount so that the
  // test is as loose as pad on both sides (and by how far the vertices may have left
  // the anchors the boxes were fitted around).
  const double g = pad_ + motionGrow();
  const Vector3d lo = box.min.array() - g, hi = box.max.array() + g;
  traverse(
      [&](const Node& h) {
        return !(h.lo[0] > hi[0] || h.lo[1] > hi[1] || h.lo[2] > hi[2] || lo[0] > h.hi[0] || lo[1] > h.hi[1] ||
                 lo[2] > h.hi[2]);
      },
      [&](const Node& leaf) {
        const Block& blk = blocks_[leaf.index];
        for (std::uint32_t k = 0; k < leaf.count; ++k) out.push_back(Face(blk.tri[k].face));
        return false;
      });
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
  const double g = pad_ + motionGrow();
  const Vector3d tri[3] = {p0, p1, p2};
  const TriangleSat sat(tri);
  Box tb;
  for (const Vector3d& p : tri) tb.extend(p);
  // Boxes carry pad_ already; the extra pad_ keeps the old (twice padded) looseness
  // for the SAT's own roundings.
  traverse(
      [&](const Node& h) {
        const Vector3d lo = Vector3d(h.lo[0], h.lo[1], h.lo[2]).array() - g;
        const Vector3d hi = Vector3d(h.hi[0], h.hi[1], h.hi[2]).array() + g;
        if (!(lo.array() <= hi.array()).all()) return false;  // empty leaf
        if ((lo.array() > tb.max.array()).any() || (hi.array() < tb.min.array()).any()) return false;
        return sat.meets(0.5 * (lo + hi), 0.5 * (hi - lo), h.leaf());
      },
      [&](const Node& leaf) {
        const Block& blk = blocks_[leaf.index];
        for (std::uint32_t k = 0; k < leaf.count; ++k) out.push_back(Face(blk.tri[k].face));
        return false;
      });
}

void TriangleBvh::intersectSegment(const mesh::SurfaceMesh& m, const Vector3d& a, const Vector3d& b,
                                   std::vector<SurfaceHit>& out, QueryCounters* counters) const {
  checkMesh(m, "intersectSegment");
  out.clear();
  const double grow = queryGrow(a, b) + motionGrow();
  const SegmentSlab slab(a, b, grow);
  const double segScale = std::max(maxAbs(a), maxAbs(b));
  const Vector3d* P = m.positions().data();
  QueryCounters qc;
  auto leafVisit = [&](const Node& leaf) {
    const Block& blk = blocks_[leaf.index];
    qc.faces += leaf.count;
    for (std::uint32_t k = 0; k < leaf.count; ++k) {
      const TriRef& r = blk.tri[k];
      const Vector3d &p0 = P[r.v[0]], &p1 = P[r.v[1]], &p2 = P[r.v[2]];
      if (!mayHit(a, b, segScale, p0, p1, p2, tol_)) continue;
      ++qc.exact;
      const SegTriResult res = intersectSegmentTriangle(a, b, p0, p1, p2, tol_);
      if (res.hit()) out.push_back(toSurfaceHit(m, Face(r.face), res));
    }
    return false;
  };
  if (grow == 0.0) {
    traverse(
        [&](const Node& n) {
          ++qc.nodes;
          return slab.enter<false>(n.lo, n.hi) <= 1.0;
        },
        leafVisit);
  } else {
    traverse(
        [&](const Node& n) {
          ++qc.nodes;
          return slab.enter<true>(n.lo, n.hi) <= 1.0;
        },
        leafVisit);
  }
  if (counters) {
    counters->nodes += qc.nodes;
    counters->faces += qc.faces;
    counters->exact += qc.exact;
  }
  if (out.size() > 1) canonicalizeHits(m, out, defaultMergeDistance(a, b, tol_));
}

bool TriangleBvh::anyHit(const mesh::SurfaceMesh& m, const Vector3d& a, const Vector3d& b,
                         QueryCounters* counters) const {
  checkMesh(m, "anyHit");
  const SegmentSlab slab(a, b, queryGrow(a, b) + motionGrow());
  const double segScale = std::max(maxAbs(a), maxAbs(b));
  const Vector3d* P = m.positions().data();
  QueryCounters qc;
  bool found = false;
  traverse(
      [&](const Node& n) {
        ++qc.nodes;
        return slab.enter<true>(n.lo, n.hi) <= 1.0;
      },
      [&](const Node& leaf) {
        const Block& blk = blocks_[leaf.index];
        for (std::uint32_t k = 0; k < leaf.count; ++k) {
          const TriRef& r = blk.tri[k];
          ++qc.faces;
          if (!mayHit(a, b, segScale, P[r.v[0]], P[r.v[1]], P[r.v[2]], tol_)) continue;
          ++qc.exact;
          if (intersectSegmentTriangle(a, b, P[r.v[0]], P[r.v[1]], P[r.v[2]], tol_).hit()) return found = true;
        }
        return false;
      });
  if (counters) {
    counters->nodes += qc.nodes;
    counters->faces += qc.faces;
    counters->exact += qc.exact;
  }
  return found;
}

bool TriangleBvh::firstHit(const mesh::SurfaceMesh& m, const Vector3d& a, const Vector3d& b, SurfaceHit& out,
                           QueryCounters* counters) const {
  checkMesh(m, "firstHit");
  const SegmentSlab slab(a, b, queryGrow(a, b) + motionGrow());
  const double segScale = std::max(maxAbs(a), maxAbs(b));
  const Vector3d* P = m.positions().data();
  const double md = defaultMergeDistance(a, b, tol_);
  const double len = (b - a).norm();
  // Canonicalisation moves a contact to a covering one at most md away (twice along
  // a chain interior -> edge -> vertex); the covering hits of those lie within md
  // again. So every hit up to 3 md past the earliest raw hit decides the front.
  const double window =
      len > 0.0 ? 3.0 * md / len * 1.01 + 16.0 * DBL_EPSILON : std::numeric_limits<double>::infinity();
  QueryCounters qc;
  std::vector<SurfaceHit> hits;
  std::vector<std::uint32_t> tested;  // faces that passed the cheap test (few)
  double tMin = std::numeric_limits<double>::infinity();
  auto test = [&](Face f, const Vector3d& p0, const Vector3d& p1, const Vector3d& p2) {
    ++qc.faces;
    if (!mayHit(a, b, segScale, p0, p1, p2, tol_)) return;
    if (std::find(tested.begin(), tested.end(), f.idx()) != tested.end()) return;
    tested.push_back(f.idx());
    ++qc.exact;
    const SegTriResult r = intersectSegmentTriangle(a, b, p0, p1, p2, tol_);
    if (!r.hit()) return;
    hits.push_back(toSurfaceHit(m, f, r));
    tMin = std::min(tMin, r.t);
  };
  auto testFace = [&](Face f) {
    const auto& vs = m.vertices(f);
    test(f, m.position(vs[0]), m.position(vs[1]), m.position(vs[2]));
  };
  traverseOrdered(
      [&](const Node& n) {
        ++qc.nodes;
        return slab.enter<true>(n.lo, n.hi);
      },
      [&](const Node& leaf) {
        const Block& blk = blocks_[leaf.index];
        for (std::uint32_t k = 0; k < leaf.count; ++k) {
          const TriRef& r = blk.tri[k];
          test(Face(r.face), P[r.v[0]], P[r.v[1]], P[r.v[2]]);
        }
        return tMin + window;
      });
  if (!hits.empty()) {
    // The same contact on a vertex or edge is reported by each face around it and
    // the canonical one is the lowest face's: test them all, wherever their t falls.
    // Hits past the window change nothing: they are neither first nor within the
    // merge distance of a hit that could be.
    for (std::size_t i = 0; i < hits.size(); ++i) {
      const SurfaceHit h = hits[i];
      if (h.kind == HitKind::OnVertex) {
        for (mesh::Edge e : m.edges(h.vertex))
          for (int k = 0; k < 2; ++k)
            if (m.face(e, k).isValid()) testFace(m.face(e, k));
      } else if (h.kind == HitKind::OnEdge) {
        for (int k = 0; k < 2; ++k)
          if (m.face(h.edge, k).isValid()) testFace(m.face(h.edge, k));
      }
    }
    if (hits.size() > 1) canonicalizeHits(m, hits, md);
    out = hits.front();
  }
  if (counters) {
    counters->nodes += qc.nodes;
    counters->faces += qc.faces;
    counters->exact += qc.exact;
  }
  return !hits.empty();
}

// ---- diagnostics ----------------------------------------------------------------

BvhStats TriangleBvh::stats() const {
  BvhStats s;
  s.nodes = nodes_.size();
  for (const Node& n : nodes_)
    if (n.leaf()) {
      ++s.leaves;
      s.faces += n.count;
      if (n.count == 0) ++s.emptyLeaves;
    }
  s.maxDepth = maxDepth_;
  s.editsSinceBuild = editsSinceBuild_;
  s.builds = builds_;
  s.bytes = nodes_.capacity() * sizeof(Node) + parent_.capacity() * 4 + blocks_.capacity() * sizeof(Block) +
            blockLeaf_.capacity() * 4 + faceSlot_.capacity() * 4 + blockVerts_.capacity() * sizeof(BlockVerts) +
            (inner_.capacity() + innerLate_.capacity()) * 4;
  return s;
}

std::string TriangleBvh::check(const mesh::SurfaceMesh& m) const {
  std::ostringstream why;
  std::vector<int> seen(m.facesSize(), 0);
  if (parent_.size() != nodes_.size()) why << "parent array out of step\n";
  if (blockLeaf_.size() != blocks_.size() || blockVerts_.size() != blocks_.size()) why << "block map out of step\n";
  std::size_t inner = 0;
  for (const Node& n : nodes_) inner += n.leaf() ? 0 : 1;
  const double grow = motionGrow();
  if (inner != inner_.size() + innerLate_.size()) why << "inner node lists out of step\n";
  for (std::size_t b = 0; b < blocks_.size() && b < blockVerts_.size() && b < blockLeaf_.size(); ++b) {
    // The cached corner list: exactly the distinct corners of the block's faces.
    std::vector<std::uint32_t> want, have(blockVerts_[b].v, blockVerts_[b].v + blockVerts_[b].n);
    const std::uint32_t count = blockLeaf_[b] < nodes_.size() ? nodes_[blockLeaf_[b]].count : 0;
    for (std::uint32_t k = 0; k < count && k < static_cast<std::uint32_t>(kLeafCapacity); ++k)
      want.insert(want.end(), blocks_[b].tri[k].v, blocks_[b].tri[k].v + 3);
    std::sort(want.begin(), want.end());
    want.erase(std::unique(want.begin(), want.end()), want.end());
    std::sort(have.begin(), have.end());
    if (want != have) why << "block " << b << " corner list is stale\n";
  }
  for (std::size_t i = 0; i < nodes_.size() && parent_.size() == nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    const Box nb = boxOf(i);
    if (n.leaf()) {
      if (n.count > static_cast<std::uint32_t>(kLeafCapacity)) why << "leaf " << i << " overfull\n";
      if (n.index >= blocks_.size() || blockLeaf_[n.index] != i) {
        why << "leaf " << i << " and its block disagree\n";
        continue;
      }
      for (std::uint32_t k = 0; k < n.count && k < static_cast<std::uint32_t>(kLeafCapacity); ++k) {
        const TriRef& r = blocks_[n.index].tri[k];
        const Face f(r.face);
        if (f.idx() >= m.facesSize() || !m.isValid(f)) {
          why << "leaf " << i << " holds dead face " << f << "\n";
          continue;
        }
        ++seen[f.idx()];
        if (faceSlot_[f.idx()] != n.index * kLeafCapacity + k) why << "slot of " << f << " is wrong\n";
        const auto& vs = m.vertices(f);
        for (int c = 0; c < 3; ++c) {
          if (r.v[c] != vs[static_cast<std::size_t>(c)].idx()) why << "stale corners of " << f << "\n";
          const Vector3d& p = m.position(vs[static_cast<std::size_t>(c)]);
          // (With a motion margin, as grown at query time.)
          if ((p.array() < nb.min.array() - grow).any() || (p.array() > nb.max.array() + grow).any())
            why << "leaf " << i << " box misses a corner of " << f << "\n";
        }
      }
    } else {
      for (std::uint32_t k = 0; k < 2; ++k) {
        const std::uint32_t c = n.index + k;
        if (c >= nodes_.size() || c <= i) {
          why << "child index of " << i << " not after its parent\n";
          continue;
        }
        if (parent_[c] != i) why << "node " << c << " has a wrong parent\n";
        const Box cb = boxOf(c);
        if (!cb.empty() && ((cb.min.array() < nb.min.array()).any() || (cb.max.array() > nb.max.array()).any()))
          why << "node " << i << " box misses child " << c << "\n";
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
