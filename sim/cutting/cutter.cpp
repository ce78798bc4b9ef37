#include "sim/cutting/cutter.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <limits>
#include <numeric>
#include <tuple>
#include <variant>

#include "sim/collision/bvh.h"
#include "sim/collision/point_triangle.h"
#include "sim/collision/segment_triangle.h"
#include "sim/cutting/mesh_checks.h"

namespace ld::cutting {

using instruments::Hand;
using instruments::Pose;
using instruments::Tool;
using mesh::Edge;
using mesh::Face;
using mesh::SurfaceMesh;
using mesh::Vertex;
using Vec3 = Eigen::Vector3d;

namespace {

bool dbg() {
  static bool d = std::getenv("LD_CUT_DEBUG") != nullptr;
  return d;
}

constexpr const char* kApexProp = "v:cut_apex";

bool sliverTrace() {
  static bool d = std::getenv("LD_CUT_SLIVER_TRACE") != nullptr;
  return d;
}

int handIndex(Hand h) { return h == Hand::Left ? 0 : 1; }

// The monotonic clock (vDSO, ~30 ns) times the edits, queries and separations, not the
// thread CPU clock: that one is a system call (1.2-1.7 us on a Firecracker VM with page
// table isolation, where each call also flushed the TLB), and with a few intervals a
// sample it took 75 % of a cut's wall time there (BM_Remesh/1: 19.8 -> 4.6 ms a run).
// Intervals are a few microseconds, so the core being taken away inside one is rare;
// the benchmarks take medians over repetitions.
double clockNow() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// The cost of an empty interval is measured once (smallest of many) and taken off every
// interval: intervals as short as one edit would otherwise partly measure the clock.
double timerOverhead() {
  static const double overhead = [] {
    double best = 1e9;
    for (int i = 0; i < 200; ++i) {
      const double a = clockNow();
      const double b = clockNow();
      best = std::min(best, b - a);
    }
    return best;
  }();
  return overhead;
}

struct IntervalTimer {
  double& acc;
  double t0 = clockNow();
  ~IntervalTimer() { acc += std::max(0.0, clockNow() - t0 - timerOverhead()); }
};

// One crossing of a cutting edge with a surface in the current sample.
struct Hit {
  int object = -1;
  int segment = -1;
  Face face;
  Vec3 point = Vec3::Zero();
  double t = 0.0;
  int dir = 0;  // +1: the edge (a->b) enters the material here, -1: leaves it
  Vec3 depth = Vec3::Zero();
  bool used = false;
  // A sheet's track ended on a slit between its tip and this crossing (advance): the way
  // back to that tip and the plane the walk followed, for the new track's start.
  struct PastSlit {
    Vec3 back = Vec3::Zero(), normal = Vec3::Zero();
  };
  // A track whose crossing slid back along it past its start ended (advance): the new
  // track starts next to that start instead, so the stretch between is cut.
  struct PastStart {
    Face face;
    Vec3 point = Vec3::Zero();
  };
  // Set when a track ended on this crossing (advance, one track at most): where the new one starts.
  std::variant<std::monostate, PastSlit, PastStart> restart;
};

// Set of vertex handles without a heap node per element (open addressing, linear
// probing; a cut's path only grows): membership tests are on the walk's hot path.
class VertexSet {
 public:
  [[nodiscard]] bool count(Vertex v) const {
    if (slots_.empty() || !v.isValid()) return false;
    for (std::size_t i = hash(v);; i = (i + 1) & mask()) {
      if (slots_[i] == v.idx()) return true;
      if (slots_[i] == kEmpty) return false;
    }
  }
  void insert(Vertex v) {
    if (!v.isValid()) return;
    if (2 * (size_ + 1) > slots_.size()) grow();
    for (std::size_t i = hash(v);; i = (i + 1) & mask()) {
      if (slots_[i] == v.idx()) return;
      if (slots_[i] == kEmpty) {
        slots_[i] = static_cast<std::uint32_t>(v.idx());
        ++size_;
        return;
      }
    }
  }
  template <class F>
  void forEach(F&& f) const {
    for (std::uint32_t x : slots_)
      if (x != kEmpty) f(Vertex(x));
  }

 private:
  static constexpr std::uint32_t kEmpty = 0xffffffffu;
  [[nodiscard]] std::size_t mask() const { return slots_.size() - 1; }
  [[nodiscard]] std::size_t hash(Vertex v) const { return (v.idx() * 0x9E3779B1u) & mask(); }
  void grow() {
    std::vector<std::uint32_t> old = std::move(slots_);
    slots_.assign(std::max<std::size_t>(16, 2 * old.size()), kEmpty);
    size_ = 0;
    for (std::uint32_t x : old)
      if (x != kEmpty) insert(Vertex(x));
  }
  std::vector<std::uint32_t> slots_;
  std::size_t size_ = 0;
};

// A point of the tissue: the corners of the face holding it and its barycentric
// weights there. It moves with the tissue when physics moves the vertices.
struct Anchor {
  std::array<Vertex, 3> corners{};
  Vec3 weights = Vec3::Zero();
  bool valid = false;
};

// One layer crossing followed through a stroke.
struct Track {
  int id = 0;
  int object = -1;  // object id
  int segment = -1;
  int dir = 0;
  bool alive = true;
  // Before the first permanent vertex: the start point (pierce-in), not yet inserted.
  bool hasStart = false;
  Vec3 start = Vec3::Zero();
  Vec3 startDepth = Vec3::Zero();
  Vec3 startMotion = Vec3::Zero();  // the edge's motion when the track began
  Hit::PastSlit startPastSlit;      // Hit::restart past a slit (else zero)
  Vec3 startBlade = Vec3::Zero();
  Face startFace;
  // The cut so far ends at `tip`. The front of the opening runs from tip through
  // `chain` (usually one vertex: the other layer's tip, or the groove's bottom);
  // empty until the cut has an edge.
  Vertex tip;
  std::vector<Vertex> chain;
  Vec3 tipDepth = Vec3::Zero();
  // tipDepth in the tissue's rest frame (home of tip + the blade's offset from it when
  // tip was made; NaN without homes): where the groove's bottom line is kept on moving
  // tissue.
  Vec3 tipRestDepth = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  // The blade's current point, inside a triangle next to tip (temporary).
  bool hasPending = false;
  Vec3 pending = Vec3::Zero();
  Vec3 pendingDepth = Vec3::Zero();
  // A face around tip holding the pending point (checked first on the next sample:
  // while the blade stays in it, a sample costs one point-in-triangle test).
  Face pendingFace;
  int partner = -1;  // track id of the other layer of a cut-through, or -1
  // Paired with a layer the blade went through in the middle of the object (a groove
  // that got deeper, or a pierce through both): the paths grow closed until both can
  // open, then openTunnel joins the layers (side walls; the object gets a hole).
  bool tunnel = false;
  // The walk has reached the wall of an earlier cut (another stroke's slot) and stops
  // there: when the partner has too, the pair cuts out across that wall.
  bool atWall = false;
  // Samples it has waited on such a wall with the blade's point past the matching radius
  // (advance: kWallWaitsPastRadius).
  int wallWaitsPastRadius = 0;
  VertexSet visited;  // path vertices, their copies and this cut's wall apexes
  // start and pending as points of the tissue (set at the end of every sample), and the
  // object's motion count they were taken at: a moved object moves them too.
  Anchor startAt, pendingAt;
  long anchoredAt = -1;
  Vertex prevTip;           // the path vertex before tip (the cut runs from it to tip)
  Vertex prevTipCopy;       // its other copy once the cut opened there (else none)
  Vertex first;             // the path's first vertex (a pierce's: the back end of the slot)
  double pathLength = 0.0;  // along the path so far (extend)
  Vec3 lastMotion = Vec3::Zero();  // the edge's motion in the last sample that moved it
};

// What one contact of a hand (from the blade's first crossing until it is out of the
// tissue with no cut open) has done to one object: the vertices its cuts made or
// walked (the lips and walls of this stroke's cut) and the faces it has added.
struct StrokeOnObject {
  int object = -1;
  VertexSet cut;          // visited vertices of this stroke's tracks that have ended
  long facesAtStart = 0;  // the object's faces when the stroke first cut it
  bool capped = false;    // grew past the stroke's budget: no more cutting until it ends
};

struct HandState {
  bool hasPrev = false;
  Tool tool = Tool::Scalpel;
  Pose prev;
  long motionAtPrev = -1;  // the engine's motionCount when prev was cut
  std::vector<Track> tracks;
  std::vector<StrokeOnObject> stroke;
};

double scaleOf(const Vec3& p) { return 1.0 + p.cwiseAbs().maxCoeff(); }

Pose lerpPose(const Pose& a, const Pose& b, double s) {
  Pose p = b;
  p.tip = a.tip + s * (b.tip - a.tip);
  Vec3 d = a.dir + s * (b.dir - a.dir);
  if (d.norm() > 1e-12) p.dir = d.normalized();
  Vec3 u = a.up + s * (b.up - a.up);
  u -= u.dot(p.dir) * p.dir;
  if (u.norm() > 1e-12) p.up = u.normalized();
  return p;
}

}  // namespace

const char* walkEndName(WalkEnd e) {
  switch (e) {
    case WalkEnd::Reached:
      return "reached";
    case WalkEnd::AtLip:
      return "at_lip";
    case WalkEnd::PastReach:
      return "past_reach";
    case WalkEnd::AtRim:
      return "at_rim";
    case WalkEnd::NoWay:
      return "no_way";
    case WalkEnd::Unreached:
      return "unreached";
    case WalkEnd::TooLong:
      return "too_long";
    case WalkEnd::Blocked:
      return "blocked";
    case WalkEnd::NotAdjacent:
      return "not_adjacent";
    case WalkEnd::Refused:
      return "refused";
    case WalkEnd::AtEarlierWall:
      return "at_earlier_wall";
    case WalkEnd::Count:
      break;
  }
  throw CutError("walkEndName: not a walk end");
}

struct CutEngine::Impl {
  CutParams p;
  std::vector<TissueObject> objects;
  std::vector<bool> hasTissue;
  // One BVH per object (same index as objects): the cutter's own edits reach it by
  // TriangleBvh::sync (local); moved vertices (physics, through object()) by a refit
  // at the next sample; compacted meshes (separation) by a rebuild.
  std::vector<collision::TriangleBvh> bvhs;
  std::vector<char> moved;                            // every vertex may have moved
  std::vector<double> moveBound;                      // by at most this (per coordinate) since the last sync
  std::vector<std::vector<std::uint32_t>> movedList;  // else these moved (verticesMoved)
  long motionCount = 0;                               // object()/verticesMoved calls: tracks re-anchor to the tissue
  std::vector<collision::SurfaceHit> scratchHits;
  std::vector<Face> scratchFaces;
  int nextId = 0;
  int nextTrackId = 0;
  HandState hands[2];
  CutStats stats;
  StepResult* res = nullptr;
  std::vector<int> checkSeparation;

  // ---- object access -------------------------------------------------------------
  int indexOf(int id) const {
    for (std::size_t i = 0; i < objects.size(); ++i)
      if (objects[i].id == id) return static_cast<int>(i);
    return -1;
  }
  // The object's index for the public calls that name it: CutError for an unknown id.
  std::size_t indexOfKnown(int id) const {
    const int i = indexOf(id);
    if (i < 0) throw CutError("no tissue object with id " + std::to_string(id));
    return static_cast<std::size_t>(i);
  }
  SurfaceMesh& meshOf(int id) { return objects[static_cast<std::size_t>(indexOf(id))].mesh; }
  bool closedObject(int id) const {
    const int i = indexOf(id);
    return objects[static_cast<std::size_t>(i)].closedAtStart || p.wallsOnOpenMeshes;
  }
  bool tissue(int id) const { return hasTissue[static_cast<std::size_t>(indexOf(id))]; }

  Track* trackById(int id) {
    if (id < 0) return nullptr;
    for (auto& h : hands)
      for (auto& t : h.tracks)
        if (t.id == id && t.alive) return &t;
    return nullptr;
  }

  // Room for the cuts to come (a quarter more of every element): without it the first
  // edit that outgrows a copied, loaded or compacted mesh (arrays exactly full) copies
  // every element array at once (on a 100k-triangle tissue, milliseconds in one sample).
  // The room is written once (no first-touch page faults inside a sample later), and
  // the engine's own per-face and per-vertex marks (the walk's face lists, the flips'
  // thin cache) are sized to it at the same time: sized on first use instead, they
  // were filled inside the first edits of a cut (on the CLI's expert straight line,
  // ~0.2 M of the 1.7 M instructions of its 78 cut triangles).
  void roomToCut(std::size_t k) {
    SurfaceMesh& m = objects[k].mesh;
    const std::size_t nv = m.verticesSize() + m.verticesSize() / 4 + 256;
    const std::size_t nf = m.facesSize() + m.facesSize() / 4 + 512;
    m.reserve(nv, m.edgesSize() + m.edgesSize() / 4 + 768, nf);
    m.touchReserved();  // the cuts fill it without first-touch page faults
    if (faceMark.size() < nf) {
      faceMark.resize(nf, 0);
      faceMarkAt.resize(nf, 0);
    }
    const int obj = objects[k].id;
    ThinCache& c = thinCacheEntry(obj);
    if (c.obj != obj) {
      c.obj = obj;
      c.layout = ~std::uint64_t{0};  // no mesh has it: thinCacheFor starts afresh
    }
    if (c.okGen.size() < nf) c.okGen.resize(nf, 0);
    if (c.settledGen.size() < nv) c.settledGen.resize(nv, 0);
  }

  // ---- physics hooks ---------------------------------------------------------------
  // Vertices edited in this sample, checked for pinches at its end (safety net).
  struct Dirty {
    int obj;
    Vertex v;
    bool fanChecked = false;  // found one fan after this edit (extend checks its own)
    std::uint32_t seq = 0;    // edit order (fixPinches)
    Dirty(int o, Vertex x) : obj(o), v(x) {}
  };
  std::vector<Dirty> dirty;
  // The tissue properties of the mesh last edited, looked up again only for another
  // mesh or a changed property set (several hooks run per edit).
  physics::TissueHandles tissueHandles;
  physics::TissueHandles& handlesOf(const SurfaceMesh& m) { return tissueHandles.of(m); }

  void touch(int obj, std::initializer_list<Vertex> vs) {
    for (Vertex v : vs)
      if (v.isValid()) dirty.emplace_back(obj, v);
    if (!tissue(obj)) return;
    physics::initEdgesAround(meshOf(obj), handlesOf(meshOf(obj)), std::span<const Vertex>(vs.begin(), vs.size()),
                             p.tissue);
  }

  // touch(obj, {v}) right after a physics::initVertexOnEdge/InFace hook, which has set
  // v's springs and its ring's masses (v's own last): the same values, computed once.
  void touchInitialised(int obj, Vertex v) {
    if (!tissue(obj)) return touch(obj, {v});
    if (v.isValid()) dirty.emplace_back(obj, v);
  }

  // touch(obj, {x}) for each x, in one go: the tissue hooks' results are the same (an
  // edge's spring reads only the homes, a mass only its vertex's springs and areas).
  void touchEach(int obj, std::span<const Vertex> vs) {
    for (Vertex v : vs)
      if (v.isValid()) dirty.emplace_back(obj, v);
    if (tissue(obj)) physics::initEdgesAround(meshOf(obj), handlesOf(meshOf(obj)), vs, p.tissue);
  }

  // ---- geometry helpers --------------------------------------------------------------
  // SurfaceMesh::faces(v) into a kept vector (the walk asks for every step).
  // Each face once, in the same order, by the engine's marks per face index (a const
  // mesh has no scratch of its own: its faces(v, out) searches a stack buffer or table,
  // and called here instead it cost 2 % more of the remesh's instructions).
  void facesAround(const SurfaceMesh& m, Vertex v, std::vector<Face>& out) {
    out.clear();
    newFaceMarks(m);
    for (Edge e : m.edges(v))
      for (int k = 0; k < 2; ++k)
        if (const Face f = m.face(e, k); f.isValid() && faceMark[f.idx()] != faceStamp) {
          faceMark[f.idx()] = faceStamp;
          out.push_back(f);
        }
  }
  // Per face index: the stamp of the listing that met it, and its place in that list.
  std::vector<std::uint32_t> faceMark, faceMarkAt;
  std::uint32_t faceStamp = 0;
  void newFaceMarks(const SurfaceMesh& m) {
    if (faceMark.size() < m.facesSize()) {
      faceMark.resize(m.facesSize() + 1024, 0);
      faceMarkAt.resize(faceMark.size(), 0);
    }
    if (++faceStamp == 0) {  // wrapped
      std::fill(faceMark.begin(), faceMark.end(), 0u);
      faceStamp = 1;
    }
  }

  static Vec3 rawNormal(const SurfaceMesh& m, Face f) {
    const auto& v = m.vertices(f);
    return (m.position(v[1]) - m.position(v[0])).cross(m.position(v[2]) - m.position(v[0]));
  }

  // Point within the triangle (on its plane up to rounding).
  static bool pointInFace(const SurfaceMesh& m, Face f, const Vec3& P, double baryTol = 1e-9) {
    const auto& v = m.vertices(f);
    const Vec3 &a = m.position(v[0]), &b = m.position(v[1]), &c = m.position(v[2]);
    const Vec3 n = (b - a).cross(c - a);
    const double n2 = n.squaredNorm();
    if (!(n2 > 0.0)) return false;
    // The barycentric tests first: most faces asked about (the fan around a walk's
    // tip) fail them, and then the distance test (square roots) is not needed. The
    // same tests as always, in another order: the same answer.
    const double l0 = n.dot((b - P).cross(c - P)) / n2;
    if (!(l0 >= -baryTol)) return false;
    const double l1 = n.dot((c - P).cross(a - P)) / n2;
    if (!(l1 >= -baryTol)) return false;
    const double l2 = 1.0 - l0 - l1;
    if (!(l2 >= -baryTol)) return false;
    const double nl = std::sqrt(n2);
    const double dist = std::abs(n.dot(P - a)) / nl;
    const double sc = std::max({scaleOf(a), scaleOf(b), scaleOf(c), scaleOf(P)});
    return !(dist > 1e-7 * sc + 1e-3 * std::sqrt(nl));
  }

  static Vec3 barycentric(const SurfaceMesh& m, Face f, const Vec3& P) {
    const auto& v = m.vertices(f);
    const Vec3 &a = m.position(v[0]), &b = m.position(v[1]), &c = m.position(v[2]);
    const Vec3 n = (b - a).cross(c - a);
    const double n2 = n.squaredNorm();
    if (!(n2 > 0.0)) return Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
    const double l0 = n.dot((b - P).cross(c - P)) / n2;
    const double l1 = n.dot((c - P).cross(a - P)) / n2;
    return Vec3(l0, l1, 1.0 - l0 - l1);
  }

  // The face containing P: the hint, the faces around its corners, else all faces.
  Face locate(const SurfaceMesh& m, Face hint, const Vec3& P) {
    if (m.isValid(hint) && pointInFace(m, hint, P)) return hint;
    if (m.isValid(hint)) {
      for (Vertex v : m.vertices(hint))
        for (Face f : m.faces(v))
          if (pointInFace(m, f, P)) return f;
    }
    Face best;
    double bestD = 1e-6 * scaleOf(P);
    // Only faces whose box is near P (the object's BVH), never the whole mesh.
    std::vector<Face> near;
    for (std::size_t i = 0; i < objects.size(); ++i)
      if (&objects[i].mesh == &m) {
        syncBvh(i);
        collision::Box box;
        box.extend(P);
        box.min.array() -= 1e-6 * scaleOf(P);
        box.max.array() += 1e-6 * scaleOf(P);
        bvhs[i].facesOverlapping(box, near);
      }
    for (Face f : near) {
      if (!m.isValid(f)) continue;
      if (pointInFace(m, f, P)) return f;
      // Rounding may leave P a hair outside every face: take the closest one.
      const Vec3 b = barycentric(m, f, P);
      if (b.minCoeff() < -1e-6) continue;
      const Vec3 n = rawNormal(m, f).normalized();
      const double d = std::abs(n.dot(P - m.position(m.vertices(f)[0])));
      if (d < bestD) {
        bestD = d;
        best = f;
      }
    }
    return best;
  }

  double snapTolerance(double edgeLength) const { return std::max(p.snapDistance, p.snapFraction * edgeLength); }

  // Where a split would make a triangle thinner than 0.3 of the snapping distance (next
  // to the floor the property test asserts, a quarter of it), the point moves onto an
  // end of the edge instead, up to the edge's middle. (Also moving it for triangles
  // under half the snapping distance, within 4 of them, moved cuts on moving tissue
  // enough to change the validity test's deviation by 20 %, for no floor gained.)
  double sliverHeight() const { return 0.3 * p.snapDistance; }
  static double sliverReach(double edgeLength) { return 0.5 * edgeLength; }

  // Smallest height of the triangles that splitting e at q makes.
  static double splitEdgeQuality(const SurfaceMesh& m, Edge e, const Vec3& q) {
    const Vec3 &pa = m.position(m.vertex(e, 0)), &pb = m.position(m.vertex(e, 1));
    double h = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 2; ++k)
      if (const Face g = m.face(e, k); g.isValid()) {
        const Vec3& pc = m.position(m.oppositeVertex(g, e));
        h = std::min({h, height(pa, q, pc), height(q, pb, pc)});
      }
    return h;
  }

  // The end of edge e that a point q on it snaps to, or none (split at q): an end
  // within the snapping tolerance, else, when the split would make a sliver, the
  // nearer end within reach. Ends in `avoid` (the cut itself) are not taken;
  // `blocked` tells that one was within the tolerance.
  Vertex edgeSnap(const SurfaceMesh& m, Edge e, const Vec3& q, const VertexSet* avoid, bool* blocked = nullptr) {
    Vertex a = m.vertex(e, 0), b = m.vertex(e, 1);
    double da = (q - m.position(a)).norm(), db = (q - m.position(b)).norm();
    if (db < da) {
      std::swap(a, b);
      std::swap(da, db);
    }
    const double L = m.edgeLength(e);
    const double tol = std::min(snapTolerance(L), 0.3 * L);
    auto free = [&](Vertex x) { return !avoid || !avoid->count(x); };
    if (da <= tol) {
      if (free(a)) return a;
      if (db <= tol && free(b)) return b;
      if (blocked) *blocked = true;
      return Vertex();
    }
    const double quality = splitEdgeQuality(m, e, q);
    if (quality >= sliverHeight()) return Vertex();
    bool onCut = false;
    for (const auto& [x, d] : {std::pair{a, da}, std::pair{b, db}}) {
      if (d > sliverReach(L)) continue;
      if (!free(x)) {
        onCut = true;
        continue;
      }
      ++stats.sliverSnaps;
      if (sliverTrace()) std::cerr << "sliverSnap edge d=" << d << " L=" << L << " q=" << quality << "\n";
      return x;
    }
    // The end to take is on the cut itself: stop there (as within the tolerance)
    // rather than leave a sliver.
    if (onCut && blocked) *blocked = true;
    return Vertex();
  }

  // A point q on edge e becomes a vertex (an end of e, see edgeSnap, or a new one).
  Vertex pointOnEdge(int obj, Edge e, const Vec3& q) {
    const Vertex x = edgeSnap(meshOf(obj), e, q, nullptr);
    return x.isValid() ? x : splitEdgeAt(obj, e, q);
  }

  // LD_CUT_SLIVER_TRACE: names the edit that left a thin triangle around `vs`.
  void traceThin(int obj, std::initializer_list<Vertex> vs, const char* what) {
    if (!sliverTrace()) return;
    const SurfaceMesh& m = meshOf(obj);
    for (Vertex v : vs) {
      if (!m.isValid(v)) continue;
      for (Face f : m.faces(v)) {
        const auto& fv = m.vertices(f);
        const double h = height(m.position(fv[0]), m.position(fv[1]), m.position(fv[2]));
        if (h < 0.25 * p.snapDistance) {
          std::cerr << "THIN " << what << " h=" << h << " kind " << m.getFaceProperty<int>(kFaceKindProp)[f] << ":";
          for (Vertex x : fv) std::cerr << " " << x << "(" << m.position(x).transpose() << ")";
          std::cerr << "\n";
          return;
        }
      }
    }
  }

  // ---- elementary edits with hooks ------------------------------------------------------
  Vertex splitEdgeAt(int obj, Edge e, const Vec3& q) {
    SurfaceMesh& m = meshOf(obj);
    const Vertex a = m.vertex(e, 0), b = m.vertex(e, 1);
    const double L = (m.position(b) - m.position(a)).norm();
    const double t = L > 0 ? std::clamp((q - m.position(a)).norm() / L, 0.0, 1.0) : 0.5;
    double hBefore = 1e300;
    if (sliverTrace())
      for (int k = 0; k < 2; ++k)
        if (const Face g = m.face(e, k); g.isValid()) {
          const auto& gv = m.vertices(g);
          hBefore = std::min(hBefore, height(m.position(gv[0]), m.position(gv[1]), m.position(gv[2])));
        }
    if (sliverTrace()) {
      std::cerr << "splitEdge " << a << "(" << m.position(a).transpose() << ") " << b << "("
                << m.position(b).transpose() << ") at t=" << t << " opp";
      for (int k = 0; k < 2; ++k)
        if (const Face g = m.face(e, k); g.isValid())
          std::cerr << " " << m.oppositeVertex(g, e) << "(" << m.position(m.oppositeVertex(g, e)).transpose() << ")";
      std::cerr << "\n";
    }
    const Vertex v = m.splitEdge(e, q);
    // No split keeps a two-triangle pillow (a flat piece a cut freed) manifold: the
    // point goes to the edge's nearer end, as a snap would.
    if (!v.isValid()) return t < 0.5 ? a : b;
    if (tissue(obj)) physics::initVertexOnEdge(m, handlesOf(m), v, a, b, t, p.tissue);
    touchInitialised(obj, v);
    traceThin(obj, {v}, hBefore < 0.25 * p.snapDistance ? "splitEdge/inherited" : "splitEdge/new");
    return v;
  }

  // Inserts P (inside f) as a vertex, snapping to a corner or an edge of f when closer
  // than the snapping tolerance. Returns the vertex (possibly an existing one).
  Vertex insertPoint(int obj, Face f, const Vec3& P) {
    SurfaceMesh& m = meshOf(obj);
    const auto v = m.vertices(f);
    const auto e = m.edges(f);
    double minEdge = 1e300;
    for (int i = 0; i < 3; ++i) minEdge = std::min(minEdge, m.edgeLength(e[static_cast<std::size_t>(i)]));
    const double tol = std::min(snapTolerance(minEdge), 0.3 * minEdge);
    int bestV = -1;
    double bestVD = tol;
    for (int i = 0; i < 3; ++i) {
      const double d = (m.position(v[static_cast<std::size_t>(i)]) - P).norm();
      if (d <= bestVD) {
        bestVD = d;
        bestV = i;
      }
    }
    if (bestV >= 0) return v[static_cast<std::size_t>(bestV)];
    // Edge i joins corner i and i+1.
    int bestE = -1;
    double bestED = tol;
    Vec3 proj = P;
    for (int i = 0; i < 3; ++i) {
      const Vec3& a = m.position(v[static_cast<std::size_t>(i)]);
      const Vec3& b = m.position(v[static_cast<std::size_t>((i + 1) % 3)]);
      const double s = std::clamp((P - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      const Vec3 q = a + s * (b - a);
      const double d = (q - P).norm();
      if (d <= bestED) {
        bestED = d;
        bestE = i;
        proj = q;
      }
    }
    if (bestE >= 0) return pointOnEdge(obj, e[static_cast<std::size_t>(bestE)], proj);
    double q = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i)
      q = std::min(q, height(m.position(v[static_cast<std::size_t>(i)]),
                             m.position(v[static_cast<std::size_t>((i + 1) % 3)]), P));
    if (q < sliverHeight()) {
      // Splitting f at P would make a sliver: onto the nearest edge or corner within
      // reach whose split does not (a corner makes no triangle at all). A corner is in
      // reach within the snapping distance too, where f's short edge (an earlier cut's)
      // brings half of it below that.
      double bestD = 1e300;
      Vertex to;
      Edge onto;
      for (int i = 0; i < 3; ++i) {
        const Vertex x = v[static_cast<std::size_t>(i)];
        const double d = (m.position(x) - P).norm();
        if (d < bestD && d <= std::max(sliverReach(minEdge), p.snapDistance)) {
          bestD = d;
          to = x;
          onto = Edge();
        }
        const Vec3& a = m.position(x);
        const Vec3& b = m.position(v[static_cast<std::size_t>((i + 1) % 3)]);
        const Vec3 x2 = a + std::clamp((P - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0) * (b - a);
        const double d2 = (x2 - P).norm();
        if (d2 < bestD && d2 <= sliverReach(minEdge) &&
            splitEdgeQuality(m, e[static_cast<std::size_t>(i)], x2) >= sliverHeight()) {
          bestD = d2;
          onto = e[static_cast<std::size_t>(i)];
          proj = x2;
        }
      }
      if (onto.isValid() || to.isValid()) {
        ++stats.sliverSnaps;
        if (sliverTrace()) std::cerr << "sliverSnap face d=" << bestD << " minEdge=" << minEdge << "\n";
        return onto.isValid() ? splitEdgeAt(obj, onto, proj) : to;
      }
    }
    const Vec3 bary = barycentric(m, f, P);
    const Vertex nv = m.splitFace(f, P);
    if (tissue(obj)) physics::initVertexInFace(m, handlesOf(m), nv, v[0], v[1], v[2], bary, p.tissue);
    touchInitialised(obj, nv);
    traceThin(obj, {nv}, "splitFace");
    return nv;
  }

  // ---- fans ---------------------------------------------------------------------------
  // Faces around x grouped by connection through edges at x that are not in `cuts`.
  std::vector<std::vector<Face>> fanGroups(const SurfaceMesh& m, Vertex x, const std::vector<Edge>& cuts) {
    std::vector<std::vector<Face>> groups(static_cast<std::size_t>(fanLabels(m, x, cuts)));
    for (std::size_t i = 0; i < fanFaces.size(); ++i)
      groups[static_cast<std::size_t>(fanLabel[i])].push_back(fanFaces[i]);
    return groups;
  }

  // The grouping without allocation (hot path: every extension): labels the faces
  // around x (fanFaces, in SurfaceMesh::faces order) 0, 1, ... in order of their first
  // face. Returns the number of groups.
  int fanLabels(const SurfaceMesh& m, Vertex x, std::span<const Edge> cuts) {
    // The faces in SurfaceMesh::faces order, and per edge side the face's place in that
    // list (found while listing it: no second search per edge).
    const auto& es = m.edges(x);
    fanFaces.clear();
    if (fanSide.size() < 2 * es.size()) fanSide.resize(2 * es.size());  // (only grows: no refill)
    newFaceMarks(m);
    for (std::size_t i = 0; i < es.size(); ++i)
      for (int k = 0; k < 2; ++k) {
        const Face f = m.face(es[i], k);
        int at = -1;
        if (f.isValid()) {
          if (faceMark[f.idx()] != faceStamp) {
            faceMark[f.idx()] = faceStamp;
            faceMarkAt[f.idx()] = static_cast<std::uint32_t>(fanFaces.size());
            fanFaces.push_back(f);
          }
          at = static_cast<int>(faceMarkAt[f.idx()]);
        }
        fanSide[2 * i + static_cast<std::size_t>(k)] = at;
      }
    const std::size_t n = fanFaces.size();
    fanParent.resize(n);
    fanLabel.resize(n);
    std::iota(fanParent.begin(), fanParent.end(), 0);
    // Roots are the smallest index of their group (a parent is always smaller); path
    // halving shortens the chains without changing any root.
    auto find = [&](int i) {
      while (fanParent[static_cast<std::size_t>(i)] != i) {
        const int up = fanParent[static_cast<std::size_t>(fanParent[static_cast<std::size_t>(i)])];
        fanParent[static_cast<std::size_t>(i)] = up;
        i = up;
      }
      return i;
    };
    for (std::size_t i = 0; i < es.size(); ++i) {
      const int i0 = fanSide[2 * i], i1 = fanSide[2 * i + 1];
      if (i0 < 0 || i1 < 0) continue;
      if (std::find(cuts.begin(), cuts.end(), es[i]) != cuts.end()) continue;
      const int r0 = find(i0), r1 = find(i1);
      if (r0 != r1) fanParent[static_cast<std::size_t>(std::max(r0, r1))] = std::min(r0, r1);
    }
    // A root is the smallest index of its group, so groups are met in fanGroups' order;
    // a parent comes before its child, so its label is known (no search to the root).
    int count = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const int up = fanParent[i];
      fanLabel[i] = up == static_cast<int>(i) ? count++ : fanLabel[static_cast<std::size_t>(up)];
    }
    return count;
  }

  // The faces labelled g by the last fanLabels, in its order.
  std::span<const Face> fanOf(int g) {
    fanPick.clear();
    for (std::size_t i = 0; i < fanFaces.size(); ++i)
      if (fanLabel[i] == g) fanPick.push_back(fanFaces[i]);
    return fanPick;
  }

  // Splits x so that every group of faces (separated by `cuts`) gets its own vertex.
  std::vector<Vertex> splitByGroups(int obj, Vertex x, const std::vector<Edge>& cuts) {
    SurfaceMesh& m = meshOf(obj);
    std::vector<Vertex> made;
    const int groups = fanLabels(m, x, cuts);
    if (groups < 2) return made;
    // Every group's faces first: the splits change the faces around x.
    fanGroupsBuf.resize(static_cast<std::size_t>(groups));
    for (int g = 1; g < groups; ++g) {
      const auto fan = fanOf(g);
      fanGroupsBuf[static_cast<std::size_t>(g)].assign(fan.begin(), fan.end());
    }
    for (int g = 1; g < groups; ++g) {
      const Vertex nv = m.splitVertex(x, fanGroupsBuf[static_cast<std::size_t>(g)]);
      if (!nv.isValid()) continue;
      if (tissue(obj)) physics::initVertexCopy(m, handlesOf(m), nv, x, p.tissue);
      made.push_back(nv);
    }
    return made;
  }

  // The edge of f at x other than e (f's two edges at x are the one leaving x and the
  // one arriving at it); invalid when x is not a corner of f.
  static Edge otherEdgeAt(const SurfaceMesh& m, Face f, Vertex x, Edge e) {
    const int k = m.localIndex(f, x);
    if (k < 0) return Edge();
    const auto& fe = m.edges(f);
    const Edge out = fe[static_cast<std::size_t>(k)], in = fe[static_cast<std::size_t>((k + 2) % 3)];
    return out == e ? in : out;
  }

  // The faces around x form one fan (walk across the edges at x from one face, no
  // allocation): what the safety net checks around every edit.
  static bool singleFan(const SurfaceMesh& m, Vertex x) {
    const auto& es = m.edges(x);
    if (es.empty()) return true;
    // The usual case first: the walk from the first edge comes back to it after one face
    // per edge. Then every edge at x was crossed (the faces and edges at x form paths and
    // cycles, which a walk that never turns back follows without meeting an edge twice),
    // so none is a boundary and the faces are one closed fan: the walk below would start
    // there too and count them all. Otherwise that walk decides.
    {
      const Edge start = es.front();
      Face f = m.face(start, 0);
      Edge e = start;
      std::size_t count = 0;
      while (f.isValid() && count < es.size()) {
        ++count;
        const Edge next = otherEdgeAt(m, f, x, e);
        if (!next.isValid()) break;
        if (next == start) {
          if (count == es.size()) return true;
          break;
        }
        e = next;
        f = m.otherFace(next, f);
      }
    }
    int twice = 0;
    Edge start = es.front();
    bool startOnBoundary = m.isBoundary(start);
    for (Edge e : es) {
      const bool boundary = m.isBoundary(e);
      twice += (m.face(e, 0).isValid() ? 1 : 0) + (boundary ? 0 : 1);
      if (boundary && !startOnBoundary) {
        start = e;
        startOnBoundary = true;
      }
    }
    const int total = twice / 2;
    Face f = m.face(start, 0);
    if (!f.isValid()) return total == 0;
    Edge e = start;
    int count = 0;
    while (count <= total) {
      ++count;
      const Edge next = otherEdgeAt(m, f, x, e);
      if (!next.isValid() || next == start) break;
      const Face g = m.otherFace(next, f);
      if (!g.isValid()) break;
      e = next;
      f = g;
    }
    return count == total;
  }

  void unpinch(int obj, Vertex x) {
    SurfaceMesh& m = meshOf(obj);
    if (!m.isValid(x) || singleFan(m, x)) return;
    const auto made = splitByGroups(obj, x, {});
    stats.unpinched += static_cast<long>(made.size());
  }

  // The face kind property, looked up once per edit instead of once per triangle.
  // And kept while the mesh's property set is the same (SurfaceMesh::propertySetVersion:
  // views stay valid and name the same properties), across calls too: looked up again
  // in each call, they were one lookup by name per slow sample.
  struct PropertyViews {
    const SurfaceMesh* mesh = nullptr;
    std::uint64_t propertySet = 0;
    mesh::FaceProperty<int> kinds;
    mesh::VertexProperty<std::uint8_t> apex;
  };
  mutable PropertyViews views;  // (a cache: const queries fill it too)
  PropertyViews& viewsOf(const SurfaceMesh& m) const {
    if (views.mesh != &m || views.propertySet != m.propertySetVersion())
      views = PropertyViews{&m, m.propertySetVersion(), {}, {}};
    return views;
  }
  // The face kind property for a query (null when m has none), without the lookup by
  // name once found: the walk's tests asked for it at every step.
  mesh::FaceProperty<int> kindsIn(const SurfaceMesh& m) const {
    PropertyViews& w = viewsOf(m);
    if (!w.kinds) w.kinds = m.getFaceProperty<int>(kFaceKindProp);
    return w.kinds;
  }
  mesh::FaceProperty<int> kindsOf(SurfaceMesh& m) {
    PropertyViews& w = viewsOf(m);
    if (!w.kinds) w.kinds = m.faceProperty<int>(kFaceKindProp, kSurface);
    return w.kinds;
  }
  mesh::VertexProperty<std::uint8_t> apexOf(SurfaceMesh& m) {
    PropertyViews& w = viewsOf(m);
    if (!w.apex) w.apex = m.vertexProperty<std::uint8_t>(kApexProp, 0);
    return w.apex;
  }

  static Face addTriangle(SurfaceMesh& m, mesh::FaceProperty<int>& kinds, Vertex a, Vertex b, Vertex c, int kind) {
    // A face running a -> b already rules out (a, b, c): try the other orientation first
    // (the same result, without the failed attempt).
    // The three sides are looked up once for both orientations.
    if (!m.isValid(a) || !m.isValid(b) || !m.isValid(c)) return m.addFace(a, b, c);  // throws
    const Edge ab = m.findEdge(a, b), bc = m.findEdge(b, c), ca = m.findEdge(c, a);
    bool flip = false;
    if (ab.isValid()) {
      const auto& fv = m.vertices(m.face(ab, 0));
      const int i = m.localIndex(m.face(ab, 0), a);
      flip = i >= 0 && fv[static_cast<std::size_t>((i + 1) % 3)] == b;
    }
    // (a, b, c) runs ab, bc, ca; (a, c, b) runs ca, bc, ab.
    Face f = flip ? m.addFace(a, c, b, {ca, bc, ab}) : m.addFace(a, b, c, {ab, bc, ca});
    if (!f.isValid() && !flip) f = m.addFace(a, c, b, {ca, bc, ab});
    if (f.isValid()) kinds[f] = kind;
    return f;
  }

  Face addTriangle(int obj, Vertex a, Vertex b, Vertex c, int kind) {
    SurfaceMesh& m = meshOf(obj);
    auto kinds = kindsOf(m);
    return addTriangle(m, kinds, a, b, c, kind);
  }

  // Fills the quad hole (x, n, y, o) with two triangles around o (apex invalid) or
  // four around a new vertex at apexPos. Returns the apex used, invalid on failure.
  Vertex fillQuad(int obj, Vertex x, Vertex n, Vertex y, Vertex o, bool newApex, const Vec3& apexPos, int kind) {
    SurfaceMesh& m = meshOf(obj);
    auto kinds = kindsOf(m);
    std::array<Face, 4> added{};
    std::size_t nAdded = 0;
    auto rollback = [&]() {
      for (std::size_t i = 0; i < nAdded; ++i) m.deleteFace(added[i]);
      nAdded = 0;
    };
    if (!newApex && !m.findEdge(n, o).isValid()) {
      for (auto tri : {std::array<Vertex, 3>{x, n, o}, std::array<Vertex, 3>{n, y, o}}) {
        const Face f = addTriangle(m, kinds, tri[0], tri[1], tri[2], kind);
        if (!f.isValid()) break;
        added[nAdded++] = f;
      }
      if (nAdded == 2) return o;
      rollback();
    }
    const Vec3 bestPos = apexPos;
    const Vertex B = m.addVertex(bestPos);
    for (auto tri : {std::array<Vertex, 3>{x, n, B}, std::array<Vertex, 3>{n, y, B}, std::array<Vertex, 3>{y, o, B},
                     std::array<Vertex, 3>{o, x, B}}) {
      const Face f = addTriangle(m, kinds, tri[0], tri[1], tri[2], kind);
      if (!f.isValid()) break;
      added[nAdded++] = f;
    }
    if (nAdded == 4) {
      apexOf(m)[B] = 1;
      if (tissue(obj)) {
        // (Its springs and mass: the caller's touchEach, extend being the only caller.)
        physics::copyVertexState(handlesOf(m), B, n);
        auto home = handlesOf(m).home;
        if (home) home[B] = home[n] + (bestPos - m.position(n));
      }
      return B;
    }
    rollback();
    m.deleteVertex(B);
    return Vertex();
  }

  // ---- the cut front ---------------------------------------------------------------------
  // Vertices of the cut (path, copies, wall apexes) are shared by both layers of a cut-through.
  void mark(Track& tr, Vertex v) {
    tr.visited.insert(v);
    if (Track* P = trackById(tr.partner)) P->visited.insert(v);
  }

  // Another track may have split an edge of this track's front since it was recorded
  // (slab 4452: a terminating track's splits on the front edge down a side face). The
  // vertices on that edge join the chain; else the front past them stays closed and the
  // opening is not the loop the fill expects. Only where an edge of the chain is missing
  // and a path of vertices on its segment joins its ends.
  void refreshChain(Track& tr) {
    SurfaceMesh& m = meshOf(tr.object);
    std::vector<Vertex>& chain = tr.chain;
    for (std::size_t i = 0; i + 1 < chain.size(); ++i) {
      const Vertex a = chain[i], b = chain[i + 1];
      if (m.findEdge(a, b).isValid()) continue;
      const Vec3 pa = m.position(a), ab = m.position(b) - pa;
      const double L2 = ab.squaredNorm();
      if (!(L2 > 0.0)) return;
      const double tol = 1e-9 * std::sqrt(L2);
      std::vector<Vertex> between;
      Vertex cur = a;
      double tCur = 0.0;
      while (cur != b && between.size() < 8) {
        Vertex best;
        double tBest = 2.0;
        for (Edge e : m.edges(cur)) {
          const Vertex x = m.otherVertex(e, cur);
          const Vec3 d = m.position(x) - pa;
          const double t = d.dot(ab) / L2;
          if (t > tCur && t <= 1.0 && t < tBest && (d - t * ab).norm() <= tol) {
            best = x;
            tBest = t;
          }
        }
        if (!best.isValid()) return;
        cur = best;
        tCur = tBest;
        if (cur != b) between.push_back(cur);
      }
      if (cur != b) return;
      if (dbg()) std::cerr << "refreshChain: " << between.size() << " vertices between " << a << " and " << b << "\n";
      for (Vertex x : between) mark(tr, x);
      chain.insert(chain.begin() + static_cast<std::ptrdiff_t>(i + 1), between.begin(), between.end());
      i += between.size();
    }
  }

  // Extends the track's cut from its tip to N (an edge (tip, N) exists): the old tip
  // opens into two vertices (and so does the rest of a front chain that was not open
  // yet), and the opening is closed at once with wall triangles.
  bool extend(Track& tr, Vertex N, const Vec3& depthN, bool lastStep = false) {
    SurfaceMesh& m = meshOf(tr.object);
    mark(tr, N);
    // The blade's depth point under N in the rest frame: N's home plus the blade's offset
    // from N now (as fillQuad places a new bottom vertex's home); NaN without homes.
    const auto home = tissue(tr.object) ? handlesOf(m).home : mesh::VertexProperty<Vec3>();
    const Vec3 restDepthN =
        home ? Vec3(home[N] + (depthN - m.position(N))) : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    auto tipToN = [&] {
      tr.tip = N;
      tr.tipDepth = depthN;
      tr.tipRestDepth = restDepthN;
    };
    if (!tr.tip.isValid()) {
      tipToN();
      tr.first = N;
      return true;
    }
    const Vertex v = tr.tip;
    if (N == v) return true;
    tr.pathLength += (m.position(N) - m.position(v)).norm();
    Track* P = trackById(tr.partner);
    tr.prevTip = v;
    tr.prevTipCopy = Vertex();
    // (assign: the chain keeps its buffer)
    auto advanceTo = [&](std::initializer_list<Vertex> chain) {
      tr.chain.assign(chain);
      tipToN();
      stats.longestFront = std::max(stats.longestFront, static_cast<long>(tr.chain.size()) + 1);
    };
    if (tr.tunnel) {
      // Nothing opens until both layers have a path that can (two edges each).
      tr.chain.insert(tr.chain.begin(), v);
      tipToN();
      stats.longestFront = std::max(stats.longestFront, static_cast<long>(tr.chain.size()) + 1);
      if (P && P->tunnel && tunnelReady(tr) && tunnelReady(*P)) openTunnel(tr, *P);
      return true;
    }
    if (tr.chain.empty()) {
      if (P && P->tip == v) P->chain = {N};
      advanceTo({v});
      return true;
    }
    refreshChain(tr);
    // Read before advanceTo replaces it (only this track's chain changes here).
    const std::vector<Vertex>& chain = tr.chain;
    const std::size_t chainLen = chain.size();
    const Vertex o = chain.front();
    const Edge eOut = m.findEdge(v, N), eFront = m.findEdge(v, o);
    if (!eOut.isValid() || !eFront.isValid() || std::find(chain.begin(), chain.end(), N) != chain.end()) {
      advanceTo({v});
      return true;
    }
    const bool walls = closedObject(tr.object);
    const bool paired = P != nullptr;
    const auto apexProp = apexOf(m);
    const double thr = 0.5 * p.snapDistance;
    // How to close the opening, decided on the geometry before anything changes:
    //  Fan  - triangles from N over the front (v, chain...): two for a one-vertex front;
    //  Apex - a new vertex (groove bottom at the blade's depth, or between the layers
    //         when N and the front are already joined by an edge): four triangles.
    // If neither gives triangles thicker than half the snapping distance (the blade has
    // hardly moved off the front, e.g. right after a slide-in, or moves along itself),
    // the front grows instead and opens with a later step.
    //  Halves - a longer front whose fan from N has a needle (its first edge runs on along
    //         the cut, as the cut-in path after a slide-in does on a fine mesh): each half
    //         of the opening, N ... chain.back() and its copy, triangulated on its own.
    enum class Fill { Fan, Apex, Halves, Defer } fill = Fill::Fan;
    Vec3 apexPos = Vec3::Zero();
    bool slide = false;  // a groove's bottom vertex o moves to slidePos (no new vertex)
    Vec3 slidePos = Vec3::Zero();
    if (walls) {
      const Vec3 pv = m.position(v), pN = m.position(N);
      const bool joinedNO = m.findEdge(N, o).isValid();  // (nothing changes before the fill)
      // The opening will be the loop N, v, chain..., copies of chain and v back to N.
      double qFan = -std::numeric_limits<double>::infinity();
      if (chain.size() == 1) {
        // Loop N, v, o, v': its only triangulation is two copies of (v, N, o).
        if (!joinedNO) qFan = height(pv, pN, m.position(o));
      } else {
        std::vector<Vertex> ids{N, v};
        ids.insert(ids.end(), chain.begin(), chain.end());
        for (std::size_t i = chain.size() - 1; i-- > 0;) ids.push_back(chain[i]);
        ids.push_back(v);
        qFan = fanQuality(m, ids);
      }
      const bool fanOk = qFan >= thr && !(chain.size() == 1 && joinedNO);
      double qApex = -1.0;
      if (chain.size() == 1) {
        const Vec3 po = m.position(o);
        // Between the layers: halfway from N to o, or inside the wall triangle when N and
        // o are already joined by an edge (both tips on a side face the blade is leaving
        // along: halfway would sit on that edge and leave the cut-out loop no area).
        Vec3 want = paired ? (joinedNO ? Vec3((pv + pN + po) / 3.0) : Vec3(0.5 * (pN + po))) : depthN;
        if (!paired && (depthN - pN).norm() < p.snapDistance) {
          // Keep the groove at least the snapping distance deep (no flat walls).
          const Vec3 n = rawNormal(m, m.face(eOut, 0)).normalized();
          want = pN - p.snapDistance * (n.allFinite() ? n : Vec3::UnitZ());
        }
        // (Between the layers with N and o joined the apex also keeps off their edge: on
        // it, as halfway between them, the cut-out loop over that edge has no area.)
        auto quality = [&](const Vec3& b) {
          const double q = std::min(height(pv, pN, b), height(pv, po, b));
          return paired && joinedNO ? std::min(q, height(pN, po, b)) : q;
        };
        apexPos = want;
        qApex = quality(want);
        for (const Vec3& c : {Vec3(0.5 * (want + po)), Vec3(0.5 * (pN + po)), Vec3((pv + pN + po) / 3.0)}) {
          if (qApex >= thr) break;
          const double q = quality(c);
          if (q > qApex) {
            qApex = q;
            apexPos = c;
          }
        }
      }
      const bool apexOk = qApex >= thr;
      if (paired || chain.size() > 1) {
        fill = fanOk ? Fill::Fan : (apexOk && chain.size() == 1 ? Fill::Apex : Fill::Defer);
        if (fill == Fill::Defer && chain.size() > 1 && halvesOk(m, N, v, chain, thr)) fill = Fill::Halves;
      } else {
        // Groove: the bottom vertex o is reused while the new wall triangle (v, N, o)
        // keeps a smallest angle of wallMinAngleDeg; else o slides on along the groove
        // toward the blade's depth when the new triangle and every one o carries keep it
        // (the bottom vertex stays under the middle of the path it fans to instead of
        // under its start, so one vertex serves a path about twice as long); else a new
        // bottom vertex goes under N. Where nothing keeps it (a short step under a deep
        // groove) the best of the three, a new vertex only when it beats both. The bottom
        // stays within reach of the blade's depth (grooveSpacing at the last step of a
        // cut) and on its line.
        const Vec3 po = m.position(o);
        const double sinFloor = std::sin(p.wallMinAngleDeg * M_PI / 180.0);
        const bool isApex = apexProp[o] != 0;
        const double depth = (depthN - pN).norm();
        // The bottom's line here: through the blade's depth points at v and N (not the
        // path vertices, which may be snapped off the sweep). On tissue with homes it is
        // kept in the rest frame: physics opens the cut and carries the bottom vertex
        // off the world's line (0.27 mm on the expert's straight line, against a
        // tolerance of 0.09), and every step would make a new one.
        const bool rest = home && restDepthN.allFinite() && tr.tipRestDepth.allFinite();
        const Vec3 fo = rest ? home[o] : po, fN = rest ? restDepthN : depthN;
        Vec3 along = fN - (rest ? tr.tipRestDepth : tr.tipDepth);
        if (!(along.norm() > 1e-3 * (pN - pv).norm())) along = rest ? Vec3(home[N] - home[v]) : Vec3(pN - pv);
        along = along.norm() > 0.0 ? Vec3(along.normalized()) : Vec3::Zero();
        const double reach =
            lastStep ? p.grooveSpacing : std::max({p.grooveSpacing, 4.0 * (pN - pv).norm(), kBottomReach * depth});
        const double offTol = std::max(p.snapDistance, kBottomDepthTol * depth);
        // Within reach of the blade's depth under N and on the bottom's line (a groove
        // getting deeper, or curving, gets bottom vertices more often).
        auto onLine = [&](const Vec3& q) {
          const Vec3 d = q - fN;
          return (d - d.dot(along) * along).norm() <= offTol;
        };
        auto inReach = [&](const Vec3& q) { return (q - fN).norm() < reach && onLine(q); };
        // o slid a fraction t of the way to the blade's depth (its home moves as far:
        // slideBottom).
        auto inReachAt = [&](double t) { return inReach(fo + t * (fN - fo)); };
        const double reuseSin = isApex && fanOk && inReach(fo) ? minAngleSin(pv, pN, po) : -1.0;
        double slideSin = -1.0;
        if (isApex && reuseSin < sinFloor && !joinedNO)
          slideSin = bestSlide(m, o, v, N, depthN, thr, inReachAt, onLine(fo), slidePos);
        if (reuseSin >= sinFloor) {
          fill = Fill::Fan;
        } else if (slideSin >= sinFloor) {
          fill = Fill::Fan;
          slide = true;
        } else {
          // Neither keeps the floor (a short step under a deep groove): the best of the
          // three; a new vertex only when it beats both.
          const double apexSin = apexOk ? std::min(minAngleSin(pv, pN, apexPos), minAngleSin(pv, po, apexPos)) : -1.0;
          if (apexOk && apexSin > std::max(reuseSin, slideSin))
            fill = Fill::Apex;
          else if (slideSin > 0.0 && slideSin >= reuseSin) {
            fill = Fill::Fan;
            slide = true;
          } else if (fanOk)
            fill = Fill::Fan;
          else
            fill = Fill::Defer;
        }
      }
      if (dbg() && paired)
        std::cerr << "pair step track " << tr.id << " chain " << chain.size() << " qFan " << qFan << " qApex " << qApex
                  << " fill " << static_cast<int>(fill) << " v " << v << m.position(v).transpose() << " N " << N
                  << m.position(N).transpose() << " o " << o << m.position(o).transpose() << " Ptip "
                  << (P ? P->tip : Vertex()) << "\n";
      if (dbg() && !paired && chain.size() == 1)
        std::cerr << "groove step to " << pN.transpose() << " fill " << static_cast<int>(fill) << "\n";
      if (dbg() && !paired && chain.size() > 1) {
        std::cerr << "groove chain step " << v << " -> " << N << "(" << pN.transpose() << ") fill "
                  << static_cast<int>(fill) << " chain";
        for (Vertex x : chain) std::cerr << " " << x << "(" << m.position(x).transpose() << ")";
        std::cerr << "\n";
      }
      if (fill == Fill::Defer) {
        if (P && !P->chain.empty() && P->chain.back() == v) P->chain.push_back(N);
        tr.chain.insert(tr.chain.begin(), v);  // the front grows: v, chain...
        tipToN();
        return true;
      }
    }
    const std::size_t facesBefore = m.facesSize();
    const std::array<Edge, 2> cutsAtV{eOut, eFront};
    Vertex vn;
    if (fanLabels(m, v, cutsAtV) == 2) {
      const std::size_t j0 = m.editedFaces().size();
      vn = m.splitVertex(v, fanOf(1));
      // Its faces only change a corner for a copy at the same place: the same shapes.
      if (vn.isValid()) keptShapes.push_back({tr.object, m.layoutVersion(), j0, m.editedFaces().size()});
    }
    if (!vn.isValid()) {
      // Cannot open here (should not happen on a manifold mesh): leave the slit closed.
      advanceTo({v});
      return true;
    }
    // (Springs and masses of v and vn once the walls are in: touchEach below.)
    if (tissue(tr.object)) physics::copyVertexState(handlesOf(m), vn, v);
    mark(tr, vn);
    tr.prevTipCopy = vn;
    std::vector<Vertex>& touched = extendTouched;
    touched.assign({v, vn, N});
    // A longer front (a cut-in path, or a front through a wall apex) opens as well.
    for (std::size_t i = 0; i + 1 < chainLen; ++i) {
      touched.push_back(chain[i]);
      const Edge e = m.findEdge(chain[i], chain[i + 1]);
      if (!e.isValid()) continue;
      for (Vertex x : splitByGroups(tr.object, chain[i], {e})) {
        mark(tr, x);
        touched.push_back(x);
      }
    }
    const Vertex chainBack = chain.back();
    touched.push_back(chainBack);
    std::array<Vertex, 2> next{v, Vertex()};
    std::size_t nextLen = 1;
    if (walls && chainLen == 1) {
      const Vertex apex =
          fillQuad(tr.object, vn, N, v, o, fill == Fill::Apex, apexPos, paired ? kSideWall : kGrooveWall);
      if (!apex.isValid()) {
        ++stats.fillFailures;
      } else if (apex == o) {
        if (slide) slideBottom(tr.object, o, slidePos, N, depthN);
        next[0] = o;
        if (P && P->tip == o) P->chain = {N};
      } else {
        mark(tr, apex);
        touched.push_back(apex);
        next[0] = apex;
        if (P && P->tip == o) {
          next[1] = o;
          nextLen = 2;
          P->chain = {apex, N};
        }
      }
    } else if (walls) {
      // A fan from N: the new front is the edge N - chain.back() (any other
      // triangulation would leave no edge there, and the next step would lose the front).
      const int kind = P ? kSideWall : kGrooveWall;
      const bool filled =
          fill == Fill::Halves ? fillHalvesAt(tr.object, N, chainBack, kind) : fillFanAt(tr.object, N, kind);
      if (!filled && !fillHoleAt(tr.object, N, kind)) ++stats.fillFailures;
      next[0] = chainBack;
      if (P && P->tip == chainBack) P->chain = {N};
    }
    if (nextLen == 2)
      advanceTo({next[0], next[1]});
    else
      advanceTo({next[0]});
    if (dbg()) {
      for (Vertex x : touched)
        if (m.isValid(x))
          for (Face f : m.faces(x)) {
            const auto& fv = m.vertices(f);
            const double h = height(m.position(fv[0]), m.position(fv[1]), m.position(fv[2]));
            if (h < 0.25 * p.snapDistance && f.idx() >= facesBefore)
              std::cerr << "extend made sliver h=" << h << " fill=" << static_cast<int>(fill) << " chain=" << chainLen
                        << " paired=" << paired << " f" << f.idx() << ": " << fv[0] << m.position(fv[0]).transpose()
                        << " " << fv[1] << m.position(fv[1]).transpose() << " " << fv[2]
                        << m.position(fv[2]).transpose() << "\n";
          }
    }
    const std::size_t dirtyBefore = dirty.size();
    touchEach(tr.object, touched);
    const long unpinchedBefore = stats.unpinched;
    for (Vertex x : touched) unpinch(tr.object, x);
    // Checked here and nothing split: the safety net need not walk these fans again
    // unless a later edit lists them.
    if (stats.unpinched == unpinchedBefore)
      for (std::size_t i = dirtyBefore; i < dirty.size(); ++i) dirty[i].fanChecked = true;
    if (sliverTrace())
      for (Vertex x : touched)
        traceThin(tr.object, {x}, fill == Fill::Apex ? "extend/apex" : (chainLen > 1 ? "extend/chain" : "extend/fan"));
    return true;
  }

  // A boundary edge at v (the first in v's edge order), invalid when v is interior.
  static Edge boundaryEdgeAt(const SurfaceMesh& m, Vertex v) {
    for (Edge e : m.edges(v))
      if (m.isBoundary(e)) return e;
    return Edge();
  }

  // Closes the boundary loop through `start` (an opening made by the cut) with
  // triangles: the triangulation of the loop whose smallest triangle is largest,
  // never reusing an existing edge as a diagonal.
  bool fillHoleAt(int obj, Vertex start, int kind) {
    SurfaceMesh& m = meshOf(obj);
    const Edge be = boundaryEdgeAt(m, start);
    if (!be.isValid()) return true;
    const auto loop = boundaryLoop(m, be, 200);
    if (loop.size() < 3) return false;
    return fillLoop(obj, loop, kind);
  }

  // Smallest height of the fan from ids[0] closing the loop `ids` (copies listed as
  // their originals), -inf when one of its diagonals is an edge already.
  static double fanQuality(const SurfaceMesh& m, const std::vector<Vertex>& ids) {
    double q = std::numeric_limits<double>::infinity();
    for (std::size_t i = 1; i + 1 < ids.size(); ++i) {
      if (i >= 2 && (ids[i] == ids[0] || m.findEdge(ids[0], ids[i]).isValid()))
        return -std::numeric_limits<double>::infinity();
      q = std::min(q, height(m.position(ids[0]), m.position(ids[i]), m.position(ids[i + 1])));
    }
    return q;
  }

  // Closes the boundary loop through `apex` with a fan from it. False (mesh unchanged)
  // when a diagonal exists already.
  bool fillFanAt(int obj, Vertex apex, int kind) {
    SurfaceMesh& m = meshOf(obj);
    const Edge be = boundaryEdgeAt(m, apex);
    if (!be.isValid()) return false;
    std::vector<Vertex> loop = boundaryLoop(m, be, 200);
    const auto at = std::find(loop.begin(), loop.end(), apex);
    if (loop.size() < 3 || at == loop.end()) return false;
    std::rotate(loop.begin(), at, loop.end());
    for (std::size_t i = 2; i + 1 < loop.size(); ++i)
      if (loop[i] == apex || m.findEdge(apex, loop[i]).isValid()) return false;
    std::vector<Face> added;
    for (std::size_t i = 1; i + 1 < loop.size(); ++i) {
      const Face f = addTriangle(obj, apex, loop[i], loop[i + 1], kind);
      if (!f.isValid()) {
        for (Face g : added) m.deleteFace(g);
        return false;
      }
      added.push_back(f);
    }
    return true;
  }

  // Each half of the opening a longer front makes (N, v, chain..., and the copies' side)
  // closes on its own, joined by the edge N - chain.back(): the new front. Good enough
  // when its thinnest triangle is `thr` thick, or half the shortest edge of the half
  // (no triangle on an edge is thicker than the edge, and deferring keeps the edges:
  // the front would only grow). Long fronts are opened whatever their quality short of
  // degenerate: growing costs O(front) per step, and the cut-out caps it with one fan.
  // Never under the sliver floor (sliverHeight = 0.6 thr), even on a long front.
  static bool halvesOk(const SurfaceMesh& m, Vertex N, Vertex v, const std::vector<Vertex>& chain, double thr) {
    if (m.findEdge(N, chain.back()).isValid()) return false;
    // A front that folds back onto itself (a vertex and its copy, e.g. a tunnel's path
    // left to open as a groove) is not the boundary the halves would close.
    for (std::size_t i = 0; i < chain.size(); ++i)
      for (std::size_t j = i + 1; j < chain.size(); ++j)
        if ((m.position(chain[i]) - m.position(chain[j])).squaredNorm() == 0.0) return false;
    std::vector<Vertex> half{N, v};
    half.insert(half.end(), chain.begin(), chain.end());
    double shortest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i + 1 < half.size(); ++i)
      shortest = std::min(shortest, (m.position(half[i + 1]) - m.position(half[i])).norm());
    const double need = std::max(0.6 * thr, half.size() > kLongFront ? 0.0 : std::min(thr, 0.5 * shortest));
    return !loopFallsShort(m, half, need) && loopQuality(m, half) >= need;
  }
  static constexpr std::size_t kLongFront = 24;

  // Closes the boundary loop through a and b (a cut's opening) as two polygons joined by
  // the new edge (a, b), each triangulated for its thickest thinnest triangle. False
  // (mesh unchanged) when that is not possible.
  bool fillHalvesAt(int obj, Vertex a, Vertex b, int kind) {
    SurfaceMesh& m = meshOf(obj);
    const Edge be = boundaryEdgeAt(m, a);
    if (!be.isValid() || m.findEdge(a, b).isValid()) {
      if (dbg()) std::cerr << "fillHalvesAt: no boundary at a or edge a-b\n";
      return false;
    }
    std::vector<Vertex> loop = boundaryLoop(m, be, 4 * kLongFront + 16);
    const auto ia = std::find(loop.begin(), loop.end(), a);
    if (ia == loop.end()) {
      if (dbg()) std::cerr << "fillHalvesAt: a not on loop of " << loop.size() << "\n";
      return false;
    }
    std::rotate(loop.begin(), ia, loop.end());
    const auto ib = std::find(loop.begin(), loop.end(), b);
    if (ib == loop.end() || ib - loop.begin() < 2 || loop.end() - ib < 2) {
      if (dbg())
        std::cerr << "fillHalvesAt: b not across the loop of " << loop.size() << " (at " << (ib - loop.begin())
                  << ")\n";
      return false;
    }
    // Each half starts after a loop edge, so that its first triangle (on the closing
    // edge: last vertex, first) takes its orientation from the face already there.
    std::vector<Vertex> h1(loop.begin() + 1, ib + 1), h2(ib + 1, loop.end());
    h1.push_back(a);
    h2.insert(h2.end(), {a, b});
    std::vector<Face> added;
    for (const auto* h : {&h1, &h2}) {
      std::vector<Vec3> pts;
      for (Vertex x : *h) pts.push_back(m.position(x));
      std::vector<std::array<int, 3>> tris;
      const double q = triangulate(
          pts,
          [&](int i, int j) {
            const Vertex x = (*h)[static_cast<std::size_t>(i)], y = (*h)[static_cast<std::size_t>(j)];
            return x != y && !m.findEdge(x, y).isValid();
          },
          tris);
      if (dbg()) std::cerr << "fillHalvesAt: half of " << h->size() << " quality " << q << "\n";
      bool ok = q > -std::numeric_limits<double>::infinity();
      for (std::size_t t = 0; ok && t < tris.size(); ++t) {
        const auto& tri = tris[t];
        const Face f = addTriangle(obj, (*h)[static_cast<std::size_t>(tri[0])], (*h)[static_cast<std::size_t>(tri[1])],
                                   (*h)[static_cast<std::size_t>(tri[2])], kind);
        ok = f.isValid();
        if (ok) added.push_back(f);
      }
      if (!ok) {
        for (Face g : added) m.deleteFace(g);
        return false;
      }
    }
    return true;
  }

  // Every triangulation of the loop has a triangle on each loop edge: when some edge has
  // no apex (another loop vertex) making a triangle as thick as `need`, none reaches it.
  // Shortest edges first (a triangle is no thicker than its shortest edge): a growing
  // front that cannot open yet is turned down in a few heights, not a cubic search.
  static bool loopFallsShort(const SurfaceMesh& m, const std::vector<Vertex>& ids, double need) {
    const std::size_t n = ids.size();
    if (n < 3 || n > 64) return false;
    std::array<std::pair<double, std::size_t>, 64> order;
    for (std::size_t i = 0; i < n; ++i)
      order[i] = {(m.position(ids[(i + 1) % n]) - m.position(ids[i])).squaredNorm(), i};
    std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(n));
    for (std::size_t r = 0; r < n; ++r) {
      const std::size_t i = order[r].second, j = (i + 1) % n;
      const Vec3 a = m.position(ids[i]), b = m.position(ids[j]);
      bool reaches = false;
      // (A NaN height does not count against the loop, as in triangulate; the margin
      // covers the rounding of a height taken from another corner.)
      for (std::size_t k = 0; k < n && !reaches; ++k)
        reaches = k != i && k != j && !(height(a, b, m.position(ids[k])) < (1.0 - 1e-9) * need);
      if (!reaches) return true;
    }
    return false;
  }

  // Best smallest triangle height for closing a loop of vertices (copies listed as
  // their originals: a diagonal is allowed only where no edge exists yet).
  static double loopQuality(const SurfaceMesh& m, const std::vector<Vertex>& ids) {
    std::vector<Vec3> pts;
    for (Vertex x : ids) pts.push_back(m.position(x));
    std::vector<std::array<int, 3>> tris;
    return triangulate(
        pts,
        [&](int i, int j) {
          const Vertex a = ids[static_cast<std::size_t>(i)], b = ids[static_cast<std::size_t>(j)];
          return a != b && !m.findEdge(a, b).isValid();
        },
        tris);
  }

  // Sine of the smallest angle of triangle (a, b, c) (no trigonometry): the smallest
  // angle lies between the two longest edges (and is at most 60°).
  static double minAngleSin(const Vec3& a, const Vec3& b, const Vec3& c) {
    const double l0 = (b - a).squaredNorm(), l1 = (c - b).squaredNorm(), l2 = (a - c).squaredNorm();
    const double shortest = std::min({l0, l1, l2});
    if (!(shortest > 0.0)) return 0.0;
    return (b - a).cross(c - a).norm() / std::sqrt(l0 * l1 * l2 / shortest);
  }
  // How far ahead of a groove's bottom vertex the blade's depth may be (in groove
  // depths; the wall angle usually decides first), and how far the bottom vertex may be
  // off the bottom's line, through the blade's depth points (fraction of the depth).
  static constexpr double kBottomReach = 4.0;
  static constexpr double kBottomDepthTol = 0.1;

  // The faces around a groove-bottom vertex o: its two other corners in face order, the
  // face's normal, squared smallest-angle sine and height, the squared length of the
  // edge opposite o (kept between steps). A face of the other wall over the same
  // corners (the walls of a groove are copies of each other) is listed once.
  struct StarFace {
    Vec3 a, b, n;
    double sin2, h2, ab2;
  };
  std::vector<StarFace> starBuf;
  std::vector<int> starTable;  // open addressing over starBuf by corner positions

  // Squared smallest-angle sine and squared smallest height of triangle (q, a, b), given
  // the cross product c = (a - q) x (b - q) and the squared length ab2 of a - b.
  static void shape2(const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c, double ab2, double& sin2, double& h2) {
    const double qa2 = (a - q).squaredNorm(), qb2 = (b - q).squaredNorm();
    const double c2 = c.squaredNorm();
    const double shortest = std::min({qa2, qb2, ab2}), longest = std::max({qa2, qb2, ab2});
    sin2 = shortest > 0.0 ? c2 * shortest / (qa2 * qb2 * ab2) : 0.0;
    h2 = longest > 0.0 ? c2 / longest : 0.0;
  }

  // Where o could move along the groove, from its place toward depthN (the blade's
  // depth under the new path vertex N), so that the new wall triangle (v, N, o) and all
  // of o's triangles are best: largest smallest-angle sine of the new triangle and of
  // every triangle the move makes worse; none may flip or get thinner than min(thr, its
  // height), and o may not come near another vertex. Only from a place on the bottom's
  // line (oOnLine) and to places within reach (inReachAt(t), o slid the fraction t of
  // the way). Returns that sine, -1 when o carries anything but groove walls or
  // nothing fits.
  template <class Reach>
  double bestSlide(SurfaceMesh& m, Vertex o, Vertex v, Vertex N, const Vec3& depthN, double thr, const Reach& inReachAt,
                   bool oOnLine, Vec3& best) {
    const Vec3 pv = m.position(v), pN = m.position(N), po = m.position(o);
    // The first bottom vertex of a groove stays (its walls ramp up to where the cut
    // began: moved on, the groove would start shallower than the blade cut it).
    const auto apexProp = apexOf(m);
    bool follows = false;
    for (Edge e : m.edges(o))
      if (apexProp[m.otherVertex(e, o)] != 0) {
        follows = true;
        break;
      }
    if (!follows) return -1.0;
    // Each face once, from the edge on which it leaves o (no search through a list: a
    // groove-bottom vertex carries many faces), and a twin (the other wall's face over
    // the same corners) found through a small hash of its corners. The search's result
    // does not depend on the order of the faces nor on a face being listed twice (a
    // smallest value; the twin's tests are the same numbers).
    auto kinds = kindsOf(m);
    starBuf.clear();
    std::size_t tableSize = 64;
    while (tableSize < 4 * m.edges(o).size()) tableSize *= 2;
    starTable.assign(tableSize, -1);
    const std::size_t mask = tableSize - 1;
    auto keyOf = [](const Vec3& x) {
      std::uint64_t u = 0;
      const double d = x.x() + 0.0;  // -0 and +0 alike
      std::memcpy(&u, &d, sizeof u);
      return (u ^ (u >> 29)) * 0x9E3779B97F4A7C15ull;
    };
    for (Edge e : m.edges(o))
      for (int side = 0; side < 2; ++side) {
        const Face f = m.face(e, side);
        if (!f.isValid()) continue;
        const int k = m.localIndex(f, o);
        if (k < 0) return -1.0;
        if (m.edges(f)[static_cast<std::size_t>(k)] != e) continue;  // listed from its other edge at o
        if (kinds[f] != kGrooveWall) return -1.0;
        const auto& fv = m.vertices(f);
        StarFace sf;
        sf.a = m.position(fv[static_cast<std::size_t>((k + 1) % 3)]);
        sf.b = m.position(fv[static_cast<std::size_t>((k + 2) % 3)]);
        std::size_t slot = static_cast<std::size_t>((keyOf(sf.a) + keyOf(sf.b)) >> 40) & mask;
        bool twin = false;
        for (; starTable[slot] >= 0; slot = (slot + 1) & mask) {
          const StarFace& g = starBuf[static_cast<std::size_t>(starTable[slot])];
          if ((g.a == sf.b && g.b == sf.a) || (g.a == sf.a && g.b == sf.b)) {
            twin = true;
            break;
          }
        }
        if (twin) continue;
        sf.n = (sf.a - po).cross(sf.b - po);
        sf.ab2 = (sf.b - sf.a).squaredNorm();
        shape2(po, sf.a, sf.b, sf.n, sf.ab2, sf.sin2, sf.h2);
        starTable[slot] = static_cast<int>(starBuf.size());
        starBuf.push_back(sf);
      }
    const double thr2 = thr * thr, vN2 = (pN - pv).squaredNorm();
    // o slides along the bottom's line only from a place on it (tissue moved by physics
    // may have carried it off: such a slide would reshape its walls at once).
    if (!oOnLine) return -1.0;
    // With a bound, the loop may stop as soon as the value is below it: the caller only
    // needs to know that it is (the value returned is then below the bound, above the
    // true one, and is never kept as a best).
    auto quality = [&](double t, double bound) {
      const Vec3 q = po + t * (depthN - po);
      if (!inReachAt(t)) return -1.0;
      double worst = 0.0, h2 = 0.0;
      shape2(q, pv, pN, (pv - q).cross(pN - q), vN2, worst, h2);
      if (h2 < thr2) return -1.0;
      for (const StarFace& sf : starBuf) {
        const Vec3 c = (sf.a - q).cross(sf.b - q);
        if (c.dot(sf.n) <= 0.0) return -1.0;
        double s2 = 0.0, fh2 = 0.0;
        shape2(q, sf.a, sf.b, c, sf.ab2, s2, fh2);
        if (fh2 < std::min(thr2, sf.h2)) return -1.0;
        if (s2 < sf.sin2) worst = std::min(worst, s2);
        if (worst < bound) return worst;
      }
      return worst;
    };
    constexpr double kNoBound = -2.0;  // below every value, -1 included
    // Golden-section search on t in [0, 1] (the quality is a minimum of triangles that
    // get worse and the new one that gets better as o moves on). Each new point only
    // has to be compared with the one it meets: its evaluation is bounded by that one's
    // value (same comparisons, so the same search, as with full evaluations).
    constexpr double g = 0.6180339887498949;
    double lo = 0.0, hi = 1.0;
    double bestT = 1.0, bestQ = quality(1.0, kNoBound);
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double q1 = quality(x1, kNoBound), q2 = quality(x2, q1);
    for (int it = 0; it < kSlideSearchSteps; ++it) {
      if (q1 < q2) {
        lo = x1;
        x1 = x2;
        q1 = q2;
        x2 = lo + g * (hi - lo);
        q2 = quality(x2, q1);
      } else {
        hi = x2;
        x2 = x1;
        q2 = q1;
        x1 = hi - g * (hi - lo);
        q1 = quality(x1, q2);
      }
    }
    for (auto [t, q] : {std::pair{x1, q1}, std::pair{x2, q2}})
      if (q > bestQ) bestQ = q, bestT = t;
    if (bestQ <= 0.0) return -1.0;
    best = po + bestT * (depthN - po);
    // Never onto another vertex: at the blade's depth under N, where another cut's new
    // bottom vertex would go too (a cut retracing its own groove: both lips are cut).
    if ((best - depthN).squaredNorm() < thr2 && !clearOfVertices(m, o, best, thr)) return -1.0;
    return std::sqrt(bestQ);
  }
  static constexpr int kSlideSearchSteps = 6;

  // No vertex but o within r of q (the object's tree: only faces whose box is near).
  bool clearOfVertices(SurfaceMesh& m, Vertex o, const Vec3& q, double r) {
    for (std::size_t i = 0; i < objects.size(); ++i) {
      if (&objects[i].mesh != &m) continue;
      syncBvh(i);
      collision::Box box;
      box.extend(q);
      box.min.array() -= r;
      box.max.array() += r;
      scratchFaces.clear();
      bvhs[i].facesOverlapping(box, scratchFaces);
      for (Face f : scratchFaces) {
        if (!m.isValid(f)) continue;
        for (Vertex x : m.vertices(f))
          if (x != o && (m.position(x) - q).squaredNorm() < r * r) return false;
      }
    }
    return true;
  }

  // Moves groove-bottom vertex o to q (its faces are all groove walls; n is the path
  // vertex above): rest shape, springs and masses of the tissue follow, and the tree
  // refits o's boxes at its next sync (before any query).
  void slideBottom(int obj, Vertex o, const Vec3& q, Vertex n, const Vec3& depthN) {
    SurfaceMesh& m = meshOf(obj);
    if (dbg())
      std::cerr << "slide bottom " << o << " from " << m.position(o).transpose() << " to " << q.transpose() << "\n";
    const Vec3 po = m.position(o);
    m.position(o) = q;
    ++stats.bottomSlides;
    if (tissue(obj)) {
      // Its rest place moves as far toward a new bottom vertex's at depthN (N's, offset
      // as in the world, as fillQuad does).
      auto home = handlesOf(m).home;
      const double full = (depthN - po).norm();
      const double t = full > 0.0 ? std::clamp((q - po).norm() / full, 0.0, 1.0) : 1.0;
      if (home) home[o] += t * (home[n] + (depthN - m.position(n)) - home[o]);
      std::vector<Vertex> around{o};
      for (Edge e : m.edges(o)) around.push_back(m.otherVertex(e, o));
      for (Edge e : m.edges(o)) physics::initEdge(m, handlesOf(m), e, p.tissue);
      physics::redistributeMass(m, handlesOf(m), around, p.tissue);
    }
    slidPending.emplace_back(obj, o);  // its boxes are refitted at the next sync
    // Its faces changed shape: the flips' thinness test must see them again.
    for (ThinCache& c : thinCaches)
      if (c.obj == obj) {
        for (Edge e : m.edges(o))
          for (int side = 0; side < 2; ++side) {
            const Face f = m.face(e, side);
            if (f.isValid() && f.idx() < c.okGen.size()) c.okGen[f.idx()] = 0;
          }
        // (their corners: o and its neighbours)
        c.unsettle(o);
        for (Edge e : m.edges(o)) c.unsettle(m.otherVertex(e, o));
      }
  }

  // Smallest height of triangle (a, b, c): what makes a sliver.
  static double height(const Vec3& a, const Vec3& b, const Vec3& c) {
    // One square root for the longest edge: the root is monotonic and correctly rounded,
    // so the root of the largest square is the largest of the three norms, to the bit.
    const double longest = std::sqrt(std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()}));
    return longest > 0 ? (b - a).cross(c - a).norm() / longest : 0.0;
  }

  static constexpr int kFanApexes = 32;

  // Triangulation of a closed polygon maximising the smallest triangle height (dynamic
  // programming, O(n³)); triangles in pre-order from the edge (n-1, 0), so that each
  // shares an edge with one listed before it. Returns the smallest height, or -inf.
  template <class DiagonalOk>
  static double triangulate(const std::vector<Vec3>& P, const DiagonalOk& diagonalOk,
                            std::vector<std::array<int, 3>>& out) {
    const int n = static_cast<int>(P.size());
    out.clear();
    const double inf = std::numeric_limits<double>::infinity();
    if (n < 3) return -inf;
    if (n > 20) {
      // Long loops (a long unopened front): the best fan from at most kFanApexes evenly
      // spread apexes, O(n) rather than O(n²) over all of them.
      double bestQ = -inf;
      int bestK = -1;
      const int stride = std::max(1, n / kFanApexes);
      for (int k = 0; k < n; k += stride) {
        double q = inf;
        for (int s = 1; s + 1 < n && q > bestQ; ++s) {
          const int i = (k + s) % n, j = (k + s + 1) % n;
          if (s > 1 && !diagonalOk(std::min(k, i), std::max(k, i))) q = -inf;
          q = std::min(q, height(P[static_cast<std::size_t>(k)], P[static_cast<std::size_t>(i)],
                                 P[static_cast<std::size_t>(j)]));
        }
        if (q > bestQ) {
          bestQ = q;
          bestK = k;
        }
      }
      if (bestK < 0) return -inf;
      for (int s = 1; s + 1 < n; ++s) out.push_back({bestK, (bestK + s) % n, (bestK + s + 1) % n});
      return bestQ;
    }
    // (n <= 20: the tables fit on the stack)
    std::array<double, 400> best;
    std::array<int, 400> split;
    std::fill_n(best.begin(), n * n, -inf);
    std::fill_n(split.begin(), n * n, -1);
    auto at = [&](int i, int j) -> double& { return best[static_cast<std::size_t>(i * n + j)]; };
    for (int i = 0; i + 1 < n; ++i) at(i, i + 1) = inf;
    for (int len = 2; len < n; ++len)
      for (int i = 0; i + len < n; ++i) {
        const int j = i + len;
        if (len < n - 1 && !diagonalOk(i, j)) continue;
        for (int k = i + 1; k < j; ++k) {
          // A split whose two sides are no better than the best so far cannot beat it:
          // its height need not be computed (same result, same split).
          const double sides = std::min(at(i, k), at(k, j));
          if (!(sides > at(i, j))) continue;
          const double val = std::min(sides, height(P[static_cast<std::size_t>(i)], P[static_cast<std::size_t>(k)],
                                                    P[static_cast<std::size_t>(j)]));
          if (val > at(i, j)) {
            at(i, j) = val;
            split[static_cast<std::size_t>(i * n + j)] = k;
          }
        }
      }
    if (split[static_cast<std::size_t>(n - 1)] < 0) return -inf;
    std::vector<std::pair<int, int>> todo{{0, n - 1}};
    while (!todo.empty()) {
      const auto [i, j] = todo.back();
      todo.pop_back();
      if (j - i < 2) continue;
      const int k = split[static_cast<std::size_t>(i * n + j)];
      out.push_back({i, k, j});
      todo.push_back({k, j});
      todo.push_back({i, k});
    }
    return at(0, n - 1);
  }

  // Closes the loop with a fan around a new vertex at its centroid if every fan
  // triangle is thicker than `than`. Returns false (mesh unchanged) otherwise.
  bool fillLoopAroundCentroid(int obj, const std::vector<Vertex>& loop, double than, int kind) {
    SurfaceMesh& m = meshOf(obj);
    Vec3 c = Vec3::Zero();
    for (Vertex v : loop) c += m.position(v);
    c /= static_cast<double>(loop.size());
    double q = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < loop.size(); ++i)
      q = std::min(q, height(m.position(loop[i]), m.position(loop[(i + 1) % loop.size()]), c));
    if (!(q > than)) return false;
    const Vertex B = m.addVertex(c);
    std::vector<Face> added;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Face f = addTriangle(obj, loop[i], loop[(i + 1) % loop.size()], B, kind);
      if (!f.isValid()) {
        for (Face g : added) m.deleteFace(g);
        m.deleteVertex(B);
        return false;
      }
      added.push_back(f);
    }
    if (tissue(obj)) {
      // Home and velocity from the nearest loop vertex, offset like the position.
      Vertex nearest = loop.front();
      for (Vertex v : loop)
        if ((m.position(v) - c).squaredNorm() < (m.position(nearest) - c).squaredNorm()) nearest = v;
      physics::copyVertexState(handlesOf(m), B, nearest);  // (springs and mass: touch below)
      auto home = handlesOf(m).home;
      if (home) home[B] = home[nearest] + (c - m.position(nearest));
    }
    touch(obj, {B});
    return true;
  }

  bool fillLoop(int obj, const std::vector<Vertex>& loop, int kind) {
    SurfaceMesh& m = meshOf(obj);
    if (dbg()) {
      std::cerr << "fillLoop";
      for (Vertex v : loop) std::cerr << " " << v << "(" << m.position(v).transpose() << ")";
      std::cerr << "\n";
    }
    std::vector<Vec3> P;
    for (Vertex v : loop) P.push_back(m.position(v));
    std::vector<std::array<int, 3>> tris;
    const double q = triangulate(
        P,
        [&](int i, int j) {
          return !m.findEdge(loop[static_cast<std::size_t>(i)], loop[static_cast<std::size_t>(j)]).isValid();
        },
        tris);
    if (!(q > -std::numeric_limits<double>::infinity())) return false;
    // Every triangulation of the loop is thin (e.g. the only free diagonal joins a
    // vertex and its own copy across a slit): close it around a new vertex at the
    // loop's centroid instead, when that is thicker.
    if (q < 0.5 * p.snapDistance && fillLoopAroundCentroid(obj, loop, q, kind)) return true;
    std::vector<Face> added;
    for (const auto& t : tris) {
      const Face f = addTriangle(obj, loop[static_cast<std::size_t>(t[0])], loop[static_cast<std::size_t>(t[1])],
                                 loop[static_cast<std::size_t>(t[2])], kind);
      if (!f.isValid()) {
        for (Face g : added) m.deleteFace(g);
        return false;
      }
      added.push_back(f);
    }
    return true;
  }

  // ---- groove to cut-through: the tunnel ------------------------------------------------------
  static bool tunnelReady(const Track& t) { return t.tip.isValid() && t.chain.size() >= 2; }

  // Boundary loop through `start`, in the direction a face closing it must run: for
  // each consecutive pair (a, b) the face already on edge (a, b) runs b -> a.
  static std::vector<Vertex> orientedLoop(const SurfaceMesh& m, Vertex start, std::size_t maxLen) {
    std::vector<Vertex> loop{start};
    Vertex cur = start;
    for (;;) {
      Vertex next;
      for (Edge e : m.edges(cur)) {
        if (!m.isBoundary(e)) continue;
        const Vertex o = m.otherVertex(e, cur);
        const Face f = m.face(e, 0);
        const int k = m.localIndex(f, o);
        if (k >= 0 && m.vertices(f)[static_cast<std::size_t>((k + 1) % 3)] == cur) {
          next = o;
          break;
        }
      }
      if (!next.isValid()) return {};
      if (next == start) return loop;
      loop.push_back(next);
      cur = next;
      if (loop.size() > maxLen) return {};
    }
  }

  // Triangles joining polyline P (run forward by the new faces) to polyline Q (run
  // backward), from rung (P0, Q0) to rung (Pn, Qm): the strip whose thinnest triangle
  // is thickest (dynamic programming over the rungs). `rungOk` rejects a rung.
  template <class RungOk>
  static double strip(const SurfaceMesh& m, const std::vector<Vertex>& P, const std::vector<Vertex>& Q, RungOk&& rungOk,
                      std::vector<std::array<Vertex, 3>>& out) {
    const std::size_t n = P.size(), k = Q.size();
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<double> best(n * k, -inf);
    std::vector<char> from(n * k, 0);  // 1: came by advancing P, 2: by advancing Q
    auto at = [&](std::size_t i, std::size_t j) -> double& { return best[i * k + j]; };
    at(0, 0) = inf;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < k; ++j) {
        if ((i || j) && !rungOk(i, j)) continue;
        if (i > 0 && at(i - 1, j) > -inf) {
          const double q = std::min(at(i - 1, j), height(m.position(P[i - 1]), m.position(P[i]), m.position(Q[j])));
          if (q > at(i, j)) {
            at(i, j) = q;
            from[i * k + j] = 1;
          }
        }
        if (j > 0 && at(i, j - 1) > -inf) {
          const double q = std::min(at(i, j - 1), height(m.position(P[i]), m.position(Q[j]), m.position(Q[j - 1])));
          if (q > at(i, j)) {
            at(i, j) = q;
            from[i * k + j] = 2;
          }
        }
      }
    out.clear();
    if (!(at(n - 1, k - 1) > -inf)) return -inf;
    for (std::size_t i = n - 1, j = k - 1; i || j;) {
      if (from[i * k + j] == 1) {
        out.push_back({P[i - 1], P[i], Q[j]});
        --i;
      } else {
        out.push_back({P[i], Q[j], Q[j - 1]});
        --j;
      }
    }
    return at(n - 1, k - 1);
  }

  // Both layers of a cut through the middle of the object have a closed path of two
  // edges or more (A: tip, chain... ending at the groove front or the pierce point; B
  // likewise on the other layer). Opens both paths (their inner vertices split in
  // two) and joins the two openings with side walls: a strip on each side from the
  // front rung (A tip, B tip) to the back rung (A's chain end, B's chain end). The
  // object gets its hole here; from now on the pair goes on as an ordinary cut-through.
  bool openTunnel(Track& A, Track& B) {
    const int obj = A.object;
    SurfaceMesh& m = meshOf(obj);
    std::vector<Vertex> pa{A.tip}, pb{B.tip};
    pa.insert(pa.end(), A.chain.begin(), A.chain.end());
    pb.insert(pb.end(), B.chain.begin(), B.chain.end());
    const Vertex fa = pa.front(), ba = pa.back(), fb = pb.front(), bb = pb.back();
    for (Vertex x : pa)
      if (std::find(pb.begin(), pb.end(), x) != pb.end()) return false;
    if (m.findEdge(fa, fb).isValid() || m.findEdge(ba, bb).isValid()) return false;
    // Every inner vertex must open into exactly two sides along the path.
    for (const auto* path : {&pa, &pb})
      for (std::size_t i = 1; i + 1 < path->size(); ++i) {
        const Vertex x = (*path)[i];
        const Edge e0 = m.findEdge(x, (*path)[i - 1]), e1 = m.findEdge(x, (*path)[i + 1]);
        if (!e0.isValid() || !e1.isValid() || m.isBoundary(e0) || m.isBoundary(e1)) return false;
        if (fanGroups(m, x, {e0, e1}).size() != 2) return false;
      }
    {
      // The walls will have the paths' shape (the copies sit on the originals): wait
      // for a later step while they would be thinner than walls may be.
      std::vector<std::array<Vertex, 3>> tris;
      const double q = strip(
          m, pa, pb,
          [&](std::size_t i, std::size_t j) {
            const bool endP = i == 0 || i + 1 == pa.size(), endQ = j == 0 || j + 1 == pb.size();
            if (endP && endQ) return (i == 0) == (j == 0);
            return !m.findEdge(pa[i], pb[j]).isValid();
          },
          tris);
      if (!(q >= 0.5 * p.snapDistance)) return false;
    }
    std::vector<Vertex> touched;
    for (const auto* path : {&pa, &pb})
      for (std::size_t i = 1; i + 1 < path->size(); ++i) {
        const Vertex x = (*path)[i];
        std::vector<Edge> cuts;
        for (const Vertex y : {(*path)[i - 1], (*path)[i + 1]})
          if (const Edge e = m.findEdge(x, y); e.isValid()) cuts.push_back(e);
        touched.push_back(x);
        for (Vertex c : splitByGroups(obj, x, cuts)) {
          mark(A, c);
          touched.push_back(c);
        }
      }
    const std::vector<Vertex> la = orientedLoop(m, fa, 4 * pa.size() + 8);
    const std::vector<Vertex> lb = orientedLoop(m, fb, 4 * pb.size() + 8);
    const auto ia = std::find(la.begin(), la.end(), ba), ib = std::find(lb.begin(), lb.end(), bb);
    bool ok = !la.empty() && !lb.empty() && ia != la.end() && ib != lb.end();
    std::vector<Face> added;
    if (ok) {
      // Strip 1: A's loop from its tip to its back end, against B's loop run backward
      // from its tip; strip 2: the other halves, back end to tip.
      std::vector<Vertex> P1(la.begin(), ia + 1), P2(ia, la.end());
      P2.push_back(fa);
      std::vector<Vertex> Q1{fb}, Q2(lb.begin(), ib + 1);
      Q1.insert(Q1.end(), lb.rbegin(), std::make_reverse_iterator(ib));
      std::reverse(Q2.begin(), Q2.end());
      std::vector<std::array<Vertex, 3>> tris, more;
      auto rungOk = [&](const std::vector<Vertex>& P, const std::vector<Vertex>& Q) {
        return [&](std::size_t i, std::size_t j) {
          const bool endP = i == 0 || i + 1 == P.size(), endQ = j == 0 || j + 1 == Q.size();
          if (endP && endQ) return (i == 0) == (j == 0);  // only the two designated end rungs
          return !m.findEdge(P[i], Q[j]).isValid();
        };
      };
      const double q1 = strip(m, P1, Q1, rungOk(P1, Q1), tris);
      const double q2 = strip(m, P2, Q2, rungOk(P2, Q2), more);
      tris.insert(tris.end(), more.begin(), more.end());
      ok = q1 > -std::numeric_limits<double>::infinity() && q2 > -std::numeric_limits<double>::infinity();
      for (std::size_t t = 0; ok && t < tris.size(); ++t) {
        const Face f = m.addFace(tris[t][0], tris[t][1], tris[t][2]);
        if (!f.isValid()) {
          ok = false;
          break;
        }
        m.faceProperty<int>(kFaceKindProp, kSurface)[f] = kSideWall;
        added.push_back(f);
      }
    }
    if (!ok) {
      // Should not happen on a manifold mesh: close each opening on its own.
      for (Face f : added) m.deleteFace(f);
      ++stats.fillFailures;
      fillHoleAt(obj, fa, kGrooveWall);
      fillHoleAt(obj, fb, kGrooveWall);
    }
    A.tunnel = B.tunnel = false;
    A.chain = {fb};
    B.chain = {fa};
    touched.insert(touched.end(), {fa, ba, fb, bb});
    for (Vertex x : touched) touch(obj, {x});
    for (Vertex x : touched) unpinch(obj, x);
    if (sliverTrace())
      for (Vertex x : touched) traceThin(obj, {x}, "tunnel");
    return ok;
  }

  // ---- walking along the sweep plane ------------------------------------------------------
  struct WalkGoal {
    bool toVertex = false;
    Vertex vertex;
    Vec3 point = Vec3::Zero();
    Face face;               // the face holding point (advance: the hit's), if known
    bool stopAtLip = false;  // stop on an earlier cut's lip with point across its gap (acrossLip)
    // A groove's blade (unit, into the material; zero: none): stop where the curve goes
    // deeper than the blade reaches.
    Vec3 reach = Vec3::Zero();
    // Where the plane leaves the tip's fan ahead in more than one place (an object's
    // edge), take the way whose curve reaches the point (wayToGoal).
    bool chooseWay = false;
    // Edit nothing unless the first step's curve reaches the point's face (the goal
    // vertex's) within kMustReachSlack times the walk's length (traced as in wayToGoal):
    // otherwise the walk fails at once (WalkEnd::Unreached).
    bool mustReach = false;
  };
  // The first step of a walk (and of pastBlade's trace of where it would go) only has to
  // avoid going back: its cosine to `forward` above this.
  static constexpr double kFirstStepMinCos = -0.7;
  // WalkGoal::mustReach refuses a first step whose traced curve is longer than this many
  // times the walk's length.
  static constexpr double kMustReachSlack = 1.4;
  // Samples a cut-through layer waits on an earlier cut's wall for its partner with the
  // blade's point past the matching radius (scale 50: at 1, two pieces fewer come free; at
  // 3, none more, and longer stretches go uncut: sim/cutting/README.md, Limits).
  static constexpr int kWallWaitsPastRadius = 2;
  // A face of v's fan, from v: v's corner index (-1: not a corner) and the corners after
  // it, the edge where the plane leaves the fan.
  struct FanEdge {
    int k;
    Vertex a, b;
  };
  static FanEdge fanEdge(const SurfaceMesh& m, Face f, Vertex v) {
    const auto& fv = m.vertices(f);
    const int k = m.localIndex(f, v);
    return {k, fv[static_cast<std::size_t>((k + 1) % 3)], fv[static_cast<std::size_t>((k + 2) % 3)]};
  }

  // A blade crossing another cut's slot or groove: the walk (advance) reaches the near
  // lip, the blade's point lies across the gap on the far lip, and walking on would
  // follow the sweep plane down that cut's wall (and on a slot round the object). When
  // that curve would pass the blade's end first (pastBlade), the walk stops on the lip
  // and advance ends the track there: the crossing starts a new one beyond. (A groove
  // crossing a shallower groove still walks down its wall, across its bottom and up.)
  struct [[nodiscard]] WalkResult {
    WalkEnd end = WalkEnd::Reached;
    Edge blockedAt;  // Blocked: the edge whose crossing would have touched the cut
    explicit operator bool() const { return end == WalkEnd::Reached; }
    // Ends where the track stops short of an earlier cut's gap (or a sheet's rim) and the
    // crossing starts a new track beyond: a lip stop, not a failure.
    [[nodiscard]] bool atLip() const {
      return end == WalkEnd::AtLip || end == WalkEnd::PastReach || end == WalkEnd::AtRim;
    }
    // x is an end of blockedAt (live in m: the caller checks).
    [[nodiscard]] bool blockedAtEnd(const SurfaceMesh& m, Vertex x) const {
      return x.isValid() && (m.vertex(blockedAt, 0) == x || m.vertex(blockedAt, 1) == x);
    }
  };
  void countWalkFailure(WalkEnd end) {
    ++stats.walkFailures;
    ++stats.walkFailuresBy[static_cast<std::size_t>(end)];
  }

  // The sweep plane through `origin` (normal n) on mesh m: a vertex's side of it, and
  // where it crosses the edge from a to b (ends on either side).
  struct PlaneCut {
    const SurfaceMesh& m;
    Vec3 n, origin;
    [[nodiscard]] double side(Vertex x) const { return n.dot(m.position(x) - origin); }
    [[nodiscard]] Vec3 cross(Vertex a, Vertex b) const {
      const double sa = side(a), sb = side(b);
      return m.position(a) + (m.position(b) - m.position(a)) * (sa / (sa - sb));
    }
  };
  // Follows the plane's curve over the faces, nothing edited (pastBlade, rimBehind): from
  // the crossing q on edge e (ends strictly on either side), leaving face f, len along the
  // curve so far, over at most maxSteps faces (then: atLimit). atCrossing(e, q, len) may
  // end it at each crossing, entering(g, c, q, len) at the next face g (c: its corner off
  // e), with their answer; where the curve's way on is lost: false.
  template <class AtCrossing, class Entering>
  static bool traceCurve(const PlaneCut& pc, Face f, Edge e, Vec3 q, double len, int maxSteps, bool atLimit,
                         AtCrossing&& atCrossing, Entering&& entering) {
    const SurfaceMesh& m = pc.m;
    for (int i = 0;; ++i) {
      if (const std::optional<bool> r = atCrossing(e, q, len)) return *r;
      if (i == maxSteps) return atLimit;
      const Face g = m.otherFace(e, f);
      if (!g.isValid()) return false;
      const Vertex a = m.vertex(e, 0), b = m.vertex(e, 1);
      Vertex c;
      for (Vertex x : m.vertices(g))
        if (x != a && x != b) c = x;
      if (const std::optional<bool> r = entering(g, c, q, len)) return *r;
      if (!c.isValid()) return false;
      // It leaves g over (o, c), o the end of e across the plane from c.
      const double sa = pc.side(a), sc = pc.side(c);
      const Vertex o = (sa > 0) != (sc > 0) ? a : b;
      if (pc.side(o) == sc) return false;
      e = m.findEdge(o, c);
      if (!e.isValid()) return false;
      const Vec3 x = pc.cross(m.vertex(e, 0), m.vertex(e, 1));
      len += (x - q).norm();
      q = x;
      f = g;
    }
  }
  // From v: would the sweep plane's curve (heading `forward` first) go past the blade's
  // end (`end`, the crossing's depth: the end of a groove's blade, the middle of a
  // tunnel's) by more than the snapping distance before it reaches the goal's face, or
  // run on for more than maxLen? Traced over the faces, nothing edited.
  bool pastBlade(const SurfaceMesh& m, Vertex v, const WalkGoal& goal, const Vec3& n, const Vec3& forward,
                 const Vec3& end, double maxLen) const {
    const Vec3 pv = m.position(v);
    const Vec3 into = end - goal.point;
    if (!(into.norm() > 0.0)) return false;
    const Vec3 u = into.normalized();
    const PlaneCut pc{m, n, pv};
    Face f;
    Edge e;
    Vec3 q = pv;
    double best = kFirstStepMinCos;
    for (Face g : m.faces(v)) {
      const auto [k, a, b] = fanEdge(m, g, v);
      const double sa = pc.side(a), sb = pc.side(b);
      if (sa == 0.0 || sb == 0.0 || (sa > 0) == (sb > 0)) continue;
      const Vec3 x = pc.cross(a, b);
      if (!((x - pv).norm() > 0.0)) continue;
      const double score = (x - pv).normalized().dot(forward);
      if (score > best) {
        best = score;
        f = g;
        e = m.findEdge(a, b);
        q = x;
      }
    }
    if (!f.isValid() || !e.isValid()) return false;  // cannot tell: the walk goes on
    return traceCurve(
        pc, f, e, q, (q - pv).norm(), 1000, true,
        [&](Edge, const Vec3& x, double len) -> std::optional<bool> {
          if ((x - end).dot(u) > p.snapDistance || len > maxLen) return true;
          return std::nullopt;
        },
        [&](Face g, Vertex, const Vec3&, double) -> std::optional<bool> {
          if (pointInFace(m, g, goal.point)) return false;
          return std::nullopt;
        });
  }

  // How deep a groove's blade has been since the tip, along its direction into the
  // material (WalkGoal::reach; zero: no limit). A point past it by more than the
  // snapping distance lies where the blade never went: the walk and its trace
  // (wayToGoal) stop there alike.
  struct Reach {
    Vec3 dir = Vec3::Zero();
    double max = 0.0;
    [[nodiscard]] bool passedBy(const Vec3& q, double tol) const { return !dir.isZero() && q.dot(dir) - max > tol; }
  };
  // A step of a walk, where the plane leaves the tip's fan (face f) over edge (a, b) at q.
  struct Way {
    Face f;
    Vertex a, b;
    Vec3 q = Vec3::Zero();
    double score = -1e300;
    int sign = 1;
  };
  // Does the plane's curve from the tip at pv, leaving its fan by way w, reach the goal's
  // face (a face with the goal vertex) within maxLen, without passing the blade's reach or
  // crossing the cut's own edges?
  // With `missed`: whether it does not for one of those reasons (not merely a curve lost
  // where the trace cannot follow it, through a corner on the plane, which the walk can).
  bool curveReaches(const SurfaceMesh& m, const Track& tr, const Vec3& pv, const Way& w, const WalkGoal& goal,
                    const Vec3& n, double maxLen, const Reach& reach, bool* missed = nullptr) const {
    if (missed) *missed = false;
    const Edge e = m.findEdge(w.a, w.b);
    if (!e.isValid()) return false;
    return traceCurve(
        PlaneCut{m, n, pv}, w.f, e, w.q, (w.q - pv).norm(), 1000, false,
        [&](Edge x, const Vec3& q, double len) -> std::optional<bool> {
          if (len > maxLen || (tr.visited.count(m.vertex(x, 0)) && tr.visited.count(m.vertex(x, 1))) ||
              reach.passedBy(q, p.snapDistance)) {
            if (missed) *missed = true;
            return false;
          }
          return std::nullopt;
        },
        [&](Face g, Vertex, const Vec3&, double) -> std::optional<bool> {
          if (goal.toVertex ? m.localIndex(g, goal.vertex) >= 0 : pointInFace(m, g, goal.point)) return true;
          return std::nullopt;
        });
  }
  // Which of the walk's first steps `ways` (from the tip at pv; the first the walk's own
  // pick) to take: -1 (its pick) unless the curve from its pick does not reach the
  // goal's face within maxLen (without passing the blade's reach or crossing the cut's
  // own edges) while another's does, traced over the faces with nothing edited (disc
  // 3644: a blade near the bottom entering the rim, the walk went over the top and round).
  int wayToGoal(const SurfaceMesh& m, const Track& tr, const Vec3& pv, std::span<Way> ways, const WalkGoal& goal,
                const Vec3& n, double maxLen, const Reach& reach) {
    for (std::size_t i = 1; i < ways.size(); ++i)  // by score, best first (a handful)
      for (std::size_t j = i; j > 0 && ways[j].score > ways[j - 1].score; --j) std::swap(ways[j], ways[j - 1]);
    // Two ways through one place (the coinciding walls of a closed slot, or a corner)
    // are no choice the trace can make: the walk's own rules decide there.
    for (std::size_t i = 0; i < ways.size(); ++i)
      for (std::size_t j = i + 1; j < ways.size(); ++j)
        if ((ways[i].q - ways[j].q).norm() <= p.snapDistance) return -1;
    auto reaches = [&](const Way& w) { return curveReaches(m, tr, pv, w, goal, n, maxLen, reach); };
    if (reaches(ways[0])) return -1;
    for (std::size_t i = 1; i < ways.size(); ++i)
      if (reaches(ways[i])) {
        ++stats.waysChosen;
        if (dbg()) std::cerr << "walk: takes the way through " << ways[i].q.transpose() << " to its goal\n";
        return static_cast<int>(i);
      }
    return -1;
  }

  // v is on the lip of an earlier cut (a surface face and a wall face with a corner off
  // this cut among `around`, v's faces), and the goal, within the matching radius, lies across that
  // cut's gap: beyond the plane of such a wall face at v, on a surface face with a
  // corner on such a wall (the far lip) that is not behind that plane.
  bool acrossLip(const SurfaceMesh& m, const Track& tr, Vertex v, const std::vector<Face>& around,
                 const WalkGoal& goal) const {
    const auto kind = kindsIn(m);
    if (!kind || !m.isValid(goal.face) || kind[goal.face] != kSurface) return false;
    auto foreignWall = [&](Face f) {
      if (kind[f] == kSurface) return false;
      for (Vertex x : m.vertices(f))
        if (!tr.visited.count(x)) return true;
      return false;
    };
    const Vec3 pv = m.position(v);
    if ((goal.point - pv).norm() > p.matchRadius) return false;
    bool onSurface = false;
    for (Face f : around) onSurface = onSurface || kind[f] == kSurface;
    if (!onSurface) return false;
    for (Face w : around) {
      if (!foreignWall(w)) continue;
      Vec3 nw = rawNormal(m, w);
      if (!(nw.norm() > 0.0)) continue;
      nw.normalize();
      const double beyond = (goal.point - pv).dot(nw);
      if (!(beyond > 0.0)) continue;
      for (Vertex x : m.vertices(goal.face)) {
        bool farLip = false;
        for (Face g : m.faces(x)) farLip = farLip || foreignWall(g);
        if (!farLip) continue;
        if ((m.position(x) - pv).dot(nw) >= -p.snapDistance) return true;
      }
    }
    return false;
  }

  // The path turns back along the cut's last edge (v, x), x a copy of the path vertex
  // before the tip (a hairpin: at an L's corner the step before the turn snapped onto a
  // vertex just behind the blade's new way), and crosses edge e within the snapping
  // tolerance of x. x is the cut's own, so the crossing cannot snap there; stopping would
  // end the track (and lose its pair). Splitting e at q instead keeps the thin wedge
  // between the two ways whole, when no triangle of the split is a sliver. (The front,
  // the partner's tip and the cut's starts still stop the walk: advance waits there, or
  // the cut joins its start.)
  // On tissue that moved since the last sample the same holds for a vertex of a
  // cut-through's front between the layers' tips (not the partner's tip): the motion
  // moved the crossing beside the front (the cut-in path of a slide-in), and the first
  // edge the walk crosses passes next to one of its vertices (moving seed 40563).
  bool hairpinSplit(const SurfaceMesh& m, const Track& tr, Vertex v, Edge e, const Vec3& q) {
    const Vertex a = m.vertex(e, 0), b = m.vertex(e, 1);
    const Vertex x = (q - m.position(a)).norm() <= (q - m.position(b)).norm() ? a : b;
    const bool onFront = std::find(tr.chain.begin(), tr.chain.end(), x) != tr.chain.end();
    const bool frontSplit = onFront && movedSincePrev && tr.partner >= 0;
    if (x != tr.prevTip && x != tr.prevTipCopy && !frontSplit) return false;
    const Edge vx = m.findEdge(v, x);
    const auto kind = kindsIn(m);
    if (tr.tunnel || !vx.isValid() || !kind || x == tr.first || (onFront && !frontSplit)) return false;
    if (const Track* P = trackById(tr.partner); P && (x == P->tip || x == P->first)) return false;
    if (frontSplit) return splitEdgeQuality(m, e, q) >= sliverHeight();
    bool opened = false;  // (v, x) is an edge of the opening: a wall face on one side
    for (int k = 0; k < 2; ++k)
      if (const Face g = m.face(vx, k); g.isValid() && kind[g] != kSurface) opened = true;
    return opened && splitEdgeQuality(m, e, q) >= sliverHeight();
  }

  // From the track's tip, follows the curve where the plane (through the tip, unit
  // normal n) meets the surface, in the direction `forward` at the start, inserting
  // a vertex at every edge it crosses (extending the cut). Stops when the goal point
  // lies in a face around the current vertex (or the goal vertex is a neighbour).
  // With `collect`, the new vertices are only inserted and listed (the cut does not
  // open along them yet).
  WalkResult walk(Track& tr, const WalkGoal& goal, const Vec3& n, const Vec3& forward, double maxLen,
                  const Vec3& depth0, const Vec3& depth1, std::vector<Vertex>* collect = nullptr) {
    const auto ended = [](WalkEnd e) { return WalkResult{e, Edge()}; };
    const WalkResult reached;
    const Vec3 origin = meshOf(tr.object).position(tr.tip);
    // depth0 belongs to the last sampled point (the pending one, else the tip): the
    // depth at a crossing is interpolated between the two samples around it, so it does
    // not depend on the sampling rate.
    const Vec3 depthFrom = tr.hasPending ? tr.pending : origin;
    const Vec3 span = goal.toVertex ? Vec3::Zero() : Vec3(goal.point - depthFrom);
    const Vec3& rd = goal.reach;
    const Reach reach{rd, rd.isZero() ? 0.0 : std::max({depth0.dot(rd), depth1.dot(rd), tr.tipDepth.dot(rd)})};
    int sgn = 0;
    double travelled = 0.0;
    Vec3 heading = forward;
    const int maxSteps = 100000;
    std::array<Way, 6> ways;  // (step 0's, below)
    for (int step = 0; step < maxSteps; ++step) {
      SurfaceMesh& m = meshOf(tr.object);
      const Vertex v = tr.tip;
      const Vec3 pv = m.position(v);
      facesAround(m, v, walkFaces);
      const std::vector<Face>& around = walkFaces;
      auto own = [&](Face f) {
        for (Vertex x : m.vertices(f))
          if (!tr.visited.count(x)) return false;
        return true;
      };
      if (goal.toVertex) {
        if (v == goal.vertex) return reached;
        for (Face f : around)
          if (!own(f) && m.localIndex(f, goal.vertex) >= 0) return reached;
      } else {
        if ((goal.point - pv).norm() <= 1e-9 * scaleOf(pv)) return reached;
        for (Face f : around)
          if (pointInFace(m, f, goal.point)) {
            tr.pendingFace = f;
            return reached;
          }
        if (goal.stopAtLip && acrossLip(m, tr, v, around, goal) &&
            pastBlade(m, v, goal, n, heading, depth1, maxLen - travelled)) {
          if (dbg()) std::cerr << "walk: at an earlier cut's lip at " << pv.transpose() << " step " << step << "\n";
          return ended(WalkEnd::AtLip);
        }
      }
      // Candidates: where the plane leaves the fan of v, ahead of v (a crossing, or the
      // corner vx on the plane).
      struct Cand {
        Way way;
        bool isVertex = false;
        Vertex vx;
      } best;
      bool found = false;
      // The first step's crossings ahead (chooseWay; a corner on the plane, or more than
      // the array holds, leaves the choice to the score).
      std::size_t nWays = 0;
      bool noChoice = false;
      const bool choosing = step == 0 && goal.chooseWay;
      const double eps = 1e-10 * scaleOf(pv);
      // Each corner's visited test once per face (own(f): all three are on the cut).
      const bool tipOnCut = tr.visited.count(v);
      for (Face f : around) {
        const FanEdge fan = fanEdge(m, f, v);
        const Vertex a = fan.a, b = fan.b;  // (named: the lambda below captures them)
        const bool onA = tr.visited.count(a), onB = tr.visited.count(b);
        if (fan.k >= 0 ? tipOnCut && onA && onB : own(f)) continue;
        const double sa = n.dot(m.position(a) - origin), sb = n.dot(m.position(b) - origin);
        const bool za = std::abs(sa) <= eps, zb = std::abs(sb) <= eps;
        const bool atA = za && !onA, atB = zb && !onB;
        const bool across = !za && !zb && ((sa > 0) != (sb > 0)) && !(onA && onB);
        if (!atA && !atB && !across) continue;  // no candidate here: its normal is not needed
        Vec3 nf = rawNormal(m, f);
        const double nl = nf.norm();
        if (!(nl > 0.0)) continue;
        nf /= nl;
        if (std::abs(nf.dot(n)) > 1.0 - 1e-9) continue;  // in the sweep plane itself
        const Vec3 tf = n.cross(nf);
        auto consider = [&](bool isV, Vertex vx, const Vec3& q) {
          const Vec3 d = q - pv;
          const double dl = d.norm();
          if (!(dl > 0.0)) return;
          const Vec3 dn = d / dl;
          const double along = dn.dot(tf);
          const int sign = along >= 0 ? 1 : -1;
          const double score = sgn == 0 ? dn.dot(forward) : sgn * along;
          // The first step only has to avoid going back (around an edge of the
          // object the curve may turn square to `forward`); later steps keep the
          // curve's orientation.
          if (sgn == 0 ? score <= kFirstStepMinCos : score <= 1e-9) return;
          const Way way{f, a, b, q, score, sign};
          if (choosing) {
            if (isV || nWays == ways.size())
              noChoice = true;
            else
              ways[nWays++] = way;
          }
          if (!found || score > best.way.score) {
            found = true;
            best = Cand{way, isV, vx};
          }
        };
        if (atA) consider(true, a, m.position(a));
        if (atB) consider(true, b, m.position(b));
        if (across) {
          const Vec3 q = m.position(a) + (m.position(b) - m.position(a)) * (sa / (sa - sb));
          consider(false, Vertex(), q);
        }
      }
      if (found && choosing && !noChoice && nWays >= 2)
        if (const int k = wayToGoal(m, tr, pv, std::span(ways.data(), nWays), goal, n, maxLen, reach); k >= 0) {
          best = Cand{ways[static_cast<std::size_t>(k)], false, Vertex()};
        }
      // The trace only follows the plane: the walk snaps onto corners near it and stops
      // where the goal lies in any face around its tip, so it may arrive sooner (slab 4449:
      // the walk arrived within its length, the trace after 1.3-1.4 times that). Only a
      // curve clearly too long, or crossing the cut itself, fails here.
      if (found && step == 0 && goal.mustReach && !best.isVertex) {
        bool missed = false;
        const bool reaches = curveReaches(m, tr, pv, best.way, goal, n, kMustReachSlack * maxLen, reach, &missed);
        if (!reaches && missed) {
          if (dbg()) std::cerr << "walk: its curve does not reach the goal from " << pv.transpose() << "\n";
          return ended(WalkEnd::Unreached);
        }
      }
      // On still tissue: the plane leaves the fan nowhere ahead but passes a corner ahead
      // within the snapping distance (a stroke along an earlier cut's lip, grazing its next
      // vertex): step onto that corner instead of losing the track (the curve's
      // orientation stays to be set by a later step).
      bool grazed = false;
      if (!found && !movedSincePrev && closedObject(tr.object)) {
        double off = p.snapDistance;
        for (Face f : around)
          for (Vertex x : m.vertices(f)) {
            const Vec3 d = m.position(x) - pv;
            const double dist = std::abs(n.dot(m.position(x) - origin)), dl = d.norm();
            if (x == v || tr.visited.count(x) || dist > off || !(d.dot(heading) > 0.5 * dl)) continue;
            off = dist;
            best = Cand{Way{Face(), Vertex(), Vertex(), m.position(x), 1.0, 0}, true, x};
            found = grazed = true;
          }
        if (grazed && dbg()) std::cerr << "walk: grazes " << best.way.q.transpose() << " off " << off << "\n";
      }
      if (!found) {
        if (dbg()) std::cerr << "walk: no candidate at " << pv.transpose() << " step " << step << "\n";
        return ended(!closedObject(tr.object) && m.isBoundary(v) ? WalkEnd::AtRim : WalkEnd::NoWay);
      }
      if (sgn == 0 && !grazed) sgn = best.way.sign;
      heading = (best.way.q - pv).normalized();
      travelled += (best.way.q - pv).norm();
      if (travelled > maxLen) {
        if (dbg()) std::cerr << "walk: too long at " << pv.transpose() << "\n";
        return ended(WalkEnd::TooLong);
      }
      const double s =
          span.squaredNorm() > 0 ? std::clamp((best.way.q - depthFrom).dot(span) / span.squaredNorm(), 0.0, 1.0) : 0.0;
      const Vec3 depth = depth0 + s * (depth1 - depth0);
      // The blade cuts no surface beyond its tip: a groove's curve going deeper than the
      // blade has been since the tip (at the tip, the last sample, this one) has left it,
      // down an earlier cut's wall or the wrong way round the object, cutting all the
      // way (slab seeds 1207, 1446 ran along the slab's bottom until the walk was too
      // long). It stops there as at an earlier cut's lip, before cutting that far.
      if (reach.passedBy(best.way.q, p.snapDistance)) {
        if (dbg())
          std::cerr << "walk: past the blade's reach at " << best.way.q.transpose() << " step " << step << "\n";
        return ended(WalkEnd::PastReach);
      }
      Vertex N;
      if (best.isVertex) {
        N = best.vx;
      } else {
        const Edge e = m.findEdge(best.way.a, best.way.b);
        bool blocked = false;
        N = edgeSnap(m, e, best.way.q, &tr.visited, &blocked);
        if (blocked) {  // would touch the cut itself
          // ... unless that is where the walk goes (a cut joining its own start).
          if (goal.toVertex && (m.vertex(e, 0) == goal.vertex || m.vertex(e, 1) == goal.vertex) &&
              m.findEdge(v, goal.vertex).isValid())
            return reached;
          // ... or the path turns back past its last edge's far end: split beside it.
          if (!hairpinSplit(m, tr, v, e, best.way.q)) return WalkResult{WalkEnd::Blocked, e};
        }
        if (!N.isValid()) N = splitEdgeAt(tr.object, e, best.way.q);
        ++stats.trianglesCut;
        ++res->trianglesCut;
      }
      if (!m.findEdge(v, N).isValid()) return ended(WalkEnd::NotAdjacent);
      if (collect) {
        mark(tr, N);
        tr.tip = N;
        collect->push_back(N);
        continue;
      }
      extend(tr, N, depth);
      if (tr.tip != N) return ended(WalkEnd::Refused);
      // A cut-through stops on the wall of another cut (it would walk down that wall
      // to the other layer): advance waits there for the partner (onEarlierWall).
      if (tr.partner >= 0 && !tr.tunnel && onEarlierWall(tr)) return ended(WalkEnd::AtEarlierWall);
    }
    return ended(WalkEnd::TooLong);
  }

  // Plane normal for a path from `from` toward `to` swept by an edge along `blade`.
  static Vec3 sweepNormal(const Vec3& from, const Vec3& to, const Vec3& blade, const Vec3& fallback) {
    const Vec3 d = to - from;
    Vec3 n = d.cross(blade);
    if (n.norm() > 1e-9 * (d.norm() + 1e-300) * (blade.norm() + 1e-300) && n.norm() > 1e-14) return n.normalized();
    n = d.cross(fallback);
    if (n.norm() > 1e-14) return n.normalized();
    return Vec3::Zero();
  }

  // ---- points of the tissue -------------------------------------------------------------------
  // Ties P to face f when it lies in it (else to a face around f's corners, or around
  // `near`, that holds it).
  Anchor anchorOf(const SurfaceMesh& m, Face f, const Vec3& P, Vertex near = Vertex()) {
    Anchor a;
    auto tie = [&](Face g) {
      if (!m.isValid(g) || !pointInFace(m, g, P, 1e-7)) return false;
      a.corners = m.vertices(g);
      a.weights = barycentric(m, g, P);
      a.valid = true;
      return true;
    };
    if (tie(f)) return a;
    if (m.isValid(near))
      for (Face g : m.faces(near))
        if (tie(g)) return a;
    if (m.isValid(f))
      for (Vertex v : m.vertices(f))
        for (Face g : m.faces(v))
          if (tie(g)) return a;
    return a;
  }

  static Vec3 placeOf(const SurfaceMesh& m, const Anchor& a) {
    return a.weights[0] * m.position(a.corners[0]) + a.weights[1] * m.position(a.corners[1]) +
           a.weights[2] * m.position(a.corners[2]);
  }

  // After every sample: where the track's start and pending points sit in the tissue.
  void anchor(Track& tr) {
    if (!tr.alive) return;
    const SurfaceMesh& m = meshOf(tr.object);
    tr.startAt = (tr.hasStart && !tr.tip.isValid()) ? anchorOf(m, tr.startFace, tr.start) : Anchor();
    if (!tr.hasPending)
      tr.pendingAt = Anchor();
    else if (tr.tip.isValid())
      tr.pendingAt = anchorOf(m, tr.pendingFace, tr.pending, tr.tip);
    else
      tr.pendingAt = anchorOf(m, tr.startFace, tr.pending);
    tr.anchoredAt = motionCount;
  }

  // Before a sample: the tissue may have moved since (physics), and the track's start
  // and pending points with it; crossings are matched and walked to where they are now.
  void followTissue(Track& tr) {
    if (!tr.alive || tr.anchoredAt == motionCount) return;
    const SurfaceMesh& m = meshOf(tr.object);
    auto valid = [&](const Anchor& a) {
      return a.valid && m.isValid(a.corners[0]) && m.isValid(a.corners[1]) && m.isValid(a.corners[2]);
    };
    if (tr.hasStart && !tr.tip.isValid() && valid(tr.startAt)) tr.start = placeOf(m, tr.startAt);
    if (tr.hasPending && valid(tr.pendingAt)) tr.pending = placeOf(m, tr.pendingAt);
    tr.anchoredAt = motionCount;
  }

  // The tissue moved under the blade (physics: a cut retracts and gapes, its tip
  // running ahead): the blade now meets the cut behind its tip (a wall of the opening,
  // a lip, or nothing). The cut waits there until the blade reaches tissue ahead of the
  // tip again, instead of walking backward or sideways (or ending and starting anew).
  bool behindTip(const Track& tr, const Vec3& P) const {
    if (!tr.tip.isValid() || !tr.prevTip.isValid()) return false;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(indexOf(tr.object))].mesh;
    if (!m.isValid(tr.prevTip)) return false;
    const Vec3 pt = m.position(tr.tip), dir = pt - m.position(tr.prevTip);
    const Vec3 d = P - pt;
    return dir.norm() > 0.0 && d.norm() <= p.matchRadius && d.dot(dir) < 0.0;
  }
  bool holdsAt(const Track& tr, const Hit& h) const {
    if (behindTip(tr, h.point)) return true;
    if (!tr.tip.isValid()) return false;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(indexOf(tr.object))].mesh;
    if (!movedSincePrev && onLipBackward(m, tr, h)) return true;
    const auto kind = kindsIn(m);
    if (!m.isValid(h.face) || !kind || (h.point - m.position(tr.tip)).norm() > p.matchRadius) return false;
    return kind[h.face] != kSurface || (movedSincePrev && tr.partner >= 0 && !tr.tunnel && onLipBehind(m, tr, h.face));
  }
  // f's corners on the cut (path vertices and their copies): two make a face along it.
  static int cornersOnCut(const SurfaceMesh& m, const Track& tr, Face f) {
    int onCut = 0;
    for (Vertex x : m.vertices(f)) onCut += tr.visited.count(x) ? 1 : 0;
    return onCut;
  }
  // A lip of the cut behind its last edge: a surface face along the cut (two corners on
  // it) at the far end of that edge (either copy), not at the tip. (Only for an opened
  // cut-through: a groove's, or a tunnel's before it opens, lips curl up into the blade's
  // way, and holding there changed the curling-groove test's cut.) On moving tissue the
  // copies part with the lips, and the way from the one copy to the tip (behindTip) can
  // point anywhere: a crossing back on the lip then read as ahead, and the walk to it,
  // stopped by the cut's own vertex, ended the track (moving seed 40236).
  static bool onLipBehind(const SurfaceMesh& m, const Track& tr, Face f) {
    bool atPrev = false;
    for (Vertex x : m.vertices(f)) {
      if (x == tr.tip) return false;
      atPrev = atPrev || (x.isValid() && (x == tr.prevTip || x == tr.prevTipCopy));
    }
    return atPrev && cornersOnCut(m, tr, f) >= 2;
  }
  // On still tissue: the crossing has gone back along the cut, onto a face along it (two
  // corners on it), behind the tip. A blade nearly in the face it crosses slides its
  // crossing along the cut much faster than it moves (on the cylinder's side a diving
  // blade's crossing climbs back up the path; a blade lying 7 degrees off the top face
  // moves its crossing 8 x its rise): past the matching radius behindTip let go, the walk
  // back was stopped by the cut's own vertex and the track ended (deepening seeds 23115,
  // 23160; disc 3087). Nothing there is left to cut: the track waits for the blade to
  // come ahead of its tip again.
  static bool onLipBackward(const SurfaceMesh& m, const Track& tr, const Hit& h) {
    if (!m.isValid(h.face) || !m.isValid(tr.prevTip)) return false;
    const Vec3 pt = m.position(tr.tip);
    return cornersOnCut(m, tr, h.face) >= 2 && (h.point - pt).dot(pt - m.position(tr.prevTip)) < 0.0;
  }
  // No crossing for the track: the blade passes by its tip inside the opening.
  bool holdsWithout(const Track& tr, const instruments::Segment& s) const {
    if (!tr.tip.isValid()) return false;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(indexOf(tr.object))].mesh;
    const Vec3 pt = m.position(tr.tip), ab = s.b - s.a;
    const double u = ab.squaredNorm() > 0 ? std::clamp((pt - s.a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
    const Vec3 q = s.a + u * ab;
    return u > 0.0 && u < 1.0 && behindTip(tr, q);
  }

  // ---- track life ---------------------------------------------------------------------------
  void commitStart(Track& tr) {
    if (tr.tip.isValid() || !tr.hasStart) return;
    SurfaceMesh& m = meshOf(tr.object);
    const Face f = locate(m, tr.startFace, tr.start);
    tr.hasStart = false;
    if (!f.isValid()) {
      tr.alive = false;
      ++stats.walkFailures;
      return;
    }
    Vertex v;
    if (tr.startMotion.norm() > 1e-9) {
      // A blade that came in over the rim of a sheet or over an edge of the object
      // starts the cut on that edge (cut-in), wherever the first sample caught it.
      const Vec3 n = sweepNormal(tr.start, tr.start + tr.startMotion, tr.startBlade, tr.startMotion);
      if (!n.isZero()) v = entryVertex(tr.object, f, tr.start, n, -tr.startMotion, true);
      Edge rim;
      Vec3 at;
      Vertex corner;
      const Hit::PastSlit& past = tr.startPastSlit;
      const bool slit = past.back.norm() > 0.0;  // restarting past a slit: its walk's plane
      if (!v.isValid() && !n.isZero() && !closedObject(tr.object) &&
          rimBehind(m, f, tr.start, slit ? past.normal : n, slit ? past.back : Vec3(-tr.startMotion),
                    (slit ? past.back : tr.startMotion).norm() + p.snapDistance, rim, at, corner)) {
        v = corner.isValid() ? corner : pointOnEdge(tr.object, rim, at);
      }
    }
    if (!v.isValid()) v = insertPoint(tr.object, f, tr.start);
    ++stats.trianglesCut;
    ++res->trianglesCut;
    extend(tr, v, tr.startDepth);
  }

  // The blade is still inside the triangle of the pending point: nothing to edit,
  // the sample only moves the temporary point. Same outcome as advance() (whose walk
  // stops at once), without touching the mesh.
  bool advanceFast(Track& tr, const Hit& h) {
    const SurfaceMesh& m = meshOf(tr.object);
    if (!tr.tip.isValid()) {
      if (!tr.hasStart || !m.isValid(tr.startFace) || !pointInFace(m, tr.startFace, tr.start) ||
          !pointInFace(m, tr.startFace, h.point))
        return false;
    } else if (!m.isValid(tr.pendingFace) || m.localIndex(tr.pendingFace, tr.tip) < 0 ||
               !pointInFace(m, tr.pendingFace, h.point)) {
      return false;
    }
    tr.pending = h.point;
    tr.pendingDepth = h.depth;
    tr.hasPending = true;
    return true;
  }

  bool movedSincePrev = false;  // the tissue moved since the hand's last sample (processSample)
  bool stepMoved = false;       // ... since the hand's last step (set by step(), for all its substeps)
  bool wallCutOut = false;  // cutOut across another cut's wall: no slivers, no rung
  bool liftCutOut = false;  // cutOut as the hand lifts (leavingOverSide): no slivers
  // The track's tip is on a wall of another cut (a wall face not of this cut).
  bool onEarlierWall(const Track& tr) const {
    if (tr.partner < 0 || !tr.tip.isValid()) return false;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(indexOf(tr.object))].mesh;
    const auto kind = kindsIn(m);
    if (!kind || !m.isValid(tr.tip)) return false;
    // Each face from both its sides at the tip, without building the face list (asked
    // at every step of a cut-through's walk): the same answer.
    for (Edge e : m.edges(tr.tip))
      for (int s = 0; s < 2; ++s) {
        const Face f = m.face(e, s);
        if (!f.isValid() || kind[f] == kSurface) continue;
        for (Vertex x : m.vertices(f))
          if (!tr.visited.count(x)) return true;
      }
    return false;
  }

  // Both tips on one wall of another cut, across it from each other: the front between
  // them lies along that wall (in the plane of a wall face at each tip).
  bool acrossWall(const Track& A, const Track& B) const {
    const SurfaceMesh& m = objects[static_cast<std::size_t>(indexOf(A.object))].mesh;
    const auto kind = kindsIn(m);
    const Vec3 d = m.position(B.tip) - m.position(A.tip);
    if (!kind || !(d.norm() > 0.0) || d.norm() > 4.0 * p.matchRadius) return false;
    auto along = [&](const Track& T) {
      for (Face f : m.faces(T.tip)) {
        if (kind[f] == kSurface) continue;
        bool own = true;
        for (Vertex x : m.vertices(f)) own = own && T.visited.count(x);
        if (!own && std::abs(rawNormal(m, f).normalized().dot(d.normalized())) < 0.25) return true;
      }
      return false;
    };
    if (!along(A) || !along(B)) return false;
    // ... and on one wall: B's tip is a corner of A's wall faces' connected neighbours
    // (wall faces of other cuts, a few hundred at most).
    std::vector<Face> todo, seen;
    for (Face f : m.faces(A.tip))
      if (kind[f] != kSurface) todo.push_back(f);
    while (!todo.empty() && seen.size() < 256) {
      const Face f = todo.back();
      todo.pop_back();
      if (std::find(seen.begin(), seen.end(), f) != seen.end()) continue;
      seen.push_back(f);
      if (m.localIndex(f, B.tip) >= 0) return true;
      for (Vertex x : m.vertices(f))
        for (Face g : m.faces(x))
          if (kind[g] != kSurface && std::find(seen.begin(), seen.end(), g) == seen.end()) todo.push_back(g);
    }
    return false;
  }

  void advance(Track& tr, Hit& h, const Vec3& bladeDir) {
    SurfaceMesh& m0 = meshOf(tr.object);
    tr.pendingFace = Face();
    if (!tr.tip.isValid()) {
      const Face f = locate(m0, tr.startFace, tr.start);
      if (f.isValid() && pointInFace(m0, f, h.point)) {
        tr.startFace = f;
        tr.pending = h.point;
        tr.pendingDepth = h.depth;
        tr.hasPending = true;
        return;
      }
      commitStart(tr);
      if (!tr.alive) return;
    }
    if (holdsAt(tr, h)) {
      ++stats.holds;
      return;
    }
    SurfaceMesh& m = meshOf(tr.object);
    const Vec3 from = m.position(tr.tip);
    Vec3 fallback = Vec3::UnitZ();
    // The first face around the tip (SurfaceMesh::faces order), without the list.
    for (Edge e : m.edges(tr.tip))
      if (const Face f = m.face(e, 0).isValid() ? m.face(e, 0) : m.face(e, 1); f.isValid()) {
        fallback = rawNormal(m, f).normalized();
        break;
      }
    const Vec3 n = sweepNormal(from, h.point, bladeDir, fallback);
    WalkResult w{WalkEnd::NoWay, Edge()};
    if (n.isZero()) {
      for (Face f : m.faces(tr.tip))
        if (pointInFace(m, f, h.point)) w.end = WalkEnd::Reached;
    } else {
      const double dist = (h.point - from).norm();
      WalkGoal g;
      g.point = h.point;
      g.face = h.face;
      // (A cut-through's layers wait on an earlier cut's wall for each other instead.)
      g.stopAtLip = tr.partner < 0 || tr.tunnel;
      const Vec3 d0 = tr.hasPending ? tr.pendingDepth : tr.tipDepth;
      // (Still, closed tissue: the reach for grooves, the choice of way for every track.)
      const bool stillClosed = !movedSincePrev && closedObject(tr.object);
      if (stillClosed && tr.partner < 0 && !tr.tunnel && h.dir != 0) g.reach = h.dir * bladeDir;
      g.chooseWay = stillClosed;
      w = walk(tr, g, n, (h.point - from).normalized(), 4.0 * dist + 4.0 * p.matchRadius, d0, h.depth);
    }
    const bool ok = static_cast<bool>(w);
    if (w.atLip()) {
      // An earlier cut's lip, the blade's point across its gap: the track ends here and
      // the hit starts a new one beyond. On a sheet the slit (or the rim) itself: no
      // tissue joins the tip to the point, and the new track starts on the far lip, on
      // this walk's plane (commitStart: rimBehind).
      if (dbg())
        std::cerr << "advance: track " << tr.id << " ends at an earlier cut's lip (" << walkEndName(w.end) << ")\n";
      ++stats.lipStops;
      endForFreshTrack(tr, h);
      if (w.end == WalkEnd::AtRim) h.restart = Hit::PastSlit{from - h.point, n};
      return;
    }
    if (w.end == WalkEnd::Blocked) {
      // The crossing has reached the other layer's tip (both layers leave over the
      // same side, and the other got there first): nothing is left to cut on this side
      // of it; the track waits for the cut-out.
      const SurfaceMesh& mb = meshOf(tr.object);
      // Likewise at the cut's own start (a pierce coming round to it): it joins there
      // when it ends (joinStart).
      if (const Track* P = trackById(tr.partner);
          P && P->tip.isValid() && mb.isValid(w.blockedAt) &&
          (w.blockedAtEnd(mb, P->tip) || w.blockedAtEnd(mb, tr.first) || w.blockedAtEnd(mb, P->first))) {
        if (dbg()) std::cerr << "advance: track " << tr.id << " holds at its partner's tip\n";
        ++stats.holds;
        return;
      }
    }
    // A walk that stopped on the wall itself waits there with the point past the matching
    // radius too, for a sample or two: crossing an earlier slot at a slant, the other
    // layer gets there a sample or two later (disc 3227, cylinder 4664 free their piece).
    // Any longer, the layer would keep taking the blade's crossings while the blade
    // moves on, and start its new track later, past tissue it used to cut.
    bool waitsOnWall = !ok && !tr.tunnel && onEarlierWall(tr);
    if (waitsOnWall && (h.point - meshOf(tr.object).position(tr.tip)).norm() > p.matchRadius) {
      waitsOnWall = w.end == WalkEnd::AtEarlierWall && tr.wallWaitsPastRadius < kWallWaitsPastRadius;
      if (waitsOnWall) ++tr.wallWaitsPastRadius;
    }
    if (waitsOnWall) {
      // An earlier cut's wall ahead (its slot is closed: the walls coincide): wait
      // there for the other layer; once both are on it, cut out across it.
      if (dbg()) std::cerr << "advance: track " << tr.id << " at an earlier cut's wall\n";
      tr.atWall = true;
      Track* P = trackById(tr.partner);
      if (!P || !P->atWall) {
        ++stats.holds;
        return;
      }
      if (acrossWall(tr, *P)) {
        SurfaceMesh& mw = meshOf(tr.object);
        wallCutOut = true;
        cutOut(tr, *P, h.point - mw.position(tr.tip));
        wallCutOut = false;
        return;
      }
    }
    if (!ok) {
      if (dbg()) {
        const SurfaceMesh& md = meshOf(tr.object);
        int own = -1, kind = -1;
        if (md.isValid(h.face)) {
          own = cornersOnCut(md, tr, h.face) == 3 ? 1 : 0;
          kind = md.getFaceProperty<int>(kFaceKindProp)[h.face];
        }
        std::cerr << "advance: walk failed for track " << tr.id << " to " << h.point.transpose() << " from "
                  << from.transpose() << " hitface own " << own << " kind " << kind << " partner " << tr.partner
                  << " chain " << tr.chain.size() << " (" << walkEndName(w.end) << ")\n";
        if (w.end == WalkEnd::Blocked && md.isValid(w.blockedAt))
          std::cerr << "advance: blocked next to" << (w.blockedAtEnd(md, tr.first) ? " its first vertex" : "")
                    << (w.blockedAtEnd(md, tr.prevTip) || w.blockedAtEnd(md, tr.prevTipCopy) ? " its last edge" : "")
                    << " (path " << tr.pathLength << ")\n";
      }
      if (const SurfaceMesh& mb0 = meshOf(tr.object); w.end == WalkEnd::Blocked && mb0.isValid(w.blockedAt) &&
                                                      w.blockedAtEnd(mb0, tr.first) && closeOnStart(tr, h.point))
        return;  // (the hit is at the start: taken)
      if (mergesAtStart(tr, w, h)) {
        if (dbg()) std::cerr << "advance: track " << tr.id << " runs into an earlier cut at its start\n";
        ++stats.startsMerged;
        endForFreshTrack(tr, h);
        return;
      }
      countWalkFailure(w.end);
      if (!movedSincePrev && w.end == WalkEnd::Blocked) backPastStart(tr, w, h);
      endForFreshTrack(tr, h);
      return;
    }
    tr.pending = h.point;
    tr.pendingDepth = h.depth;
    tr.hasPending = true;
  }

  // The track ends where it is (its pending point dropped) and the hit is left to start
  // a fresh track: at the hit, or where h.restart says.
  void endForFreshTrack(Track& tr, Hit& h) {
    tr.hasPending = false;
    end(tr);
    h.used = false;
  }

  // A groove still within the matching radius of its start whose walk was blocked next to
  // its first vertex, the blade's point on a wall of another cut: the blade went into an
  // earlier cut right after it began (an L-hook's back edge starting beside its front
  // edge's groove, which the blade then follows). What the track would cut is cut; it ends
  // as a lip stop does, not as a walk failure, and the edits are the same.
  bool mergesAtStart(const Track& tr, const WalkResult& w, const Hit& h) const {
    if (w.end != WalkEnd::Blocked || tr.partner >= 0 || tr.tunnel || !(tr.pathLength < p.matchRadius)) return false;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(indexOf(tr.object))].mesh;
    const auto kind = kindsIn(m);
    return kind && m.isValid(w.blockedAt) && w.blockedAtEnd(m, tr.first) && m.isValid(h.face) &&
           kind[h.face] != kSurface && cornersOnCut(m, tr, h.face) < 3;
  }

  // A groove come round to its own start (a circle traced back to where it began): its
  // walk was blocked next to the first vertex, which the walk may not snap onto (or its
  // last point snapped onto it as the stroke ended), with the tip and the blade's point
  // within the matching radius of it after a path of more than 4 times that radius.
  // Where the tip and the first vertex share an edge of uncut surface, the cut opens
  // along that edge: the groove closes into a ring (nothing comes free: its bottom
  // holds) and the track ends. Else false: nothing was edited, or the step only grew
  // the front onto the first vertex (extend's deferral), and the caller goes on as it
  // would have (a walk failure, or the stroke's end).
  bool closeOnStart(Track& tr, const Vec3& point) {
    if (tr.partner >= 0 || tr.tunnel || !closedObject(tr.object)) return false;
    SurfaceMesh& m = meshOf(tr.object);
    const Vertex first = tr.first;
    if (!m.isValid(first) || tr.tip == first) return false;
    const Vec3 pf = m.position(first), from = m.position(tr.tip);
    if ((from - pf).norm() > p.matchRadius || (point - pf).norm() > p.matchRadius ||
        tr.pathLength < 4.0 * p.matchRadius)
      return false;
    const Edge e = m.findEdge(tr.tip, first);
    const auto kind = kindsIn(m);
    if (!e.isValid() || !kind) return false;
    for (int k = 0; k < 2; ++k)
      if (const Face f = m.face(e, k); !f.isValid() || kind[f] != kSurface) return false;
    // The groove's depth below the tip, carried to the start (read before extend moves
    // the tip and its depth there).
    const Vec3 depth = pf + (tr.tipDepth - from);
    const Vertex v = tr.tip;
    extend(tr, first, depth, true);
    // Opened: a wall face now borders the last edge (extend may instead grow the front).
    bool opened = false;
    if (const Edge last = m.findEdge(v, first); tr.tip == first && last.isValid())
      for (int k = 0; k < 2; ++k)
        if (const Face f = m.face(last, k); f.isValid() && kindsIn(m)[f] != kSurface) opened = true;
    if (!opened) return false;
    if (dbg()) std::cerr << "advance: track " << tr.id << " closes on its start\n";
    ++stats.startsClosed;
    openStart(tr, first, depth);
    end(tr);
    return true;
  }

  // After a groove closed on its start, the first vertex still joins the ring's two lips
  // (the groove began there, at the surface): a pinch in the ring. It opens as a step of
  // the groove does: split between the start's walls and the closing step's, the hole
  // closed with four wall triangles round a new bottom vertex at `depth`, or two round
  // the closing step's bottom vertex, whichever is thicker. Only where each of the two
  // wall groups meets it in exactly one edge between walls (their bottoms) and no new
  // triangle is thinner than a fill's threshold; else the pinch stays.
  void openStart(Track& tr, Vertex F, const Vec3& depth) {
    SurfaceMesh& m = meshOf(tr.object);
    const auto kind = kindsIn(m);
    if (!kind || !depth.allFinite()) return;
    std::vector<Edge> bottoms;
    for (Edge e : m.edges(F)) {
      const Face f0 = m.face(e, 0), f1 = m.face(e, 1);
      if (f0.isValid() && f1.isValid() && kind[f0] != kSurface && kind[f1] != kSurface) bottoms.push_back(e);
    }
    if (bottoms.size() > 2) {
      // More edges between walls meet at the start: other cuts began there too (an
      // L-hook's first sample cuts a slit with its foot beside the shaft's groove). The
      // ring's own two are the closing step's (its walls reach the last tip or its copy)
      // and the deepest other one of this groove below the surface round F; the rest
      // (another cut's bottom, or the top of a wall strip left between two cuts along one
      // line) stays with whichever side it is on.
      Vec3 n = Vec3::Zero();
      for (Face f : m.faces(F))
        if (kind[f] == kSurface) n += rawNormal(m, f).normalized();
      if (!(n.norm() > 0.0)) return;
      n.normalize();
      auto atLastTip = [&](Edge e) {
        for (int k = 0; k < 2; ++k)
          for (Vertex x : {tr.prevTip, tr.prevTipCopy})
            if (x.isValid() && m.localIndex(m.face(e, k), x) >= 0) return true;
        return false;
      };
      Edge closing, start;
      double deepest = p.snapDistance;
      for (Edge e : bottoms) {
        const Vertex x = m.otherVertex(e, F);
        if (atLastTip(e)) {
          if (closing.isValid()) return;  // (two: not told apart)
          closing = e;
        } else if (const double below = n.dot(m.position(F) - m.position(x)); tr.visited.count(x) && below > deepest) {
          deepest = below;
          start = e;
        }
      }
      if (dbg())
        std::cerr << "openStart: " << bottoms.size() << " bottoms at the start, this groove's found "
                  << closing.isValid() << start.isValid() << "\n";
      if (!closing.isValid() || !start.isValid()) return;
      bottoms.assign({closing, start});
    }
    if (bottoms.size() != 2) return;
    const Vertex b = m.otherVertex(bottoms[0], F), a = m.otherVertex(bottoms[1], F);
    if (a == b) return;
    // As extend chooses: a new bottom vertex at `depth`, or (when the closing step's own
    // bottom vertex is already there, or the blade is shallow) the two triangles round
    // one of the bottoms.
    const Vec3 pF = m.position(F), pa = m.position(a), pb = m.position(b);
    const double qApex = std::min(height(pF, pb, depth), height(pF, pa, depth));
    const double qFan = m.findEdge(a, b).isValid() ? -1.0 : height(pF, pb, pa);
    if (std::max(qApex, qFan) < 0.5 * p.snapDistance) return;
    const bool newApex = qApex >= qFan;
    // Two groups, each with surface (a lip of the ring): the inner and the outer side.
    if (fanLabels(m, F, bottoms) != 2) return;
    for (int g = 0; g < 2; ++g) {
      bool lip = false;
      for (Face f : fanOf(g)) lip = lip || kind[f] == kSurface;
      if (!lip) return;
    }
    const std::vector<Vertex> made = splitByGroups(tr.object, F, bottoms);
    if (made.size() != 1) return;  // (two groups: one copy)
    const Vertex F2 = made.front();
    const Vertex B = fillQuad(tr.object, F, b, F2, a, newApex, depth, kGrooveWall);
    if (!B.isValid()) {
      if (!fillHoleAt(tr.object, F, kGrooveWall)) ++stats.fillFailures;
      touchEach(tr.object, std::array<Vertex, 4>{F, F2, a, b});
      return;
    }
    mark(tr, F2);
    mark(tr, B);
    if (dbg()) std::cerr << "openStart: " << F << " opens round " << m.position(B).transpose() << "\n";
    ++stats.startsOpened;
    const std::array<Vertex, 5> touched{F, F2, B, a, b};
    touchEach(tr.object, touched);
    for (Vertex x : touched) unpinch(tr.object, x);
  }

  // On still tissue: the walk's first step was blocked by the cut's own last edge (its
  // far end or that end's copy), the crossing behind the tip past the matching radius and
  // past the cut's start, along its line (a blade nearly in the face it crosses slides
  // its crossing back along the cut faster than it moves; deepening seeds 20087, 20207).
  // The track ends; the new one starts just past the old start, toward the crossing,
  // instead of at the crossing (the stretch between used to stay uncut).
  void backPastStart(const Track& tr, const WalkResult& w, Hit& h) {
    const SurfaceMesh& m = meshOf(tr.object);
    if (!m.isValid(w.blockedAt) || !m.isValid(tr.first) ||
        !(w.blockedAtEnd(m, tr.prevTip) || w.blockedAtEnd(m, tr.prevTipCopy)))
      return;
    const Vec3 pf = m.position(tr.first), pt = m.position(tr.tip), r = h.point - pf;
    if (!((pt - pf).norm() > 0.0)) return;
    const Vec3 ax = (pt - pf).normalized();
    const double along = r.dot(ax), lateral = (r - along * ax).norm();
    const double gap = 4.0 * p.snapDistance;  // clear of the old start's snapping distance
    if (!(along < 0.0) || lateral > -along || r.norm() <= 2.0 * gap) return;
    const Vec3 q = pf + gap * r.normalized();
    Face f;
    for (Face g : m.faces(tr.first))
      if (pointInFace(m, g, q)) f = g;
    if (!f.isValid()) f = locate(m, h.face, q);
    if (!f.isValid()) return;
    for (Vertex x : m.vertices(f))
      if (tr.visited.count(x) && (m.position(x) - q).norm() <= p.snapDistance) return;
    if (dbg())
      std::cerr << "advance: crossing back past the cut's start: the new track starts at " << q.transpose() << "\n";
    h.restart = Hit::PastStart{f, q};
  }

  // The blade left this layer: the temporary point becomes permanent and the cut ends.
  // On a sheet (open mesh, no walls) a blade that moved on over the rim cuts out to it.
  void terminate(Track& tr, const Vec3& motion = Vec3::Zero(), const Vec3& blade = Vec3::Zero(), bool unpair = true) {
    if (!tr.alive) return;
    if (dbg()) std::cerr << "terminate track " << tr.id << " pending " << tr.pending.transpose() << "\n";
    if (!tr.tip.isValid() && tr.hasStart) commitStart(tr);
    if (tr.alive && tr.tip.isValid() && tr.hasPending && !closedObject(tr.object) && motion.norm() > 1e-9 &&
        blade.norm() > 0) {
      SurfaceMesh& m = meshOf(tr.object);
      const Vec3 from = m.position(tr.tip);
      const Vec3 goalPoint = tr.pending + 2.0 * motion;
      const Vec3 n = sweepNormal(from, goalPoint, blade, motion);
      if (!n.isZero() && (goalPoint - from).cross(blade).norm() > 1e-6 * (goalPoint - from).norm()) {
        WalkGoal g;
        g.point = goalPoint;
        // (However far it gets, the cut ends there.)
        (void)walk(tr, g, n, (goalPoint - from).normalized(), (goalPoint - from).norm() + p.snapDistance, tr.tipDepth,
                   tr.tipDepth);
        tr.hasPending = false;
        // A cut from rim to rim may have freed a piece of the sheet.
        if (tr.tip.isValid() && meshOf(tr.object).isBoundary(tr.tip)) checkSeparation.push_back(tr.object);
      }
    }
    if (tr.alive && tr.tip.isValid() && tr.hasPending) {
      SurfaceMesh& m = meshOf(tr.object);
      if ((tr.pending - m.position(tr.tip)).norm() > p.snapDistance) {
        Face f;
        for (Face g : m.faces(tr.tip))
          if (pointInFace(m, g, tr.pending, 1e-7)) {
            f = g;
            break;
          }
        if (f.isValid()) {
          const Vertex N = insertPoint(tr.object, f, tr.pending);
          ++stats.trianglesCut;
          ++res->trianglesCut;
          if (N != tr.tip && !tr.visited.count(N) && m.findEdge(tr.tip, N).isValid())
            extend(tr, N, tr.pendingDepth, true);
        }
      }
    }
    // A groove ending where it began, after going round: it closes into a ring there.
    if (tr.alive && tr.tip.isValid())
      (void)closeOnStart(tr, tr.hasPending ? tr.pending : meshOf(tr.object).position(tr.tip));
    if (unpair) {
      end(tr);
    } else {
      tr.hasPending = false;  // the partner ends it after its own last step
    }
  }

  // The hand lifted (or stopped cutting): every cut ends where it is; a pair stays a
  // pair until both layers made their last step (side walls to the end).
  void terminateAll(HandState& hs) {
    for (auto& t : hs.tracks)
      if (Track* P = trackById(t.partner); t.alive && P) joinStart(t.dir < 0 ? t : *P, t.dir < 0 ? *P : t);
    for (auto& t : hs.tracks) {
      Track* P = trackById(t.partner);
      if (!t.alive || !P || !P->alive) continue;
      // On tissue that moved the side bows and the blade's lower end lags: either
      // crossing next to the side will do (moving seeds 40664, 41125).
      if (!leavingOverSide(t, *P) &&
          !(stepMoved && (leavingOverSide(t, *P, &t.pending) || leavingOverSide(t, *P, &P->pending))))
        continue;
      const bool pFront = t.chain.empty() || t.chain.back() != P->tip;  // whose front ends at the other's tip
      Track& A = pFront ? *P : t;
      Track& B = pFront ? t : *P;
      liftCutOut = true;
      cutOut(A, B, lastMotionOf(A, B));
      liftCutOut = false;
    }
    for (auto& t : hs.tracks)
      if (t.alive) terminate(t, Vec3::Zero(), Vec3::Zero(), false);
    for (auto& t : hs.tracks)
      if (t.alive) end(t);
    hs.tracks.clear();
    hs.stroke.clear();
  }

  // The hand lifted with both layers' crossings next to the face the blade was leaving
  // over (their midpoint within a few snapping distances of a face that faces the
  // blade's motion): a stroke that ends just past a side at a glancing angle, or a
  // tilted blade whose lower end is still inside. Ended there, the pair would leave a
  // strip of that face uncut and the piece attached by it; it cuts out instead. At the
  // entry side the face faces against the motion, and in the middle of the object no
  // face is that near.
  // The pair's blade motion (a layer the blade went through this sample has none yet).
  static const Vec3& lastMotionOf(const Track& A, const Track& B) {
    return A.lastMotion.squaredNorm() > 0.0 ? A.lastMotion : B.lastMotion;
  }
  bool leavingOverSide(const Track& A, const Track& B, const Vec3* at = nullptr) {
    if (A.tunnel || B.tunnel || A.object != B.object || !A.hasPending || !B.hasPending || !A.tip.isValid() ||
        !B.tip.isValid() || !closedObject(A.object))
      return false;
    const Vec3& motion = lastMotionOf(A, B);
    if (!(motion.squaredNorm() > 0.0)) return false;
    const std::size_t oi = static_cast<std::size_t>(indexOf(A.object));
    syncBvh(oi);
    const SurfaceMesh& m = objects[oi].mesh;
    const auto near = collision::nearestOnSurface(m, bvhs[oi], at ? *at : 0.5 * (A.pending + B.pending),
                                                  3.0 * p.snapDistance, scratchFaces);
    return near.face.isValid() && m.faceNormal(near.face).dot(motion) > 0.0;
  }

  void end(Track& tr) {
    tr.alive = false;
    tr.hasPending = false;
    if (Track* P = trackById(tr.partner)) {
      P->partner = -1;
      P->tunnel = false;  // goes on as a groove: its closed path opens as one
    }
    tr.partner = -1;
  }

  // A cut-through from a pierce (tunnel) that has come round to its own start: each
  // layer's path is walked on to its first vertex (the back end of the slot, where
  // the two layers' first vertices are joined by the slot's last rung), and the loop
  // tips - starts - the rung - front is cut and closed like a cut-out: what it encloses
  // comes free.
  bool joinStart(Track& A, Track& B) {
    if (!A.alive || !B.alive || A.tunnel || B.tunnel || !A.tip.isValid() || !B.tip.isValid()) return false;
    SurfaceMesh& m = meshOf(A.object);
    if (!m.isValid(A.first) || !m.isValid(B.first) || A.first == B.first || A.tip == A.first || B.tip == B.first ||
        !m.findEdge(A.first, B.first).isValid() || !closedObject(A.object))
      return false;
    if (A.chain.empty() || A.chain.back() != B.tip) return false;
    const Vec3 pa = m.position(A.tip), pb = m.position(B.tip);
    // Near the start after going round (a short slot's tip is near its start too).
    if ((m.position(A.first) - pa).norm() > p.matchRadius || (m.position(B.first) - pb).norm() > p.matchRadius ||
        std::min(A.pathLength, B.pathLength) < 4.0 * p.matchRadius)
      return false;
    if (dbg()) std::cerr << "joinStart tracks " << A.id << "," << B.id << "\n";
    auto walkTo = [&](Track& T, Vertex goalV, const Vec3& across, std::vector<Vertex>& path) {
      const Vertex start = T.tip;
      const Vec3 from = m.position(start), to = m.position(goalV);
      path.assign({start});
      const Vec3 n = sweepNormal(from, to, across, across);
      if (n.isZero()) return false;
      WalkGoal g;
      g.toVertex = true;
      g.vertex = goalV;
      const bool hadPending = T.hasPending;
      T.hasPending = false;
      const bool ok =
          static_cast<bool>(walk(T, g, n, (to - from).normalized(), 3.0 * (to - from).norm() + 2.0 * p.matchRadius,
                                 T.tipDepth, T.tipDepth, &path));
      T.tip = start;
      T.hasPending = hadPending;
      return ok && T.alive;
    };
    std::vector<Vertex> pathA, pathB;
    if (!walkTo(A, A.first, pb - pa, pathA) || !walkTo(B, B.first, pa - pb, pathB)) {
      if (dbg()) std::cerr << "joinStart: walk failed\n";
      return false;
    }
    // A.tip ... A.first, B.first ... B.tip, then the front back toward A.tip.
    std::vector<Vertex> loop = pathA;
    loop.push_back(A.first);
    loop.push_back(B.first);
    loop.insert(loop.end(), pathB.rbegin(), pathB.rend());
    for (auto it = A.chain.rbegin() + 1; it != A.chain.rend(); ++it) loop.push_back(*it);
    if (!closeLoop(A, loop, false)) return false;
    checkSeparation.push_back(A.object);
    end(A);
    end(B);
    return true;
  }

  // Both layers of a cut-through lost the blade in the same sample: if it left
  // through the side (moving on, not lifted), finish the cut around that side and
  // join the two layers (cut-out).
  void cutOut(Track& A, Track& B, const Vec3& motion) {
    if (joinStart(A, B)) return;
    bool done = false;
    const std::pair<bool, bool> hadPending{A.hasPending, B.hasPending};
    if (dbg()) {
      std::cerr << "cutOut tracks " << A.id << "," << B.id << " motion " << motion.transpose() << " tips " << A.tip
                << "," << B.tip << " chain";
      for (Vertex x : A.chain) std::cerr << " " << x;
      std::cerr << " Bchain";
      for (Vertex x : B.chain) std::cerr << " " << x;
      if (A.tip.isValid()) std::cerr << " pa " << meshOf(A.object).position(A.tip).transpose();
      if (B.tip.isValid()) std::cerr << " pb " << meshOf(A.object).position(B.tip).transpose();
      std::cerr << "\n";
    }
    // The pair's front may end at a wall apex next to B's tip (the layers opened out
    // of step, e.g. the tissue moved between samples): that edge closes the front.
    if (A.tip.isValid() && B.tip.isValid() && !A.chain.empty() && A.chain.back() != B.tip &&
        meshOf(A.object).findEdge(A.chain.back(), B.tip).isValid())
      A.chain.push_back(B.tip);
    if (A.tip.isValid() && B.tip.isValid() && motion.norm() > 1e-12 && !A.chain.empty() && A.chain.back() == B.tip) {
      SurfaceMesh& m = meshOf(A.object);
      const Vec3 pa = m.position(A.tip), pb = m.position(B.tip);
      const Vec3 n = sweepNormal(pa, pb, motion, motion);
      if (!n.isZero() && (pb - pa).cross(motion).norm() > 1e-6 * (pb - pa).norm() * motion.norm()) {
        WalkGoal g;
        g.toVertex = true;
        g.vertex = B.tip;
        // Traced first: where the curve reaches B's tip only round the object, nothing is
        // inserted, nor opened as the partial cut below (slab 1115, 1464, cylinder 4472).
        g.mustReach = true;
        const double maxLen = 3.0 * ((pb - pa).norm() + motion.norm()) + 2.0 * p.matchRadius;
        A.hasPending = B.hasPending = false;
        const Vertex start = A.tip;
        std::vector<Vertex> path{start};
        // The first step goes on with the motion (over the far edge) and toward B's tip:
        // a tilted blade may have taken A's tip over the edge and down the far side
        // already, where going on is square to the side and only B's tip tells which way.
        const Vec3 first = (motion.normalized() + (pb - pa).normalized()).normalized();
        // Tips joined by an edge of the surface (not the pair's rung: the front has more
        // than one edge), e.g. both layers met on the side face as it sprang back into
        // the blade: that edge is the path (the walk, which keeps off the cut's own
        // faces around the tip, would find no way to a tip this close).
        bool joined = false;
        if (const Edge eAB = m.findEdge(start, B.tip); eAB.isValid() && A.chain.size() >= 2) {
          const auto kindAB = kindsIn(m);
          joined = static_cast<bool>(kindAB);
          for (int k = 0; k < 2 && joined; ++k)
            if (const Face fk = m.face(eAB, k); !fk.isValid() || kindAB[fk] != kSurface) joined = false;
        }
        const WalkResult w = joined ? WalkResult{}
                                    : walk(A, g, n, first.allFinite() ? first : Vec3(motion.normalized()), maxLen,
                                           A.tipDepth, A.tipDepth, &path);
        const bool walked = static_cast<bool>(w);
        if (dbg()) std::cerr << "cutOut walk " << walkEndName(w.end) << " path " << path.size() << "\n";
        if (w.end == WalkEnd::Unreached) ++stats.cutOutsRefused;
        if (walked && A.alive) {
          A.tip = start;
          done = close(A, B, path);
        } else if (path.size() > 1 && !liftCutOut && !movedSincePrev && w.end != WalkEnd::TooLong) {
          // Went part of the way: open what was inserted as an ordinary cut (not where
          // the blade never was: a lifted hand's cut ends at its crossings; nor on moved
          // tissue, where a blade that met none at a glancing entry set off a walk along
          // the top face ahead of it: moving seeds 40651, 41234; nor a walk that ran over
          // its length, the wrong way: slab 1305 opened 11 edges 4 mm along the side).
          if (dbg()) std::cerr << "cutOut: opens the walk's " << path.size() - 1 << " edges as a cut\n";
          A.tip = start;
          for (std::size_t i = 1; i < path.size(); ++i) extend(A, path[i], A.tipDepth);
        }
      }
    }
    if (done) {
      checkSeparation.push_back(A.object);
      end(A);
      end(B);
      return;
    }
    // Both end here: A's last step keeps the pair (B's last step makes side walls too).
    // A lifted hand's cut ends at its crossings, as it would without the cut-out.
    if (liftCutOut) std::tie(A.hasPending, B.hasPending) = hadPending;
    terminate(A, Vec3::Zero(), Vec3::Zero(), false);
    terminate(B);
    end(A);
  }

  // The cut-out path (A's tip ... a neighbour of B's tip) and the front (A's tip,
  // chain ..., B's tip) form a closed loop: cut along all of it and close both sides.
  bool close(Track& A, Track& B, const std::vector<Vertex>& path) {
    std::vector<Vertex> loop = path;
    loop.push_back(B.tip);
    for (auto it = A.chain.rbegin() + 1; it != A.chain.rend(); ++it) loop.push_back(*it);
    // loop: A.tip -> path -> B.tip -> chain back toward A.tip (closing edge to A.tip).
    weldThinCap(A, B, loop);
    return closeLoop(A, loop, !wallCutOut);
  }

  // How far (in snapping distances) a loop vertex may be welded onto its neighbour, and
  // how far a face around it may turn doing so (any way short of a flip within the
  // snapping distance, as a snapped point would).
  static constexpr double kWeldReach = 5.0;
  // A cap under the floor (a quarter of the snapping distance) is worse than a slightly
  // longer weld: cylinder strips with the blade nearly tangent need 5.1-5.6.
  static constexpr double kWeldReachUnderFloor = 6.0;
  static constexpr double kWeldTurnCos = 0.995;  // ~5.7°

  // A cut-out loop too thin to cap without a sliver (no triangulation is, whatever
  // points are added): a cut-through leaving over a side face, the lower layer's path
  // vertex a hair off the rung (tip to tip) next to its end, or two path vertices a hair
  // apart on a near-straight stretch. Such a vertex is welded onto its neighbour on the
  // loop (SurfaceMesh::collapseEdge), the best first, while that thickens the cap and
  // moves no face of the surface much (a flat side face: none) nor makes one thin. The
  // tips and the rung's ends stay, unless the cap is under the floor (a quarter of the
  // snapping distance): then the rung's end on the chain may go, a weld leaving every
  // face around the vertex in its plane may be longer than the reach (a cylinder's side
  // facet with the blade nearly tangent), and a slit's two sides may go onto its end.
  void weldThinCap(Track& A, Track& B, std::vector<Vertex>& loop) {
    SurfaceMesh& m = meshOf(A.object);
    double q = loopQuality(m, loop);
    while (q < sliverHeight() && loop.size() > 3) {
      double bestQ = q;
      std::size_t bestI = 0, bestJ = 0;
      const double reach = (q < 0.25 * p.snapDistance ? kWeldReachUnderFloor : kWeldReach) * p.snapDistance;
      // Under the floor the rung's end on the chain may go too, onto the chain's next
      // vertex (the rung then ends there): B's tip a hair off the rung next to its end.
      const std::size_t last = q < 0.25 * p.snapDistance ? loop.size() : loop.size() - 1;
      for (std::size_t i = 1; i < last; ++i) {
        const Vertex x = loop[i];
        if (x == B.tip) continue;
        for (const std::size_t j : {i - 1, i + 1}) {
          if (j == loop.size()) continue;
          const Vertex y = loop[j];
          const bool inReach = (m.position(x) - m.position(y)).norm() <= reach ||
                               (q < 0.25 * p.snapDistance && weldStaysInPlane(m, x, y));
          if (!inReach || !weldKeepsSurface(m, x, y)) continue;
          std::vector<Vertex> rest = loop;
          rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
          if (const double qi = loopQuality(m, rest); qi > bestQ) {
            bestQ = qi;
            bestI = i;
            bestJ = j;
          }
        }
      }
      // An earlier cut's slit reaching into the cap (its two walls' crossings, one point,
      // either side of its end on the loop) is a spike no single weld thickens: under the
      // floor both sides may go onto the end at once.
      bool spike = false;
      if (q < 0.25 * p.snapDistance)
        for (std::size_t i = 2; i + 2 < loop.size(); ++i) {
          const Vertex t = loop[i], s0 = loop[i - 1], s1 = loop[i + 1];
          if (!((m.position(s0) - m.position(s1)).norm() <= 1e-9 * p.snapDistance) || s0 == B.tip || s1 == B.tip)
            continue;
          bool ok = true;
          for (const Vertex x : {s0, s1})
            ok = ok && ((m.position(x) - m.position(t)).norm() <= reach || weldStaysInPlane(m, x, t)) &&
                 weldKeepsSurface(m, x, t);
          if (!ok) continue;
          std::vector<Vertex> rest = loop;
          rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i + 1));
          rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i - 1));
          if (const double qi = loopQuality(m, rest); qi > bestQ) {
            bestQ = qi;
            bestI = i;
            spike = true;
          }
        }
      if (!(bestQ > q)) return;
      if (spike) {
        const Vertex t = loop[bestI];
        for (const std::size_t k : {bestI + 1, bestI - 1})
          if (!weldLoopVertex(A, B, loop, k, t)) return;
      } else if (!weldLoopVertex(A, B, loop, bestI, loop[bestJ])) {
        return;
      }
      if (dbg()) std::cerr << "weldThinCap cap " << q << " -> " << bestQ << (spike ? " (spike)" : "") << "\n";
      q = loopQuality(m, loop);
    }
  }

  // Welds loop[i] onto y (their edge collapsed, y kept) and drops it from the loop and
  // the tracks' chains. False (mesh unchanged) when the mesh refuses the collapse.
  bool weldLoopVertex(Track& A, Track& B, std::vector<Vertex>& loop, std::size_t i, Vertex y) {
    SurfaceMesh& m = meshOf(A.object);
    const Vertex x = loop[i];
    std::vector<Face> gone;
    for (Face f : m.faces(x))
      if (m.localIndex(f, y) >= 0) gone.push_back(f);
    const double len = (m.position(x) - m.position(y)).norm();
    if (!m.collapseEdge(m.findEdge(x, y), y).isValid()) return false;
    if (dbg()) std::cerr << "weldThinCap " << x << " onto " << y << " (" << len << " mm)\n";
    ++stats.capWelds;
    bvhs[static_cast<std::size_t>(indexOf(A.object))].removeFaces(m, gone);
    loop.erase(loop.begin() + static_cast<std::ptrdiff_t>(i));
    for (Track* t : {&A, &B}) std::erase(t->chain, x);
    std::vector<Vertex> ring{y};
    for (Edge e : m.edges(y)) ring.push_back(m.otherVertex(e, y));
    touchEach(A.object, ring);
    return true;
  }

  // Whether y lies in the plane of every face around x (a flat side face, or a crease
  // that y is on): moving x there changes no face's plane, however far.
  bool weldStaysInPlane(const SurfaceMesh& m, Vertex x, Vertex y) const {
    for (Face f : m.faces(x)) {
      const auto fv = m.vertices(f);
      const Vec3 n = (m.position(fv[1]) - m.position(fv[0])).cross(m.position(fv[2]) - m.position(fv[0]));
      if (!(std::abs(n.dot(m.position(y) - m.position(x))) <= 0.01 * p.snapDistance * n.norm())) return false;
    }
    return true;
  }

  // Whether moving x onto y (collapsing their edge) keeps every other face around x
  // turned by less than kWeldTurnCos (unflipped within the snapping distance) and no
  // thinner than it was or the sliver height.
  bool weldKeepsSurface(const SurfaceMesh& m, Vertex x, Vertex y) const {
    for (Face f : m.faces(x)) {
      if (m.localIndex(f, y) >= 0) continue;
      std::array<Vec3, 3> c{};
      std::array<Vec3, 3> after{};
      for (std::size_t k = 0; k < 3; ++k) {
        const Vertex v = m.vertices(f)[k];
        c[k] = m.position(v);
        after[k] = v == x ? m.position(y) : c[k];
      }
      const Vec3 n0 = (c[1] - c[0]).cross(c[2] - c[0]), n1 = (after[1] - after[0]).cross(after[2] - after[0]);
      const double turnCos = (m.position(x) - m.position(y)).norm() <= p.snapDistance ? 0.0 : kWeldTurnCos;
      if (!(n0.dot(n1) > turnCos * n0.norm() * n1.norm())) return false;
      if (!(height(after[0], after[1], after[2]) >= std::min(sliverHeight(), height(c[0], c[1], c[2])))) return false;
    }
    return true;
  }

  // Cuts along a closed loop of edges through both layers and closes both sides with
  // side walls. `mayOpenRung`: a loop without area may open the front's rung (cut-out).
  bool closeLoop(Track& A, const std::vector<Vertex>& loop, bool mayOpenRung) {
    SurfaceMesh& m = meshOf(A.object);
    std::vector<Edge> cuts;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Edge e = m.findEdge(loop[i], loop[(i + 1) % loop.size()]);
      if (!e.isValid()) {
        if (dbg())
          std::cerr << "close: no edge " << loop[i] << " - " << loop[(i + 1) % loop.size()] << " in a loop of "
                    << loop.size() << "\n";
        return false;
      }
      cuts.push_back(e);
    }
    {
      // Both sides get this loop's shape: refuse to make slivers.
      const double q = loopQuality(m, loop);
      if (dbg()) std::cerr << "close: loop of " << loop.size() << " quality " << q << "\n";
      // The caps are the cut's cross-section beyond the tips: near a rounded or moved
      // rim that is a thin crescent whatever the triangulation, and refusing it leaves
      // the piece attached. Only a degenerate loop is refused, unless the tips are on
      // the far side already (snapped onto its edge: the walk runs down the rung).
      if (wallCutOut && !(q >= sliverHeight())) return false;
      // A loop too thin to cap without a sliver (a crescent of a tip left just off the
      // far edge) tries the rung's opening first, when that makes thicker holes. A
      // cut-out the hand's lift asked for is optional (the cut can stay open): it makes
      // no sliver either way.
      const double floor = liftCutOut ? sliverHeight() : 1e-3 * p.snapDistance;
      if (!(q >= sliverHeight()) && mayOpenRung && openRung(A.object, loop, std::max(q, floor))) {
        cuts.pop_back();  // gone with its faces
      } else if (!(q > floor)) {
        return false;
      }
    }
    std::vector<Vertex> touched = loop;
    for (Vertex x : loop)
      for (Vertex nv : splitByGroups(A.object, x, cuts)) {
        mark(A, nv);
        touched.push_back(nv);
      }
    bool ok = true;
    for (std::size_t i = 0; i < touched.size(); ++i) {
      const Vertex x = touched[i];
      for (Edge e : mesh::EdgeList(m.edges(x))) {  // a copy: the fills edit x's edges
        if (!m.isValid(e) || !m.isBoundary(e)) continue;
        const auto lp = boundaryLoop(m, e, 400);
        ok = lp.size() >= 3 && fillLoop(A.object, lp, kSideWall) && ok;
      }
    }
    if (!ok) ++stats.fillFailures;
    if (sliverTrace())
      for (Vertex x : touched) traceThin(A.object, {x}, "close");
    for (Vertex x : touched) touch(A.object, {x});
    for (Vertex x : touched) unpinch(A.object, x);
    return true;
  }

  // The cut-out loop (front rung loop.back() - loop.front(), and a walk along it) has no
  // area: the two wall triangles on the rung go, so that each side's hole reaches from
  // their far corner to the walk. False (mesh unchanged) when a hole is no thicker than
  // `than` (its best triangulation's smallest height).
  bool openRung(int obj, const std::vector<Vertex>& loop, double than) {
    SurfaceMesh& m = meshOf(obj);
    const Edge rung = m.findEdge(loop.back(), loop.front());
    if (!rung.isValid() || m.isBoundary(rung)) return false;
    const std::array<Face, 2> walls{m.face(rung, 0), m.face(rung, 1)};
    for (Face f : walls) {
      std::vector<Vertex> hole{m.oppositeVertex(f, rung)};
      if (std::find(loop.begin(), loop.end(), hole[0]) != loop.end()) {
        if (dbg()) std::cerr << "openRung: far corner on the loop\n";
        return false;
      }
      hole.insert(hole.end(), loop.begin(), loop.end());
      if (dbg()) {
        std::cerr << "openRung: hole quality " << loopQuality(m, hole) << " kind "
                  << m.getFaceProperty<int>(kFaceKindProp)[f] << ":";
        for (Vertex x : hole) std::cerr << " " << x << "(" << m.position(x).transpose() << ")";
        std::cerr << "\n";
      }
      if (!(loopQuality(m, hole) > than)) return false;
    }
    for (Face f : walls) m.deleteFace(f);
    bvhs[static_cast<std::size_t>(indexOf(obj))].removeFaces(m, walls);
    return true;
  }

  // Vertices of the boundary loop through boundary edge e (empty if longer than maxLen).
  static std::vector<Vertex> boundaryLoop(const SurfaceMesh& m, Edge e, std::size_t maxLen) {
    std::vector<Vertex> loop;
    const Vertex start = m.vertex(e, 0);
    Vertex cur = m.vertex(e, 1);
    Edge curE = e;
    loop.push_back(start);
    while (cur != start) {
      loop.push_back(cur);
      if (loop.size() > maxLen) return {};
      Edge next;
      for (Edge g : m.edges(cur))
        if (g != curE && m.isBoundary(g)) {
          next = g;
          break;
        }
      if (!next.isValid()) return {};
      curE = next;
      cur = m.otherVertex(next, cur);
    }
    return loop;
  }

  // The crossing behind P (against `back`'s opposite) where the plane leaves face f:
  // the edge the blade came in through on a slide-in.
  Vertex entryVertex(int obj, Face f, const Vec3& P, const Vec3& n, const Vec3& back, bool boundaryOnly = false) {
    SurfaceMesh& m = meshOf(obj);
    const auto fv = m.vertices(f);
    const auto fe = m.edges(f);
    double s[3];
    for (int i = 0; i < 3; ++i) s[i] = n.dot(m.position(fv[static_cast<std::size_t>(i)]) - P);
    const double eps = 1e-10 * scaleOf(P);
    int bestE = -1;
    Vec3 bestQ = P;
    double bestScore = 0.0;
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3;
      const Vec3& a = m.position(fv[static_cast<std::size_t>(i)]);
      const Vec3& b = m.position(fv[static_cast<std::size_t>(j)]);
      Vec3 q;
      if (std::abs(s[i]) <= eps)
        q = a;
      else if (std::abs(s[j]) <= eps)
        q = b;
      else if ((s[i] > 0) != (s[j] > 0))
        q = a + (b - a) * (s[i] / (s[i] - s[j]));
      else
        continue;
      const double score = (q - P).dot(back);
      if (score > bestScore) {
        bestScore = score;
        bestE = i;
        bestQ = q;
      }
    }
    if (bestE < 0) return boundaryOnly ? Vertex() : insertPoint(obj, f, P);
    const Edge e = fe[static_cast<std::size_t>(bestE)];
    if (boundaryOnly && !m.isBoundary(e)) {
      // On a closed object: only a feature edge (faces meeting at more than 45°).
      const Face g = m.otherFace(e, f);
      if (!g.isValid() || rawNormal(m, f).normalized().dot(rawNormal(m, g).normalized()) > 0.7) return Vertex();
    }
    return pointOnEdge(obj, e, bestQ);
  }

  // On a sheet: the rim (its outer edge or an earlier cut's slit) behind P, where the
  // plane through P (normal n) leaves the surface going `back` from face f, within
  // maxLen. A blade that crossed a slit in one sample came in over that slit's far lip,
  // not over f's own edges (entryVertex): the cut starts there, next to the lip the
  // track before it reached.
  bool rimBehind(const SurfaceMesh& m, Face f, const Vec3& P, const Vec3& n, const Vec3& back, double maxLen, Edge& rim,
                 Vec3& at, Vertex& corner) const {
    const PlaneCut pc{m, n, P};
    const double eps = 1e-10 * scaleOf(P);
    corner = Vertex();
    if (!(maxLen >= 0.0)) return false;  // (NaN as well)
    // The plane through a corner of the rim (a slit's vertex the walk before it reached,
    // or its copy), the curve at q in face g: start there.
    auto atCorner = [&](Face g, const Vec3& q, double len) {
      for (Vertex c : m.vertices(g))
        if (std::abs(pc.side(c)) <= eps && m.isBoundary(c) && (m.position(c) - q).dot(back) > 0.0 &&
            len + (m.position(c) - q).norm() <= maxLen) {
          corner = c;
          return true;
        }
      return false;
    };
    Edge exit;  // where the curve leaves f going back from P
    Vec3 x = P;
    double bestScore = 0.0;
    for (Edge e : m.edges(f)) {
      const double sa = pc.side(m.vertex(e, 0)), sb = pc.side(m.vertex(e, 1));
      if (std::abs(sa) <= eps || std::abs(sb) <= eps || (sa > 0) == (sb > 0)) continue;  // a corner on it: below
      const Vec3 c = pc.cross(m.vertex(e, 0), m.vertex(e, 1));
      const double score = (c - P).dot(back);
      if (score > bestScore) {
        bestScore = score;
        exit = e;
        x = c;
      }
    }
    if (!exit.isValid()) return atCorner(f, P, 0.0);
    // On over at most 63 faces (64 crossings), to the rim.
    return traceCurve(
        pc, f, exit, x, (x - P).norm(), 63, false,
        [&](Edge e, const Vec3& q, double len) -> std::optional<bool> {
          if (len > maxLen) return false;
          if (!m.isBoundary(e)) return std::nullopt;
          rim = e;
          at = q;
          return true;
        },
        [&](Face g, Vertex c, const Vec3& q, double len) -> std::optional<bool> {
          if (std::abs(pc.side(c)) <= eps) return atCorner(g, q, len);  // the curve's way out is a corner
          return std::nullopt;
        });
  }

  // The blade's edge at the last sample (prev) went in and out of the object next to
  // where it now crosses it (h1 in, h0 out; within the radius a track would have
  // matched them): it was through both layers already, not outside them. Not on tissue
  // that moved since the hand's last sample (tissueMoved; prev is then an earlier
  // substep) when those crossings were a clip (`clipsBulge`), which started nothing to
  // wait for crossings that have parted: the radius is wider than a slab, the in and
  // out of a bulge clipped at the top matched both, and the slide-in over that side
  // started as a pierce 0.3 mm inside it, the piece attached by that strip (moving seed
  // 40222). (On still tissue as well it changed 40 of the random and deepening strokes
  // at LD_PROPERTY_SCALE=10, walk failures 170 -> 171 and 47 -> 48.)
  bool throughAtLast(const Hit& h0, const Hit& h1, const instruments::Segment& prev, const Vec3& motion,
                     bool tissueMoved) {
    const std::size_t oi = static_cast<std::size_t>(indexOf(h0.object));
    const double r = p.matchRadius + 2.0 * motion.norm();
    const collision::SurfaceHit* in = nullptr;  // the last entering crossing
    for (const auto& x : crossings(oi, prev.a, prev.b)) {
      if (x.kind == collision::HitKind::Coplanar || x.direction == 0) continue;
      if (x.direction > 0) {
        in = &x;
      } else if (in && (in->point - h1.point).norm() <= r && (x.point - h0.point).norm() <= r &&
                 !(tissueMoved && clipsBulge(oi, in->point, in->face, x.point, x.face, false))) {
        return true;
      } else {
        in = nullptr;
      }
    }
    return false;
  }

  // Two new crossings with material between them (a slide-in through both layers):
  // cut from the lower crossing back around the edge the blade came in over, to the
  // upper crossing, and pair the two tracks.
  void startPair(HandState& hs, const Hit& h0, const Hit& h1, const Vec3& motionIn, const Vec3& bladeDir,
                 const Vec3& upDir, const instruments::Segment* prev = nullptr, bool tissueMoved = false) {
    if (dbg()) std::cerr << "startPair at " << h0.point.transpose() << " / " << h1.point.transpose() << "\n";
    const Vec3 motion = motionIn;
    if (motion.norm() < 1e-9 || (prev && throughAtLast(h0, h1, *prev, motion, tissueMoved))) {
      // The blade appeared inside (first sample), or was already through both layers
      // there at the last sample, the tissue still since (its cuts had ended: a hook's
      // pedal): it came in over no edge, it pierces. (The walk round from an edge
      // behind it went round the object, too long, and left its splits on the way. On
      // moving tissue the last sample's blade may be inside the moved tissue after a
      // true slide-in: not tested there.)
      if (dbg() && motion.norm() >= 1e-9) std::cerr << "startPair: through both layers at the last sample\n";
      startTunnel(hs, h0, h1);
      return;
    }
    (void)upDir;
    Track A = newTrack(h0), B = newTrack(h1);
    A.hasStart = B.hasStart = false;
    SurfaceMesh& m = meshOf(h0.object);
    const Face fb = locate(m, h1.face, h1.point);
    const Vec3 n = sweepNormal(h1.point, h1.point + motion, bladeDir, motion);
    bool ok = fb.isValid() && !n.isZero();
    if (ok) {
      const Vertex sB = entryVertex(h1.object, fb, h1.point, n, -motion);
      ++stats.trianglesCut;
      ++res->trianglesCut;
      B.tip = sB;
      B.visited.insert(sB);
      A.tip = sB;
      A.visited.insert(sB);
      A.partner = B.id;
      B.partner = A.id;
      hs.tracks.push_back(A);
      hs.tracks.push_back(B);
      Track& a = hs.tracks[hs.tracks.size() - 2];
      Track& b = hs.tracks.back();
      const Vec3 from = meshOf(a.object).position(sB);
      const Vec3 n2 = sweepNormal(from, h0.point, motion, n);
      WalkGoal g;
      g.point = h0.point;
      // Where the blade came in over no edge behind it (its point came out of a side ahead
      // of a groove, the blade moving toward that side: slab 1051, cube 2451), the way
      // back goes round the object and is too long; it left its splits on the way.
      // Traced first, such a start edits nothing there and is a pierce.
      g.mustReach = true;
      std::vector<Vertex> path;
      // The first step goes back against the motion (around the edge the blade came
      // over) and toward the other crossing: when the blade is tilted back, the lower
      // crossing is on the side face the blade came through, where going back is
      // square to the face and only the other crossing tells up from down.
      Vec3 first = -motion.normalized();
      if ((h0.point - from).norm() > 1e-12) first += (h0.point - from).normalized();
      if (first.norm() < 1e-9) first = -motion;
      const WalkResult w = n2.isZero() ? WalkResult{WalkEnd::NoWay, Edge()}
                                       : walk(a, g, n2, first.normalized(),
                                              3.0 * ((h0.point - from).norm() + motion.norm()) + 2.0 * p.matchRadius,
                                              h0.depth, h0.depth, &path);
      a.pending = h0.point;
      a.pendingDepth = h0.depth;
      a.hasPending = true;
      b.pending = h1.point;
      b.pendingDepth = h1.depth;
      b.hasPending = true;
      if (w) {
        // The cut-in path sB -> ... -> a.tip stays closed for now: it is the front
        // between the layers and opens with the first step of either layer (its walls
        // then have the blade's motion as width, not zero).
        if (!path.empty()) {
          a.chain.assign(path.rbegin() + 1, path.rend());
          a.chain.push_back(sB);
          b.chain.assign(path.begin(), path.end());
          stats.longestFront = std::max(stats.longestFront, static_cast<long>(a.chain.size()) + 1);
        }
        a.visited.forEach([&](Vertex x) { b.visited.insert(x); });
        return;
      }
      if (w.end == WalkEnd::Unreached)
        ++stats.pairsPierced;
      else
        countWalkFailure(w.end);
      // Could not join the layers around the edge (e.g. a side the tissue's motion made
      // wavy): the path found is not the cut's (opening along it made long wrong cuts),
      // so nothing opens there; the two crossings go on as a pierce through both layers.
      a.alive = b.alive = false;
      startTunnel(hs, h0, h1);
      return;
    }
    // No edge the blade came in over (e.g. it went in along itself): a pierce.
    startTunnel(hs, h0, h1);
  }

  // Material thinner than this between two crossings of one edge is a fold of the
  // surface the blade grazes (a cut's lip curled by the tissue's motion), not two layers
  // to join with side walls.
  double foldThickness() const { return 10.0 * p.snapDistance; }

  // In at `in`, out at `out` within half the fold thickness, through faces facing the
  // same side (normals under 90° apart): the blade clips a bulge of one side (a side face
  // the tissue's motion bowed out), not two layers. Its crossings there slide fast along
  // the surface as it goes on, so a pair started on them can lose its lower track at once
  // while the upper one cuts on as a groove. Nothing starts until the blade is in deeper
  // and the crossings have parted or face away from each other. (The whole fold
  // thickness held back pairs that would have worked: the moving-tissue test's first 32
  // strokes freed 28 instead of 30.) On tissue that moved since the last sample, any
  // pair within two snapping distances is a clip too, whichever way its faces face: a
  // fold of the side the blade has just cut out over was otherwise cut out as a chunk of
  // its own. (On still tissue as well, it cost the still runs 2 of 32 and 20 of 320
  // freed pieces; not traced, likely slide-ins whose first contact is at an edge.)
  bool clipsBulge(const Hit& in, const Hit& out, bool still) const {
    return clipsBulge(static_cast<std::size_t>(indexOf(in.object)), in.point, in.face, out.point, out.face, still);
  }
  bool clipsBulge(std::size_t oi, const Vec3& in, Face inFace, const Vec3& out, Face outFace, bool still) const {
    const double d = (out - in).norm();
    if (!(d < 0.5 * foldThickness())) return false;
    if (!still && d < 2.0 * p.snapDistance) return true;
    const SurfaceMesh& m = objects[oi].mesh;
    return m.faceNormal(inFace).dot(m.faceNormal(outFace)) > 0.0;
  }

  // Two layers pierced in the middle of the object: each gets its own track; they
  // are paired and join through a tunnel once both paths can open.
  void startTunnel(HandState& hs, const Hit& h0, const Hit& h1) {
    if (dbg()) std::cerr << "startTunnel at " << h0.point.transpose() << " / " << h1.point.transpose() << "\n";
    if ((h0.point - h1.point).norm() < 2.0 * p.snapDistance) {
      // Grazing a fold (no material between the crossings to speak of).
      startSingle(hs, h0);
      startSingle(hs, h1);
      return;
    }
    Track A = newTrack(h0), B = newTrack(h1);
    A.partner = B.id;
    B.partner = A.id;
    A.tunnel = B.tunnel = true;
    hs.tracks.push_back(std::move(A));
    hs.tracks.push_back(std::move(B));
  }

  // A groove (track t) whose blade now also crosses the layer below (new hit h): the
  // cut turns into a cut-through from here on.
  // endFrom -> endTo: the blade's end that went through since the last sample; the
  // cut on the new layer starts where it did (the same at any sampling rate).
  void deepen(HandState& hs, std::size_t ti, const Hit& h, const Vec3* endFrom, const Vec3* endTo) {
    if (dbg()) std::cerr << "deepen track " << hs.tracks[ti].id << " through " << h.point.transpose() << "\n";
    Track B = newTrack(h);
    if (endFrom && endTo) {
      const std::size_t oi = static_cast<std::size_t>(indexOf(h.object));
      if (const auto* x = nearestCrossing(oi, *endFrom, *endTo, h.point)) {
        B.start = x->point;
        B.startFace = x->face;
      }
    }
    B.partner = hs.tracks[ti].id;
    B.tunnel = true;
    hs.tracks[ti].partner = B.id;
    hs.tracks[ti].tunnel = true;
    B.visited = hs.tracks[ti].visited;
    hs.tracks.push_back(std::move(B));
  }

  Track newTrack(const Hit& h) {
    Track t;
    t.id = nextTrackId++;
    t.object = h.object;
    t.segment = h.segment;
    t.dir = h.dir;
    t.hasStart = true;
    t.start = h.point;
    t.startDepth = h.depth;
    t.startFace = h.face;
    if (const auto* slit = std::get_if<Hit::PastSlit>(&h.restart)) t.startPastSlit = *slit;
    t.tipDepth = h.depth;
    t.pending = h.point;
    t.pendingDepth = h.depth;
    t.hasPending = true;
    ++stats.tracks;
    return t;
  }

  void startSingle(HandState& hs, const Hit& h) {
    if (dbg()) std::cerr << "startSingle at " << h.point.transpose() << " dir " << h.dir << "\n";
    hs.tracks.push_back(newTrack(h));
  }

  // ---- one stroke's own cut, and the guards against a runaway ---------------------------------
  StrokeOnObject& strokeOn(HandState& hs, int obj) {
    for (auto& so : hs.stroke)
      if (so.object == obj) return so;
    StrokeOnObject so;
    so.object = obj;
    so.facesAtStart = static_cast<long>(meshOf(obj).nFaces());
    hs.stroke.push_back(std::move(so));
    return hs.stroke.back();
  }
  // Ended tracks leave the hand; what they cut stays part of the stroke's cut.
  void retireTracks(HandState& hs) {
    for (auto& t : hs.tracks)
      if (!t.alive) {
        StrokeOnObject& so = strokeOn(hs, t.object);
        t.visited.forEach([&](Vertex x) { so.cut.insert(x); });
      }
    std::erase_if(hs.tracks, [](const Track& t) { return !t.alive; });
  }

  int kindOf(const Hit& h) const {
    const int k = indexOf(h.object);
    if (k < 0) return kSurface;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(k)].mesh;
    const auto kind = kindsIn(m);
    return kind && m.isValid(h.face) ? kind[h.face] : kSurface;
  }
  // A crossing on a lip or wall of the cut this stroke has made: its face has a corner
  // on that cut which no track of the hand goes on from (not a tip). That is the cut's
  // own edge, which the moving tissue has curled into the blade's way (a fold), not new
  // tissue: it opens no track. (The 0.5 mm fold rule only kept two such crossings side
  // by side from pairing; each still started a groove in the lip, and with crossings
  // matched along their way and slid groove bottoms that ran away: ~850 tracks in 25 s
  // on slab-straight-line with physics.)
  bool onStrokeLip(const HandState& hs, const Hit& h) const {
    const int k = indexOf(h.object);
    if (k < 0) return false;
    const SurfaceMesh& m = objects[static_cast<std::size_t>(k)].mesh;
    if (!m.isValid(h.face)) return false;
    const StrokeOnObject* so = nullptr;
    for (const auto& x : hs.stroke)
      if (x.object == h.object) so = &x;
    for (Vertex c : m.vertices(h.face)) {
      bool cut = so && so->cut.count(c), tip = false;
      for (const Track& t : hs.tracks) {
        if (t.object != h.object) continue;
        if (t.tip == c) tip = true;
        cut = cut || t.visited.count(c);
      }
      if (cut && !tip) return true;
    }
    return false;
  }

  // May n new tracks of this cutting edge start on obj in this sample? Not past
  // CutParams::maxNewTracksPerSample (the default, four, is two pairs: an edge through
  // both layers of a slab and of a piece folded over it; more is a crumpled surface),
  // nor on an object the stroke has grown past its budget. CutStats::tracksRefused.
  struct NewTracks {
    int object, segment, count;
  };
  std::vector<NewTracks> newTracksBuf;  // tracks started in this sample
  bool mayStart(HandState& hs, int obj, int segment, int n) {
    StrokeOnObject& so = strokeOn(hs, obj);
    auto it = std::find_if(newTracksBuf.begin(), newTracksBuf.end(),
                           [&](const NewTracks& x) { return x.object == obj && x.segment == segment; });
    if (it == newTracksBuf.end()) it = newTracksBuf.insert(newTracksBuf.end(), {obj, segment, 0});
    if (so.capped || it->count + n > p.maxNewTracksPerSample) {
      if (dbg()) std::cerr << "refused " << n << " new track(s) on object " << obj << "\n";
      stats.tracksRefused += n;
      return false;
    }
    it->count += n;
    return true;
  }

  // A stroke that has grown an object past its budget ends its cuts there.
  void capStrokeGrowth(HandState& hs) {
    for (auto& so : hs.stroke) {
      const int k = indexOf(so.object);
      if (so.capped || k < 0) continue;
      const long grown = static_cast<long>(objects[static_cast<std::size_t>(k)].mesh.nFaces()) - so.facesAtStart;
      const double budget =
          std::max(static_cast<double>(p.strokeFacesMin), p.strokeFacesFactor * static_cast<double>(so.facesAtStart));
      if (static_cast<double>(grown) <= budget) continue;
      if (dbg()) std::cerr << "stroke capped on object " << so.object << " after " << grown << " new faces\n";
      so.capped = true;
      ++stats.strokeCaps;
      for (auto& t : hs.tracks)
        if (t.alive && t.object == so.object) terminate(t);
    }
  }

  // A separation ended the cuts on obj (endTracksOn) and may have compacted its mesh (new
  // vertex handles): the strokes forget their cut there, so the blade may start again
  // next to where the engine, not the tissue, stopped it.
  void forgetStrokeCuts(int obj) {
    for (auto& hs : hands) {
      for (auto& so : hs.stroke)
        if (so.object == obj) so.cut = VertexSet();
      for (auto& t : hs.tracks)
        if (t.object == obj && !t.alive) t.visited = VertexSet();
    }
  }

  // ---- separation -----------------------------------------------------------------------------
  // Ends every open cut on obj where it is, its pending step dropped: terminating it
  // (a face split and an extension) here, on a piece about to come free, once left an
  // edge with four faces (property seed slab 1274, a flat piece with no volume).
  void endTracksOn(int obj) {
    for (auto& hs : hands)
      for (auto& t : hs.tracks)
        if (t.alive && t.object == obj) end(t);
  }

  // Where an object's mesh journal stood when the object was last known to be one
  // component: its components since are found from the edits after that point
  // (SurfaceMesh::splitComponents), in proportion to the pieces that come off, not to
  // the mesh. layout 0: not known (a new object), the full labelling once.
  struct Connected {
    std::uint64_t layout = 0;
    std::size_t journalFaces = 0, journalEdges = 0, facesSize = 0;
  };
  std::vector<Connected> connected;
  mesh::ComponentScratch componentScratch;
  std::vector<Face> seeds;
  // A kept mesh is compacted (and its tree remapped) only once its dead faces
  // outnumber half its live ones: O(1) per removed face, not O(mesh) per separation.
  static constexpr double kCompactDeadShare = 0.5;

  void markConnected(std::size_t k) {
    const SurfaceMesh& m = objects[k].mesh;
    connected[k] = {m.layoutVersion(), m.editedFaces().size(), m.editedEdges().size(), m.facesSize()};
  }

  mesh::SplitComponents componentsOf(std::size_t k) {
    const SurfaceMesh& m = objects[k].mesh;
    const Connected& c = connected[k];
    if (c.layout != m.layoutVersion() || c.journalFaces > m.editedFaces().size() ||
        c.journalEdges > m.editedEdges().size())
      return m.splitComponents();
    // Every component holds an edited face or a face of an edited edge: a component
    // without one has the neighbours it had when the mesh was one piece, so it is
    // all the old faces (then one of them is a seed too, below).
    seeds.clear();
    bool oldFace = false;
    for (Face f : m.editedFaces().subspan(c.journalFaces))
      if (m.isValid(f)) seeds.push_back(f);
    for (Edge e : m.editedEdges().subspan(c.journalEdges))
      if (m.isValid(e))
        for (int i = 0; i < 2; ++i)
          if (const Face f = m.face(e, i); f.isValid()) seeds.push_back(f);
    for (Face f : seeds) oldFace = oldFace || f.idx() < c.facesSize;
    if (!oldFace)
      for (Face f : m.faces()) {
        seeds.push_back(f);  // the first live face (old, since nothing old was touched)
        break;
      }
    return m.splitComponents(seeds, componentScratch);
  }

  void separate(int obj) {
    IntervalTimer timer{separationSeconds};
    const int idx = indexOf(obj);
    if (idx < 0) return;
    const std::size_t k = static_cast<std::size_t>(idx);
    mesh::SplitComponents c = componentsOf(k);
    if (c.count <= 1) {
      markConnected(k);
      return;
    }
    // Handles change below: every open cut on this object ends first.
    const std::size_t journalF = objects[k].mesh.editedFaces().size();
    const std::size_t journalE = objects[k].mesh.editedEdges().size();
    endTracksOn(obj);
    fixPinches();
    const SurfaceMesh& m = objects[k].mesh;
    if (m.editedFaces().size() != journalF || m.editedEdges().size() != journalE) c = componentsOf(k);
    if (c.count > 1) {
      for (const auto& faces : c.pieces) {
        TissueObject piece;
        piece.id = nextId++;
        piece.parent = obj;
        piece.closedAtStart = objects[k].closedAtStart;
        piece.mesh = objects[k].mesh.extract(faces);
        const bool t = hasTissue[k];
        objects.push_back(std::move(piece));
        hasTissue.push_back(t);
        bvhs.emplace_back(objects.back().mesh);
        if (p.collisionMargin > 0.0) bvhs.back().setMotionMargin(objects.back().mesh, p.collisionMargin);
        moved.push_back(0);
        moveBound.push_back(0.0);
        movedList.emplace_back();
        connected.emplace_back();
        markConnected(objects.size() - 1);
        res->separated.push_back(objects.back().id);
        ++stats.separations;
      }
      removePieces(k, c.pieces);
      forgetStrokeCuts(obj);
    }
    markConnected(k);
  }

  // The freed pieces leave the kept mesh (their faces, and their vertices left
  // without a face); its tree follows locally.
  void removePieces(std::size_t k, const std::vector<std::vector<Face>>& pieces) {
    SurfaceMesh& m = objects[k].mesh;
    syncBvh(k);
    for (const auto& faces : pieces) {
      for (Face f : faces) m.deleteFace(f);
      bvhs[k].releaseFaces(m, faces);
    }
    for (const auto& faces : pieces)
      for (Face f : faces)
        for (Vertex v : m.vertices(f))  // a deleted face keeps its corners
          if (m.isValid(v) && m.isIsolated(v)) m.deleteVertex(v);
    syncBvh(k);
    const double dead = static_cast<double>(m.facesSize() - m.nFaces());
    if (dead > kCompactDeadShare * static_cast<double>(m.nFaces())) {
      const mesh::Compaction cm = m.garbageCollection();
      roomToCut(k);
      bvhs[k].remap(m, cm);
    }
  }

  // ---- samples ------------------------------------------------------------------------------------
  double separationSeconds = 0.0;  // time splitting off freed pieces during the current call

  // Every crossing of segment a-b with object oi's surface (its tree synced first), in
  // scratchHits, ordered along the segment.
  const std::vector<collision::SurfaceHit>& crossings(std::size_t oi, const Vec3& a, const Vec3& b) {
    syncBvh(oi);
    bvhs[oi].intersectSegment(objects[oi].mesh, a, b, scratchHits);
    return scratchHits;
  }

  // The crossing of a-b with object oi nearest to `near`, if one lies within the
  // matching radius (coplanar contacts do not count).
  const collision::SurfaceHit* nearestCrossing(std::size_t oi, const Vec3& a, const Vec3& b, const Vec3& near) {
    const collision::SurfaceHit* best = nullptr;
    double bestDistance = p.matchRadius;
    for (const auto& x : crossings(oi, a, b))
      if (x.kind != collision::HitKind::Coplanar && (x.point - near).norm() < bestDistance) {
        bestDistance = (x.point - near).norm();
        best = &x;
      }
    return best;
  }

  void syncBvh(std::size_t i) {
    const SurfaceMesh& m = objects[i].mesh;
    collision::TriangleBvh& b = bvhs[i];
    if (b.sync(m) != collision::SyncResult::Rebuilt) {
      // A pass over every vertex with no bound on the moves covers the listed ones.
      const bool coversAll = moved[i] && (b.motionMargin() <= 0.0 || !std::isfinite(moveBound[i]));
      if (moved[i] && b.motionMargin() > 0.0) {
        const std::size_t passes = b.motionPasses();
        stats.verticesReanchored += static_cast<long>(travelling ? b.refitTravelled(m, travel, travelPast, groupSize)
                                                                 : b.refitMoved(m, moveBound[i]));
        stats.marginPasses += static_cast<long>(b.motionPasses() - passes);
        ++stats.marginRefits;
      } else if (moved[i]) {
        b.refit(m);
        ++stats.fullRefits;
      }
      // After the travelled refit (it takes the groups past the limit first). Listed
      // moves are not in the physics' bound or sums (a region step, settled vertices).
      if (!coversAll && !movedList[i].empty()) {
        stats.verticesReanchored += static_cast<long>(b.refitListed(m, std::span<const std::uint32_t>(movedList[i])));
        ++stats.regionRefits;
        stats.verticesRefitted += static_cast<long>(movedList[i].size());
      }
      // (A full refit covers them; fat boxes do not when the physics' bound skipped the pass.)
      if ((!moved[i] || b.motionMargin() > 0.0) && !slidPending.empty()) {
        // Groove-bottom vertices the cutter moved (slideBottom) since the last sync.
        slidScratch.clear();
        for (const auto& [id, x] : slidPending)
          if (id == objects[i].id && m.isValid(x)) slidScratch.push_back(x);
        if (!slidScratch.empty()) b.refitVertices(m, std::span<const Vertex>(slidScratch));
      }
    }
    std::erase_if(slidPending, [&](const auto& e) { return e.first == objects[i].id; });
    moved[i] = 0;
    moveBound[i] = 0.0;
    movedList[i].clear();
  }
  // verticesTravelled's groups, for the syncBvh it calls.
  bool travelling = false;
  std::span<double> travel;
  std::span<const std::uint32_t> travelPast;
  std::size_t groupSize = 0;
  std::vector<std::pair<int, Vertex>> slidPending;  // (object id, vertex) moved by slideBottom
  std::vector<Vertex> slidScratch;

  // Physics moved these vertices (told by verticesMoved): kept until the next query.
  void noteMoved(std::size_t i, std::span<const std::uint32_t> list) {
    if (moved[i] && !std::isfinite(moveBound[i])) return;  // the pass looks at every vertex
    const SurfaceMesh& m = objects[i].mesh;
    for (std::uint32_t v : list)
      if (v >= m.verticesSize()) throw CutError("verticesMoved: vertex index " + std::to_string(v) + " out of range");
    auto& l = movedList[i];
    const std::size_t nv = m.verticesSize();
    // Most of the mesh: one full refit is cheaper. (A list that long on its own needs
    // no sort to say so: the tissue's first steps, all awake, were 7 % of a 100k run.)
    bool most = 2 * list.size() > nv;
    if (!most) {
      l.insert(l.end(), list.begin(), list.end());
      if (2 * l.size() > nv) {  // several steps' lists: each vertex once
        std::sort(l.begin(), l.end());
        l.erase(std::unique(l.begin(), l.end()), l.end());
        most = 2 * l.size() > nv;
      }
    }
    if (most) {
      moved[i] = 1;
      moveBound[i] = std::numeric_limits<double>::infinity();
      l.clear();
    }
  }

  // Appends the crossings of segment a-b with every object to `out`.
  void hitsOf(const Vec3& a, const Vec3& b, int segment, std::vector<Hit>& out) {
    for (std::size_t oi = 0; oi < objects.size(); ++oi) {
      const auto& o = objects[oi];
      const std::size_t first = out.size();
      for (const auto& h : crossings(oi, a, b)) {
        if (h.kind == collision::HitKind::Coplanar || h.direction == 0) continue;
        Hit& x = out.emplace_back();
        x.object = o.id;
        x.segment = segment;
        x.face = h.face;
        x.point = h.point;
        x.t = h.t;
        x.dir = h.direction;
      }
      // Depth: the blade's end on the material side, or halfway to the next crossing.
      for (std::size_t i = first; i < out.size(); ++i) {
        Hit& x = out[i];
        if (x.dir > 0) {
          x.depth = (i + 1 < out.size()) ? Vec3(0.5 * (x.point + out[i + 1].point)) : b;
        } else {
          x.depth = (i > first) ? Vec3(0.5 * (x.point + out[i - 1].point)) : a;
        }
      }
    }
  }

  // Per-sample work lists, kept between samples (no allocation once warm).
  // Where the track's crossing has gone if the surface around it is flat: the new
  // edge meets the plane of the face holding the last point there. A blade nearly
  // parallel to that face (a tilted blade on an object's side face) moves its crossing
  // many times as fast as itself (1 / sin of the angle); tracks are matched along the
  // way from the last point to there (at most `reach` beyond the usual radius).
  Vec3 crossingAhead(const Track& t, const Vec3& at, const instruments::Segment& s, double radius) {
    const SurfaceMesh& m = meshOf(t.object);
    Face f = t.tip.isValid() ? t.pendingFace : t.startFace;
    if (t.tip.isValid() && (!m.isValid(f) || m.localIndex(f, t.tip) < 0 || !pointInFace(m, f, at, 1e-6))) {
      f = Face();
      for (Face g : m.faces(t.tip))
        if (pointInFace(m, g, at, 1e-6)) {
          f = g;
          break;
        }
    }
    if (!m.isValid(f)) return at;
    return meetsPlane(rawNormal(m, f), at, s, radius);
  }
  // The other way round: where the previous edge met the plane of the face holding a
  // new crossing (a track's crossing that went over an edge of the object onto a face
  // the blade is nearly parallel to runs on along it, up to `reach` beyond the radius).
  Vec3 crossingBehind(const Hit& h, const instruments::Segment& prev, double radius) {
    const SurfaceMesh& m = meshOf(h.object);
    if (!m.isValid(h.face)) return h.point;
    return meetsPlane(rawNormal(m, h.face), h.point, prev, radius);
  }
  // Where segment s meets the plane with normal nf through `at` (clamped to s), at most
  // 8 × radius from `at`; `at` itself when s runs along the plane.
  static Vec3 meetsPlane(const Vec3& nf, const Vec3& at, const instruments::Segment& s, double radius) {
    const Vec3 ab = s.b - s.a;
    const double den = nf.dot(ab);
    if (!(std::abs(den) > 1e-12 * nf.norm() * ab.norm())) return at;
    const double u = std::clamp(nf.dot(at - s.a) / den, 0.0, 1.0);
    Vec3 q = s.a + u * ab;
    const double reach = 8.0 * radius, d = (q - at).norm();
    if (d > reach) q = at + (q - at) * (reach / d);
    return q;
  }
  static double distanceToSegment(const Vec3& x, const Vec3& a, const Vec3& b) {
    return (x - collision::closestPointOnSegment(x, a, b)).norm();
  }

  struct Pair {
    double d;
    std::size_t track, hit;
  };
  std::vector<Hit> segHitsBuf, hitsBuf;
  std::vector<std::size_t> segBegin;
  std::vector<Pair> pairsBuf;
  std::vector<int> matchBuf, trackOfHitBuf;
  struct Deep {
    std::size_t hit;
    int track;
    Vec3 from, to;    // the edge's end that went through, last sample -> now
    double fraction;  // where along it (> 1: unknown)
  };
  std::vector<Deep> deepBuf;
  int splitting = 0;
  std::vector<Face> walkFaces;
  // Fan splits (fanLabels, splitByGroups) and extend's vertex list.
  std::vector<Face> fanFaces, fanPick;
  std::vector<int> fanParent, fanLabel, fanSide;
  std::vector<std::vector<Face>> fanGroupsBuf;
  std::vector<Vertex> extendTouched;

  std::vector<Dirty> dirtyWork;
  // Safety net: no vertex around an edit may join two fans.
  void fixPinches() {
    dirtyWork.clear();
    std::swap(dirtyWork, dirty);  // both keep their capacity
    // An edit touches a vertex several times: check each once, unless its last edit
    // already found it one fan (the order of edits is kept within a vertex).
    for (std::size_t i = 0; i < dirtyWork.size(); ++i) dirtyWork[i].seq = static_cast<std::uint32_t>(i);
    std::sort(dirtyWork.begin(), dirtyWork.end(), [](const Dirty& a, const Dirty& b) {
      if (a.obj != b.obj) return a.obj < b.obj;
      return a.v.idx() != b.v.idx() ? a.v.idx() < b.v.idx() : a.seq < b.seq;
    });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < dirtyWork.size(); ++i) {
      if (kept > 0 && dirtyWork[kept - 1].obj == dirtyWork[i].obj && dirtyWork[kept - 1].v == dirtyWork[i].v)
        dirtyWork[kept - 1].fanChecked = dirtyWork[i].fanChecked;
      else
        dirtyWork[kept++] = dirtyWork[i];
    }
    dirtyWork.resize(kept, Dirty(-1, Vertex()));
    for (const Dirty& d : dirtyWork) {
      if (d.fanChecked || indexOf(d.obj) < 0) continue;
      SurfaceMesh& m = meshOf(d.obj);
      if (!m.isValid(d.v)) continue;
      // Every edit lists the vertices whose fans it changed (the ends of a duplicated
      // edge are on the cut, hence listed too): their neighbours need no check.
      if (!singleFan(m, d.v)) unpinch(d.obj, d.v);
    }
    ThinCache* cache = nullptr;
    for (const Dirty& d : dirtyWork) {
      if (indexOf(d.obj) < 0 || !meshOf(d.obj).isValid(d.v)) continue;
      if (!cache || cache->obj != d.obj) cache = &thinCacheFor(d.obj);  // sorted by object
      improveAround(d.obj, d.v, *cache);
    }
  }

  // Faces the flips' thinness test has passed, per object: a face is tested again only
  // once an edit re-set it (the journal lists it) or the caller moved vertices
  // (motionCount); the cutter itself moves a vertex only when a groove bottom slides
  // (slideBottom un-marks its faces), so a face that passed keeps its shape until
  // then. Faces found thin are not remembered (a later flip may fix them). The result
  // is the one of testing every face around every edited vertex.
  // A vertex is settled when every face around it has passed; the faces the journal
  // lists are tested when the cache is brought up to date (thinCacheFor), and a thin one
  // unsettles its corners (so do a slide and a flip), so that around a settled vertex
  // every face has passed and improveAround need not walk its (often long: a groove's
  // bottom vertex) edge list. Testing a face earlier than improveAround would does not
  // change what happens: passing depends on the face's shape alone, and no flip is made
  // there; the flips are tried in the same order as before.
  struct ThinCache {
    int obj = -1;
    std::uint64_t layout = 0;
    long motion = -1;
    std::size_t journalF = 0;
    std::uint32_t gen = 0;
    std::vector<std::uint32_t> okGen;       // per face index: gen when it passed
    std::vector<std::uint32_t> settledGen;  // per vertex index: gen when it was settled
    [[nodiscard]] bool passed(Face f) const { return f.idx() < okGen.size() && okGen[f.idx()] == gen; }
    void pass(Face f) {
      if (f.idx() >= okGen.size()) okGen.resize(f.idx() + 1024, 0);
      okGen[f.idx()] = gen;
    }
    [[nodiscard]] bool settled(Vertex v) const { return v.idx() < settledGen.size() && settledGen[v.idx()] == gen; }
    void settle(Vertex v) {
      if (v.idx() >= settledGen.size()) settledGen.resize(v.idx() + 1024, 0);
      settledGen[v.idx()] = gen;
    }
    void unsettle(Vertex v) {
      if (v.isValid() && v.idx() < settledGen.size()) settledGen[v.idx()] = 0;
    }
  };
  std::vector<ThinCache> thinCaches;
  // Journal entries (faces [from, to) of an object's journal at `layout`) that re-set
  // faces without changing their shape (extend's splitVertex: a corner becomes its copy
  // at the same place): they keep what the thinness test found.
  struct KeptShape {
    int obj;
    std::uint64_t layout;
    std::size_t from, to;
  };
  std::vector<KeptShape> keptShapes;
  // The object's entry in thinCaches, or a new one (obj -1) when it has none.
  ThinCache& thinCacheEntry(int obj) {
    auto it = std::find_if(thinCaches.begin(), thinCaches.end(), [&](const ThinCache& c) { return c.obj == obj; });
    return it != thinCaches.end() ? *it : thinCaches.emplace_back();
  }
  ThinCache& thinCacheFor(int obj) {
    const SurfaceMesh& m = meshOf(obj);
    std::erase_if(thinCaches, [&](const ThinCache& c) { return indexOf(c.obj) < 0; });
    std::erase_if(keptShapes, [&](const KeptShape& k) { return indexOf(k.obj) < 0; });
    ThinCache& c = thinCacheEntry(obj);
    const auto journal = m.editedFaces();
    if (c.obj != obj || c.layout != m.layoutVersion() || c.motion != motionCount || c.journalF > journal.size()) {
      c.obj = obj;
      c.layout = m.layoutVersion();
      c.motion = motionCount;
      if (++c.gen == 0) {  // wrapped: forget every mark
        std::fill(c.okGen.begin(), c.okGen.end(), 0u);
        std::fill(c.settledGen.begin(), c.settledGen.end(), 0u);
        c.gen = 1;
      }
    } else {
      // The journal since the last call, less the kept shapes (recorded in edit order).
      std::size_t at = c.journalF;
      auto forget = [&](std::size_t to) {
        for (; at < to; ++at)
          if (const Face f = journal[at]; f.idx() < c.okGen.size()) c.okGen[f.idx()] = 0;
      };
      for (const KeptShape& k : keptShapes) {
        if (k.obj != obj || k.layout != c.layout || k.from < at || k.to > journal.size()) continue;
        forget(k.from);
        at = k.to;
      }
      forget(journal.size());
      // The listed faces tested now (see ThinCache): a thin one unsettles its corners.
      const double floor = 0.5 * p.snapDistance;
      for (std::size_t i = c.journalF; i < journal.size(); ++i) {
        const Face f = journal[i];
        if (m.isDeleted(f) || c.passed(f)) continue;
        if (!thinnerThan(m, f, floor))
          c.pass(f);
        else
          for (Vertex x : m.vertices(f)) c.unsettle(x);
      }
    }
    std::erase_if(keptShapes, [&](const KeptShape& k) { return k.obj == obj; });
    c.journalF = journal.size();
    return c;
  }

  // ---- sliver removal by local flips ------------------------------------------------------
  // An edge the cut relies on (path, front, walls: both ends on one live track) is never flipped.
  bool cutEdge(int obj, Vertex x, Vertex y) const {
    for (const auto& h : hands)
      for (const auto& t : h.tracks)
        if (t.alive && t.object == obj && t.visited.count(x) && t.visited.count(y)) return true;
    return false;
  }

  // Smallest height under h, without square roots (checked around every edit).
  static bool thinnerThan(const SurfaceMesh& m, Face f, double h) {
    const auto& v = m.vertices(f);
    const Vec3 &a = m.position(v[0]), &b = m.position(v[1]), &c = m.position(v[2]);
    const Vec3 ab = b - a, ac = c - a;
    const double L2 = std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
    return ab.cross(ac).squaredNorm() < h * h * L2;
  }

  // Flips edge e (faces x,y,c and y,x,d become c,x,d and d,y,c) when both faces are of
  // one kind, nearly coplanar (the surface keeps its shape), the quad is convex, and the
  // smaller of the two heights grows. Returns true when flipped.
  bool tryFlip(int obj, Edge e) {
    SurfaceMesh& m = meshOf(obj);
    if (!m.isValid(e) || m.isBoundary(e)) return false;
    const Face f0 = m.face(e, 0), f1 = m.face(e, 1);
    const auto kind = m.faceProperty<int>(kFaceKindProp, kSurface);
    if (kind[f0] != kind[f1]) return false;
    // Orient: f0 runs x -> y.
    const auto& v0 = m.vertices(f0);
    const int i0 = m.localIndex(f0, m.vertex(e, 0));
    Vertex x = m.vertex(e, 0), y = m.vertex(e, 1);
    if (v0[static_cast<std::size_t>((i0 + 1) % 3)] != y) std::swap(x, y);
    const Vertex c = m.oppositeVertex(f0, e), d = m.oppositeVertex(f1, e);
    if (!c.isValid() || !d.isValid() || c == d || m.findEdge(c, d).isValid()) return false;
    if (cutEdge(obj, x, y)) return false;
    const Vec3 &px = m.position(x), &py = m.position(y), &pc = m.position(c), &pd = m.position(d);
    const Vec3 n0 = (py - px).cross(pc - px), n1 = (px - py).cross(pd - py);
    if (!(n0.norm() > 0.0) || !(n1.norm() > 0.0) || n0.normalized().dot(n1.normalized()) < 0.995) return false;
    const Vec3 na = (px - pc).cross(pd - pc), nb = (py - pd).cross(pc - pd);
    const Vec3 nSum = n0 + n1;
    if (!(na.dot(nSum) > 0.0) || !(nb.dot(nSum) > 0.0)) return false;  // not convex
    const double before = std::min(height(px, py, pc), height(py, px, pd));
    const double after = std::min(height(pc, px, pd), height(pd, py, pc));
    if (!(after > 1.5 * before)) return false;
    const int k = kind[f0];
    const std::size_t oi = static_cast<std::size_t>(indexOf(obj));
    m.deleteFace(f0);
    m.deleteFace(f1);
    for (ThinCache& tc : thinCaches)  // new faces around x, y, c, d: not settled
      if (tc.obj == obj)
        for (Vertex z : {x, y, c, d}) tc.unsettle(z);
    const std::array<Face, 2> gone{f0, f1};
    bvhs[oi].removeFaces(m, gone);  // keeps the tree's sync local (no scan for dead faces)
    const Face a = m.addFace(c, x, d);
    const Face b = a.isValid() ? m.addFace(d, y, c) : Face();
    if (!a.isValid() || !b.isValid()) {
      // Cannot happen on a manifold mesh; put the original faces back.
      if (a.isValid()) m.deleteFace(a);
      for (const Face g : {m.addFace(x, y, c), m.addFace(y, x, d)})
        if (g.isValid()) m.faceProperty<int>(kFaceKindProp, kSurface)[g] = k;
      return false;
    }
    auto kinds = m.faceProperty<int>(kFaceKindProp, kSurface);
    kinds[a] = k;
    kinds[b] = k;
    ++stats.flips;
    touch(obj, {x, y, c, d});
    return true;
  }

  // Thin triangles around v: flip their longest edge where that helps.
  // Each face is tested once per call of fixPinches at most (and not again while it
  // keeps its shape: ThinCache).
  void improveAround(int obj, Vertex v, ThinCache& ok) {
    if (ok.settled(v)) return;  // every face around v has passed (ThinCache)
    SurfaceMesh& m = meshOf(obj);
    const double floor = 0.5 * p.snapDistance;
    for (int round = 0; round < 4; ++round) {
      // The faces around v not passed yet, in the order of v's edges (both sides):
      // most have passed, so this loop stays tight (no test, no flip). Then the
      // tests in that order, as one loop over edges and sides would make them (a face
      // listed twice is passed or, thin, tried again with the same result).
      const auto& es = m.edges(v);
      if (thinTodo.size() < 2 * es.size()) thinTodo.resize(2 * es.size());  // (only grows: no refill)
      Face* todo = thinTodo.data();
      std::size_t n = 0;
      for (Edge ev : es)
        for (int s = 0; s < 2; ++s) {
          const Face f = m.face(ev, s);
          if (f.isValid() && !ok.passed(f)) todo[n++] = f;
        }
      bool flipped = false, thin = false;
      for (std::size_t i = 0; i < n && !flipped; ++i) {
        const Face f = thinTodo[i];
        if (ok.passed(f)) continue;
        if (!thinnerThan(m, f, floor)) {
          ok.pass(f);
          continue;
        }
        thin = true;
        Edge longest;
        double L = -1.0;
        for (Edge g : m.edges(f))
          if (const double l = m.edgeLength(g); l > L) {
            L = l;
            longest = g;
          }
        flipped = tryFlip(obj, longest);  // edges of v changed: list them again
      }
      if (!flipped) {
        if (!thin) ok.settle(v);  // every face around v has passed
        return;
      }
    }
  }
  std::vector<Face> thinTodo;

  void debugScan(const char* where) {
    if (!dbg()) return;
    for (const auto& o : objects)
      for (Vertex v : o.mesh.vertices())
        if (!isManifoldVertex(o.mesh, v)) std::cerr << "PINCH after " << where << " at " << v << "\n";
    for (const auto& o : objects)  // (O(mesh): debugging only)
      if (const auto rep = o.mesh.validate(); !rep.ok())
        std::cerr << "INVALID after " << where << " obj " << o.id << ": " << rep.message() << "\n";
  }

  // stillSincePrev: the tissue has not moved since prevPose was cut, so where the blade
  // was then is where it was in the tissue as it is now.
  void processSample(HandState& hs, Tool tool, const Pose& pose, const Pose* prevPose, bool report,
                     bool stillSincePrev) {
    movedSincePrev = !stillSincePrev;
    const auto segs = instruments::segments(tool, pose, p.tool);
    const bool cuts = tool == Tool::Scalpel || (tool == Tool::Hook && pose.pedal);
    std::vector<Hit>& hits = hitsBuf;
    hits.clear();
    segHitsBuf.clear();
    segBegin.assign(segs.size() + 1, 0);
    if (cuts || report) {
      IntervalTimer timer{stats.collisionSeconds};
      for (std::size_t s = 0; s < segs.size(); ++s) {
        segBegin[s] = segHitsBuf.size();
        hitsOf(segs[s].a, segs[s].b, static_cast<int>(s), segHitsBuf);
        ++stats.collisionQueries;
      }
    }
    segBegin[segs.size()] = segHitsBuf.size();
    for (std::size_t s = 0; s < segs.size(); ++s) {
      const auto& sg = segs[s];
      if (!cuts && !report) continue;
      const auto hb = segHitsBuf.begin() + static_cast<std::ptrdiff_t>(segBegin[s]);
      const auto he = segHitsBuf.begin() + static_cast<std::ptrdiff_t>(segBegin[s + 1]);
      if (report)
        for (auto it = hb; it != he; ++it) {
          const Hit& x = *it;
          Contact c;
          c.object = x.object;
          c.segment = x.segment;
          c.role = sg.role;
          c.point = x.point;
          c.t = x.t;
          c.entering = x.dir > 0;
          res->contacts.push_back(c);
        }
      if (cuts && sg.role == instruments::SegmentRole::CuttingEdge) hits.insert(hits.end(), hb, he);
    }
    if (!cuts) {
      terminateAll(hs);
      return;
    }
    newTracksBuf.clear();
    // Out of the tissue with no cut open: the stroke is over (its own cut is any tissue now).
    if (hits.empty() && std::none_of(hs.tracks.begin(), hs.tracks.end(), [](const Track& t) { return t.alive; }))
      hs.stroke.clear();
    std::vector<instruments::Segment> prevSegs;
    if (prevPose) prevSegs = instruments::segments(tool, *prevPose, p.tool);
    auto motionOf = [&](int s) -> Vec3 {
      if (prevSegs.size() != segs.size()) return Vec3::Zero();
      const auto& a = segs[static_cast<std::size_t>(s)];
      const auto& b = prevSegs[static_cast<std::size_t>(s)];
      return 0.5 * (a.a + a.b) - 0.5 * (b.a + b.b);
    };
    auto bladeOf = [&](int s) -> Vec3 {
      const auto& a = segs[static_cast<std::size_t>(s)];
      return (a.b - a.a).normalized();
    };

    for (auto& t : hs.tracks) {
      followTissue(t);
      if (!t.alive) continue;
      if (const Vec3 mv = motionOf(t.segment); mv.squaredNorm() > 1e-24) t.lastMotion = mv;
    }
    // Match crossings to the tracks of the previous sample, nearest first.
    std::vector<Pair>& pairs = pairsBuf;
    pairs.clear();
    for (std::size_t ti = 0; ti < hs.tracks.size(); ++ti) {
      const Track& t = hs.tracks[ti];
      if (!t.alive) continue;
      const Vec3 at = t.hasPending ? t.pending : t.start;
      const double radius = p.matchRadius + 2.0 * motionOf(t.segment).norm();
      const Vec3 ahead = crossingAhead(t, at, segs[static_cast<std::size_t>(t.segment)], radius);
      for (std::size_t hi = 0; hi < hits.size(); ++hi) {
        const Hit& h = hits[hi];
        if (h.object != t.object || h.segment != t.segment || h.dir != t.dir) continue;
        double d = distanceToSegment(h.point, at, ahead);
        if (d > radius && prevSegs.size() == segs.size())
          d = std::min(d, distanceToSegment(
                              at, crossingBehind(h, prevSegs[static_cast<std::size_t>(t.segment)], radius), h.point));
        if (d <= radius) pairs.push_back({d, ti, hi});
      }
    }
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
      return a.d != b.d ? a.d < b.d : (a.track != b.track ? a.track < b.track : a.hit < b.hit);
    });
    std::vector<int>& matchOf = matchBuf;
    matchOf.assign(hs.tracks.size(), -1);
    for (const auto& pr : pairs) {
      if (matchOf[pr.track] >= 0 || hits[pr.hit].used) continue;
      matchOf[pr.track] = static_cast<int>(pr.hit);
      hits[pr.hit].used = true;
    }
    // A new crossing next to a groove's crossing with material between them: the
    // blade's end went through the layer below, and the groove turns into a cut-through
    // before the tracks move on. The sample is first split where the end went through,
    // so that the cut changes at the same place at any sampling rate.
    std::vector<int>& trackOfHit = trackOfHitBuf;
    trackOfHit.assign(hits.size(), -1);
    for (std::size_t ti = 0; ti < matchOf.size(); ++ti)
      if (matchOf[ti] >= 0) trackOfHit[static_cast<std::size_t>(matchOf[ti])] = static_cast<int>(ti);
    // On a side the motion pinched in, the blade's edge may meet the pinch's second lobe a
    // sample after a pair started on the first: a new in and out just beyond one layer's
    // crossing (away from its partner's). Started as a second pair, its inner track and
    // the first pair's met and ended as the pinch was cut, and the outer ones went on as
    // unpaired grooves (moving seeds 40419, 40772, 41251, 41364). The layer takes the far
    // crossing; its walk cuts over the pinch.
    struct PinchTake {
      std::size_t track, own, nearHit;
    };
    std::vector<PinchTake> pinchTakes;
    if (stepMoved && prevPose)
      for (std::size_t ti = 0; ti < matchOf.size(); ++ti) {
        const Track& t = hs.tracks[ti];
        const Track* P = trackById(t.partner);
        if (matchOf[ti] < 0 || !t.alive || t.tunnel || !P || !closedObject(t.object)) continue;
        const std::size_t pi = static_cast<std::size_t>(P - hs.tracks.data());
        if (pi >= matchOf.size() || matchOf[pi] < 0) continue;
        const std::size_t k = static_cast<std::size_t>(matchOf[ti]), pk = static_cast<std::size_t>(matchOf[pi]);
        if (pk + 1 != k && k + 1 != pk) continue;
        if (pk < k ? k + 2 >= hits.size() : k < 2) continue;  // no two hits beyond k
        const std::size_t nearHit = pk < k ? k + 1 : k - 1, farHit = pk < k ? k + 2 : k - 2;
        const Hit &hk = hits[k], &hn = hits[nearHit], &hf = hits[farHit];
        auto fresh = [&](const Hit& x, std::size_t xi) {
          return !x.used && trackOfHit[xi] < 0 && x.object == hk.object && x.segment == hk.segment &&
                 kindOf(x) == kSurface && !onStrokeLip(hs, x);
        };
        if (!fresh(hn, nearHit) || !fresh(hf, farHit) || hn.dir != -hk.dir || hf.dir != hk.dir ||
            (hn.point - hk.point).norm() >= p.matchRadius || (hf.point - hn.point).norm() < foldThickness() ||
            clipsBulge(hk.dir > 0 ? hf : hn, hk.dir > 0 ? hn : hf, false))
          continue;
        if (dbg()) std::cerr << "track " << t.id << " takes the pinch's far crossing " << hf.point.transpose() << "\n";
        hits[nearHit].used = hits[farHit].used = true;
        trackOfHit[k] = -1;
        trackOfHit[farHit] = static_cast<int>(ti);
        matchOf[ti] = static_cast<int>(farHit);
        pinchTakes.push_back({ti, k, nearHit});
      }
    deepBuf.clear();
    for (std::size_t i = 0; i < hits.size(); ++i) {
      const Hit& h = hits[i];
      if (h.used || !closedObject(h.object)) continue;
      for (const std::size_t nb : {i - 1, i + 1}) {
        if (nb >= hits.size()) continue;  // i - 1 wraps for i = 0
        const Hit& o = hits[nb];
        if (o.object != h.object || o.segment != h.segment || trackOfHit[nb] < 0) continue;
        const bool between = nb < i ? (o.dir > 0 && h.dir < 0) : (h.dir > 0 && o.dir < 0);
        const Track& t = hs.tracks[static_cast<std::size_t>(trackOfHit[nb])];
        if (!between || !t.alive || t.partner >= 0 || t.tunnel) continue;
        if ((h.point - o.point).norm() < foldThickness()) continue;  // a fold of the surface, not the bottom
        Deep d{i, trackOfHit[nb], Vec3::Zero(), Vec3::Zero(), 2.0};
        if (prevSegs.size() == segs.size()) {
          // The end of the edge beyond the new crossing is the one that went through.
          const std::size_t sg = static_cast<std::size_t>(h.segment);
          const bool atA = h.t < o.t;
          d.from = atA ? prevSegs[sg].a : prevSegs[sg].b;
          d.to = atA ? segs[sg].a : segs[sg].b;
          const std::size_t oi = static_cast<std::size_t>(indexOf(h.object));
          if (const auto* x = nearestCrossing(oi, d.from, d.to, h.point)) d.fraction = x->t;
        }
        deepBuf.push_back(d);
        break;
      }
    }
    if (!deepBuf.empty() && prevPose && splitting == 0) {
      double f = 1.0;
      for (const Deep& d : deepBuf) f = std::min(f, d.fraction);
      if (f > 1e-6 && f < 1.0) {
        const Pose mid = lerpPose(*prevPose, pose, f * (1.0 - 1e-6));
        ++splitting;
        processSample(hs, tool, mid, prevPose, false, stillSincePrev);
        processSample(hs, tool, pose, &mid, report, true);
        --splitting;
        return;
      }
    }
    for (const Deep& d : deepBuf) {
      hits[d.hit].used = true;
      if (!mayStart(hs, hits[d.hit].object, hits[d.hit].segment, 1)) continue;
      const bool swept = d.fraction <= 1.0;
      deepen(hs, static_cast<std::size_t>(d.track), hits[d.hit], swept ? &d.from : nullptr, swept ? &d.to : nullptr);
    }

    const std::size_t nTracks = matchOf.size();  // tracks started here (deepen) move from the next sample
    for (std::size_t ti = 0; ti < nTracks; ++ti) {
      if (matchOf[ti] < 0 || !hs.tracks[ti].alive) continue;
      Track& t = hs.tracks[ti];
      // A layer whose partner's walk failed this sample goes on as a groove: the far
      // lobe's walk is no groove's (moving seed 40781 went round the slab); it takes its
      // own crossing and the lobe starts its own cut, as before.
      for (const PinchTake& pt : pinchTakes)
        if (pt.track == ti && t.partner < 0) {
          const std::size_t far = static_cast<std::size_t>(matchOf[ti]);
          hits[pt.nearHit].used = hits[far].used = false;
          trackOfHit[far] = -1;
          trackOfHit[pt.own] = static_cast<int>(ti);
          matchOf[ti] = static_cast<int>(pt.own);
        }
      if (advanceFast(t, hits[static_cast<std::size_t>(matchOf[ti])])) {
        ++stats.fastSamples;
        continue;
      }
      ++stats.slowSamples;
      {
        IntervalTimer timer{stats.remeshSeconds};
        advance(t, hits[static_cast<std::size_t>(matchOf[ti])], bladeOf(t.segment));
      }
      debugScan("advance");
    }
    // Tracks that lost the blade.
    for (std::size_t ti = 0; ti < nTracks; ++ti) {
      Track& t = hs.tracks[ti];
      if (!t.alive || matchOf[ti] >= 0) continue;
      Track* P = trackById(t.partner);
      {
        const auto& sg = segs[static_cast<std::size_t>(t.segment)];
        if (holdsWithout(t, sg) || (P && holdsWithout(*P, sg))) {
          ++stats.holds;
          continue;
        }
      }
      // One layer of a pair lost the blade next to the side it is leaving over while the
      // other still has it: on moving tissue a dent of that side next to the crossing
      // started two grooves, and one of them took this layer's crossing as it climbed
      // the side (seeds 40174, 40182). Ended alone, it left its partner to end as a
      // groove and the piece attached; it waits for the partner, and they cut out.
      if (P && movedSincePrev) {
        const std::size_t pi = static_cast<std::size_t>(P - hs.tracks.data());
        if (pi < nTracks && matchOf[pi] >= 0 && P->alive && leavingOverSide(t, *P)) {
          if (dbg()) std::cerr << "track " << t.id << " waits at the side for its partner\n";
          ++stats.holds;
          continue;
        }
      }
      if (P) {
        std::size_t pi = static_cast<std::size_t>(P - hs.tracks.data());
        if (pi < nTracks && matchOf[pi] < 0) {
          {
            IntervalTimer timer{stats.remeshSeconds};
            cutOut(t, *P, motionOf(t.segment));
          }
          debugScan("cutOut");
          continue;
        }
      }
      {
        IntervalTimer timer{stats.remeshSeconds};
        terminate(t, motionOf(t.segment), bladeOf(t.segment));
      }
      debugScan("terminate");
    }
    // New crossings start cuts: two with material between them on a closed object
    // make a slide-in through both layers; others a pierce-in.
    for (std::size_t i = 0; i < hits.size(); ++i) {
      if (hits[i].used) continue;
      const Hit& h = hits[i];
      // (A track that could not walk to its crossing restarts there: on the surface that
      // is the cut going on past a corner it could not take, so the lip rule spares it.)
      const bool restart = trackOfHit[i] >= 0 && kindOf(h) == kSurface;
      if (!restart && onStrokeLip(hs, h)) {
        hits[i].used = true;
        ++stats.lipCrossings;
        if (dbg()) std::cerr << "lip crossing at " << h.point.transpose() << " dir " << h.dir << "\n";
        continue;
      }
      std::size_t j = i + 1;
      // On moved tissue the edge may go in, out, in and out of a side the motion pinched
      // in (within the matching radius): two pairs there each lost their inner track as
      // the pinch was cut and went on as unpaired grooves. The outer crossings make the
      // pair; clips of a bulge are left to clipsBulge. (stepMoved, not movedSincePrev: the
      // motion before the step made the pinch, and a later substep, counted as still, meets it.)
      auto pinched = [&] {
        if (!stepMoved || !prevPose || restart || j + 2 >= hits.size() || !closedObject(h.object)) return false;
        for (std::size_t k = i; k <= j + 2; ++k)
          if (hits[k].used || trackOfHit[k] >= 0 || hits[k].object != h.object || hits[k].segment != h.segment ||
              hits[k].dir != ((k - i) % 2 == 0 ? 1 : -1) || kindOf(hits[k]) != kSurface || onStrokeLip(hs, hits[k]))
            return false;
        return !clipsBulge(hits[i], hits[j], false) && !clipsBulge(hits[j + 1], hits[j + 2], false) &&
               (hits[j + 1].point - hits[j].point).norm() < p.matchRadius;
      };
      if (pinched()) {
        if (dbg()) std::cerr << "pinch of " << (hits[j + 1].point - hits[j].point).norm() << " crossed\n";
        hits[j].used = hits[j + 1].used = true;
        j += 2;
      }
      // Two new crossings close together beside a cut this edge is making: the blade
      // grazes a fold of the surface (a lip the moving tissue curled), not two layers.
      auto besideCut = [&](const Hit& x) {
        for (std::size_t k = 0; k < hits.size(); ++k)
          if (trackOfHit[k] >= 0 && hits[k].object == x.object && hits[k].segment == x.segment) return true;
        return false;
      };
      // The edge goes in here and out at the next crossing, on a closed object.
      const bool inOut = j < hits.size() && !hits[j].used && hits[j].object == h.object &&
                         hits[j].segment == h.segment && h.dir > 0 && hits[j].dir < 0 && closedObject(h.object);
      if (inOut && !restart && trackOfHit[j] < 0 && clipsBulge(h, hits[j], stillSincePrev || !prevPose)) {
        if (dbg()) std::cerr << "bulge clipped at " << h.point.transpose() << "\n";
        hits[i].used = hits[j].used = true;
        continue;
      }
      // On moved tissue, such a graze just outside a pair's crossing on a wavy side (its
      // inner crossing within the matching radius of that layer's crossing) is the layer
      // itself coming in over the dent: two grooves started there took both layers'
      // crossings at the next sample and split the pair at once (moving seeds 40339,
      // 41148, 41338). Nothing starts; the pair's track takes the layer.
      auto outsidePair = [&](std::size_t inner, std::size_t nb) {
        if (nb >= hits.size() || trackOfHit[nb] < 0 || hits[nb].object != h.object || hits[nb].segment != h.segment ||
            hits[nb].dir != -hits[inner].dir)
          return false;
        const Track& t = hs.tracks[static_cast<std::size_t>(trackOfHit[nb])];
        return t.partner >= 0 && (hits[nb].point - hits[inner].point).norm() < p.matchRadius;
      };
      if (inOut && movedSincePrev && !restart && trackOfHit[j] < 0 &&
          (hits[j].point - h.point).norm() < foldThickness() &&
          (outsidePair(j, j + 1) || (i > 0 && outsidePair(i, i - 1)))) {
        if (dbg()) std::cerr << "graze outside a pair at " << h.point.transpose() << "\n";
        hits[i].used = hits[j].used = true;
        continue;
      }
      if (inOut && !((hits[j].point - h.point).norm() < foldThickness() && besideCut(h)) && !onStrokeLip(hs, hits[j])) {
        hits[i].used = hits[j].used = true;
        if (!mayStart(hs, h.object, h.segment, 2)) continue;
        // Upper layer (h0) is the one nearer the edge's far end b.
        {
          IntervalTimer timer{stats.remeshSeconds};
          startPair(hs, hits[j], hits[i], motionOf(h.segment), bladeOf(h.segment), pose.up,
                    stillSincePrev && prevSegs.size() == segs.size() ? &prevSegs[static_cast<std::size_t>(h.segment)]
                                                                     : nullptr,
                    stepMoved);
        }
        debugScan("startPair");
        continue;
      }
      hits[i].used = true;
      if (!mayStart(hs, h.object, h.segment, 1)) continue;
      startSingle(hs, h);
      Track& t = hs.tracks.back();
      t.startMotion = motionOf(h.segment);
      t.startBlade = bladeOf(h.segment);
      const auto* past = std::get_if<Hit::PastStart>(&h.restart);
      if (past && past->face.isValid()) {  // a track's crossing went back past its start
        t.start = past->point;
        t.startFace = past->face;
        t.startMotion = Vec3::Zero();
        IntervalTimer timer{stats.remeshSeconds};
        Hit to = h;
        advance(t, to, bladeOf(h.segment));
      }
    }
    capStrokeGrowth(hs);
    retireTracks(hs);
    // Separation of freed pieces.
    auto objs = checkSeparation;
    checkSeparation.clear();
    std::sort(objs.begin(), objs.end());
    objs.erase(std::unique(objs.begin(), objs.end()), objs.end());
    if (!dirty.empty()) {
      IntervalTimer timer{stats.remeshSeconds};
      fixPinches();
    }
    debugScan("safety net");
    for (int o : objs) separate(o);
    debugScan("separate");
    for (auto& h : hands) retireTracks(h);
    for (auto& t : hs.tracks) anchor(t);
    if (report) {
      for (const auto& t : hs.tracks) {
        if (!t.alive || !t.hasPending) continue;
        CutPoint c;
        c.object = t.object;
        c.segment = t.segment;
        c.track = t.id;
        c.point = t.pending;
        c.depth = t.pendingDepth;
        c.through = t.partner >= 0;
        res->cutPoints.push_back(c);
        PreviewSegment ps;
        ps.object = t.object;
        ps.from = t.tip.isValid() ? meshOf(t.object).position(t.tip) : t.start;
        ps.to = t.pending;
        ps.depth = t.pendingDepth;
        res->preview.push_back(ps);
      }
    }
  }

  // ---- bookkeeping around a call -------------------------------------------------------------------
  struct Counts {
    long faces = 0, vertices = 0;
  };
  Counts counts() const {
    Counts c;
    for (const auto& o : objects) {
      c.faces += static_cast<long>(o.mesh.nFaces());
      c.vertices += static_cast<long>(o.mesh.nVertices());
    }
    return c;
  }
  std::uint64_t versionSum() const {
    std::uint64_t s = objects.size();
    for (const auto& o : objects) s += o.mesh.topologyVersion();
    return s;
  }

  template <class F>
  StepResult run(F&& body) {
    StepResult r;
    res = &r;
    const Counts before = counts();
    const std::uint64_t v0 = versionSum();
    separationSeconds = 0.0;
    body();
    const Counts after = counts();
    r.trianglesAdded = after.faces - before.faces;
    r.verticesAdded = after.vertices - before.vertices;
    r.topologyChanged = versionSum() != v0;
    stats.trianglesAdded += r.trianglesAdded;
    stats.verticesAdded += r.verticesAdded;
    stats.separationSeconds += separationSeconds;
    res = nullptr;
    return r;
  }
};

CutEngine::CutEngine(CutParams params) : impl_(std::make_unique<Impl>()) {
  if (!(params.snapDistance >= 0.0) || !(params.snapFraction >= 0.0) || params.snapFraction >= 0.5 ||
      !(params.maxSubstep > 0.0) || params.maxSubsteps < 1 || !(params.matchRadius > 0.0) ||
      !(params.grooveSpacing >= 0.0) || !(params.wallMinAngleDeg >= 0.0) || params.wallMinAngleDeg > 60.0 ||
      params.maxNewTracksPerSample < 1 || params.strokeFacesMin < 0 || !(params.strokeFacesFactor >= 0.0))
    throw CutError("CutParams out of range");
  impl_->p = params;
  (void)timerOverhead();  // calibrated before the first interval
}
CutEngine::~CutEngine() = default;
CutEngine::CutEngine(CutEngine&&) noexcept = default;
CutEngine& CutEngine::operator=(CutEngine&&) noexcept = default;

int CutEngine::addObject(mesh::SurfaceMesh m) {
  TissueObject o;
  o.id = impl_->nextId++;
  o.closedAtStart = m.isClosed();
  o.mesh = std::move(m);
  o.mesh.faceProperty<int>(kFaceKindProp, kSurface);
  o.mesh.vertexProperty<std::uint8_t>(kApexProp, 0);
  impl_->hasTissue.push_back(physics::hasTissueProperties(o.mesh));
  impl_->objects.push_back(std::move(o));
  impl_->roomToCut(impl_->objects.size() - 1);
  impl_->bvhs.emplace_back(impl_->objects.back().mesh);
  if (impl_->p.collisionMargin > 0.0)
    impl_->bvhs.back().setMotionMargin(impl_->objects.back().mesh, impl_->p.collisionMargin);
  impl_->moved.push_back(0);
  impl_->moveBound.push_back(0.0);
  impl_->movedList.emplace_back();
  impl_->connected.emplace_back();
  // Known to be one piece: separation checks search from the edits only.
  if (impl_->objects.back().mesh.connectedComponents().count <= 1) impl_->markConnected(impl_->objects.size() - 1);
  return impl_->objects.back().id;
}

const std::vector<TissueObject>& CutEngine::objects() const { return impl_->objects; }

TissueObject& CutEngine::object(int id) {
  const std::size_t k = impl_->indexOfKnown(id);
  // The caller may move vertices: the object's BVH is refitted before the next query.
  impl_->moved[k] = 1;
  impl_->moveBound[k] = std::numeric_limits<double>::infinity();
  ++impl_->motionCount;  // and the tracks' start and pending points move with it
  return impl_->objects[k];
}

mesh::SurfaceMesh& CutEngine::meshToMove(int id) {
  const std::size_t k = impl_->indexOfKnown(id);
  return impl_->objects[k].mesh;
}

void CutEngine::verticesMoved(int id, std::span<const std::uint32_t> vertices) {
  const std::size_t k = impl_->indexOfKnown(id);
  impl_->noteMoved(k, vertices);
  // The tracks' start and pending points move with the tissue they are anchored to.
  if (!vertices.empty()) ++impl_->motionCount;
}

void CutEngine::verticesMoved(int id) { (void)object(id); }

std::size_t CutEngine::settleAdded(std::span<const PreviewSegment> preview) {
  std::vector<Vec3> tips;
  std::vector<std::uint32_t> moved;
  std::size_t settled = 0;
  for (std::size_t i = 0; i < objects().size(); ++i) {
    const int id = objects()[i].id;
    mesh::SurfaceMesh& m = meshToMove(id);
    if (!physics::hasTissueProperties(m)) continue;
    tips.clear();
    for (const auto& pv : preview)
      if (pv.object == id) tips.push_back(pv.from);
    const std::vector<Vertex> fresh = physics::unsettledVertices(m, tips);
    if (fresh.empty()) continue;
    physics::settleVertices(m, fresh, params().tissue);
    settled += fresh.size();
    moved.clear();
    for (Vertex v : fresh) moved.push_back(static_cast<std::uint32_t>(v.idx()));
    verticesMoved(id, moved);
  }
  return settled;
}

void CutEngine::verticesMovedWithin(int id, double maxMove) {
  const std::size_t k = impl_->indexOfKnown(id);
  if (!(maxMove >= 0.0)) maxMove = std::numeric_limits<double>::infinity();  // NaN or negative: unknown
  impl_->moveBound[k] = impl_->moved[k] ? impl_->moveBound[k] + maxMove : maxMove;
  impl_->moved[k] = 1;
  ++impl_->motionCount;  // the tracks re-anchor to the tissue, as for object()
}

void CutEngine::verticesTravelled(int id, double maxMove, std::span<double> travel, std::span<const std::uint32_t> past,
                                  std::size_t groupSize) {
  if (groupSize == 0) throw CutError("verticesTravelled: groupSize must be > 0");
  const std::size_t k = impl_->indexOfKnown(id);
  Impl& I = *impl_;
  // A step that was not summed, or earlier moves not yet taken (their bound is one
  // number): the tree checks them its own way (and leaves the travelled mode).
  if (!std::isfinite(maxMove) || !(maxMove >= 0.0) || I.moved[k] || I.bvhs[k].motionMargin() <= 0.0) {
    verticesMovedWithin(id, maxMove);
    return;
  }
  I.moved[k] = 1;
  I.moveBound[k] = maxMove;
  ++I.motionCount;  // the tracks re-anchor to the tissue, as for object()
  IntervalTimer timer{I.stats.collisionSeconds};
  I.travelling = true;
  I.travel = travel;
  I.travelPast = past;
  I.groupSize = groupSize;
  struct Clear {  // the spans do not outlive the call, even if the sync throws
    Impl& I;
    ~Clear() {
      I.travelling = false;
      I.travel = {};
      I.travelPast = {};
    }
  } clear{I};
  I.syncBvh(k);
}

double CutEngine::travelLimit(int id) const {
  const std::size_t k = impl_->indexOfKnown(id);
  return impl_->bvhs[k].travelLimit();
}

double CutEngine::travelPad(int id) const {
  const std::size_t k = impl_->indexOfKnown(id);
  return impl_->bvhs[k].travelPad();
}

StepResult CutEngine::step(Hand hand, Tool tool, const Pose& pose) {
  if (!pose.tip.allFinite() || !pose.dir.allFinite() || !pose.up.allFinite() || pose.dir.norm() < 1e-12)
    throw CutError("instrument pose is not finite or has no direction");
  Impl& I = *impl_;
  HandState& hs = I.hands[handIndex(hand)];
  return I.run([&] {
    if (hs.hasPrev && hs.tool != tool) {
      I.terminateAll(hs);
      hs.hasPrev = false;
    }
    if (!hs.hasPrev) {
      I.stepMoved = false;
      I.processSample(hs, tool, pose, nullptr, true, false);
    } else {
      const auto a = instruments::segments(tool, hs.prev, I.p.tool);
      const auto b = instruments::segments(tool, pose, I.p.tool);
      double disp = 0.0;
      for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
        disp = std::max({disp, (a[i].a - b[i].a).norm(), (a[i].b - b[i].b).norm()});
      const int n = std::clamp(static_cast<int>(std::ceil(disp / I.p.maxSubstep)), 1, I.p.maxSubsteps);
      I.stepMoved = hs.motionAtPrev != I.motionCount;
      Pose prev = hs.prev;
      for (int k = 1; k <= n; ++k) {
        const Pose cur = k == n ? pose : lerpPose(hs.prev, pose, static_cast<double>(k) / n);
        // (the substeps before this one were cut in the tissue as it is now)
        I.processSample(hs, tool, cur, &prev, k == n, k > 1 || hs.motionAtPrev == I.motionCount);
        prev = cur;
      }
    }
    hs.prev = pose;
    hs.motionAtPrev = I.motionCount;
    hs.tool = tool;
    hs.hasPrev = true;
  });
}

StepResult CutEngine::endStroke(Hand hand) {
  Impl& I = *impl_;
  HandState& hs = I.hands[handIndex(hand)];
  return I.run([&] {
    {
      IntervalTimer timer{I.stats.remeshSeconds};
      I.terminateAll(hs);
      hs.hasPrev = false;
      I.fixPinches();
    }
    // A cut joined to its own start as the hand lifted may have freed a piece.
    auto objs = I.checkSeparation;
    I.checkSeparation.clear();
    std::sort(objs.begin(), objs.end());
    objs.erase(std::unique(objs.begin(), objs.end()), objs.end());
    for (int o : objs) I.separate(o);
  });
}

StepResult CutEngine::finish() {
  StepResult a = endStroke(Hand::Left);
  StepResult b = endStroke(Hand::Right);
  a.trianglesCut += b.trianglesCut;
  a.trianglesAdded += b.trianglesAdded;
  a.verticesAdded += b.verticesAdded;
  a.topologyChanged = a.topologyChanged || b.topologyChanged;
  return a;
}

const CutStats& CutEngine::stats() const { return impl_->stats; }
const CutParams& CutEngine::params() const { return impl_->p; }

}  // namespace ld::cutting
