#include "sim/physics/mass_spring.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
#include <thread>
#include <utility>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Sparse>

#if defined(__x86_64__) || defined(_M_X64) || defined(__i386__)
#include <xmmintrin.h>
#define LD_HAVE_MXCSR 1
#endif

#include "sim/physics/linear_spring.h"
#include "sim/physics/physics_error.h"
#include "sim/physics/spring_kernel.h"

namespace ld::physics {

static_assert(Dynamics::kMoveGroup == detail::kGroup, "groupMoves2 is indexed by the step's vertex groups");

using Vec3 = Eigen::Vector3d;
using detail::Cache;
using detail::Spring;

// ---- names -------------------------------------------------------------------

namespace {
constexpr std::array<Method, 5> kMethods = {Method::ExplicitEuler, Method::SymplecticEuler, Method::Verlet, Method::Rk4,
                                            Method::ImplicitEuler};
}

std::string_view methodName(Method m) {
  switch (m) {
    case Method::ExplicitEuler:
      return "explicit_euler";
    case Method::SymplecticEuler:
      return "symplectic_euler";
    case Method::Verlet:
      return "verlet";
    case Method::Rk4:
      return "rk4";
    case Method::ImplicitEuler:
      return "implicit_euler";
    case Method::Xpbd:
      return "xpbd";
  }
  return "?";
}

Method methodFromName(std::string_view name) {
  for (Method m : kMethods)
    if (methodName(m) == name) return m;
  if (name == methodName(Method::Xpbd)) return Method::Xpbd;
  std::string all;
  for (Method m : kMethods) all += (all.empty() ? "" : ", ") + std::string(methodName(m));
  all += ", " + std::string(methodName(Method::Xpbd));
  throw UnknownNameError("unknown integrator '" + std::string(name) + "' (one of: " + all + ")");
}

std::span<const Method> allMethods() { return kMethods; }

int convergenceOrder(Method m) {
  switch (m) {
    case Method::Verlet:
      return 2;
    case Method::Rk4:
      return 4;
    default:
      return 1;
  }
}

// ---- denormals -----------------------------------------------------------------

FlushDenormals::FlushDenormals() {
#ifdef LD_HAVE_MXCSR
  saved_ = _mm_getcsr();
  _mm_setcsr(saved_ | 0x8040u);  // FTZ | DAZ
#endif
}

FlushDenormals::~FlushDenormals() {
#ifdef LD_HAVE_MXCSR
  _mm_setcsr(saved_);
#endif
}

// ---- the helper thread ---------------------------------------------------------

namespace detail {

// Runs one job at a time on its own thread. Both sides spin (with a pause) before
// they sleep on the atomic: on this project's VMs a system call costs ~1.3 µs with a
// TLB flush and waking a sleeping thread tens of µs, while a step takes a few hundred,
// so a hand-off should not sleep. The helper spins kIdleSpin after a job (long enough
// to span the end of a step and the start of the next one), the caller up to
// kFinishSpin for the helper's last chunk; an idle worker then sleeps and costs
// nothing. libstdc++'s own wait adds sched_yield calls before it sleeps; it is only
// reached after the spin.
class Worker {
 public:
  Worker() : thread_([this] { loop(); }) {}
  ~Worker() {
    quit_.store(true);
    go_.fetch_add(1);
    go_.notify_one();
    thread_.join();
  }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  void start(void (*fn)(void*), void* ctx) {
    fn_ = fn;
    ctx_ = ctx;
    const std::uint32_t e = go_.load(std::memory_order_relaxed) + 1;
    gate_.store(gate(e, kOpen), std::memory_order_release);
    go_.fetch_add(1, std::memory_order_release);
    // A system call only when the helper has gone to sleep (libstdc++ checks for
    // waiters first).
    go_.notify_one();
  }
  // For a job the caller can finish alone (the two-thread step's chunks): true when
  // the worker had not taken the job yet; it will not now, so there is nothing to wait
  // for (a worker that gets its core late no longer holds the caller up). Otherwise
  // wait() as usual.
  bool takeBack() {
    std::uint64_t open = gate(go_.load(std::memory_order_relaxed), kOpen);
    return gate_.compare_exchange_strong(open, open - kOpen + kClosed, std::memory_order_acq_rel);
  }
  void wait() {
    const std::uint32_t target = go_.load(std::memory_order_relaxed);
    if (spinUntil(kFinishSpin, [&] { return done_.load(std::memory_order_acquire) == target; })) return;
    for (std::uint32_t d = done_.load(std::memory_order_acquire); d != target;
         d = done_.load(std::memory_order_acquire))
      done_.wait(d);
  }

 private:
  static constexpr std::chrono::microseconds kIdleSpin{200}, kFinishSpin{500};
  static void pause() {
#ifdef LD_HAVE_MXCSR
    _mm_pause();
#endif
  }
  // Spins until ready() or for about `budget` (the clock read every 64 tries).
  template <class Ready>
  static bool spinUntil(std::chrono::microseconds budget, Ready&& ready) {
    const auto end = std::chrono::steady_clock::now() + budget;
    for (;;) {
      for (int i = 0; i < 64; ++i) {
        if (ready()) return true;
        pause();
      }
      if (std::chrono::steady_clock::now() > end) return ready();
    }
  }
  void loop() {
    std::uint32_t seen = 0;
    for (;;) {
      std::uint32_t g = go_.load(std::memory_order_acquire);
      if (g == seen) spinUntil(kIdleSpin, [&] { return (g = go_.load(std::memory_order_acquire)) != seen; });
      while (g == seen) {
        go_.wait(seen);
        g = go_.load(std::memory_order_acquire);
      }
      seen = g;
      if (quit_.load()) return;
      std::uint64_t open = gate(seen, kOpen);  // the job, unless the caller took it back
      if (!gate_.compare_exchange_strong(open, open - kOpen + kTaken, std::memory_order_acq_rel)) continue;
      {
        FlushDenormals ftz;
        fn_(ctx_);
      }
      done_.store(seen, std::memory_order_release);
      done_.notify_one();  // a system call only when the caller sleeps
    }
  }
  // gate_: the job of start number e is open, taken by the worker, or taken back by
  // the caller (whoever changes it first from open). fn_ and ctx_ are read only by a
  // worker that took the job.
  static constexpr std::uint64_t kOpen = 1, kTaken = 2, kClosed = 3;
  static std::uint64_t gate(std::uint32_t e, std::uint64_t state) { return (std::uint64_t{e} << 2) | state; }
  void (*fn_)(void*) = nullptr;
  void* ctx_ = nullptr;
  std::atomic<std::uint64_t> gate_{0};
  // On their own cache lines: the helper spins on go_, the caller on done_.
  alignas(64) std::atomic<std::uint32_t> go_{0};
  alignas(64) std::atomic<std::uint32_t> done_{0};
  std::atomic<bool> quit_{false};
  std::thread thread_;
};

WorkerSlot::WorkerSlot() = default;
WorkerSlot::~WorkerSlot() = default;
WorkerSlot::WorkerSlot(const WorkerSlot&) {}
WorkerSlot& WorkerSlot::operator=(const WorkerSlot&) { return *this; }
WorkerSlot::WorkerSlot(WorkerSlot&&) noexcept = default;
WorkerSlot& WorkerSlot::operator=(WorkerSlot&&) noexcept = default;
Worker& WorkerSlot::get() {
  if (!worker_) worker_ = std::make_unique<Worker>();
  return *worker_;
}

}  // namespace detail

// ---- the model's view of the state --------------------------------------------

namespace detail {
namespace {
std::atomic<bool> gPerSpringLanes{false};
}
void forcePerSpringLanes(bool on) { gPerSpringLanes.store(on, std::memory_order_relaxed); }
}  // namespace detail

namespace {

struct View {
  const Spring* springs = nullptr;
  std::size_t nSprings = 0;
  std::size_t nCsr = 0;  // springs [nCsr, nSprings) were added since the last rebuild
  std::size_t n = 0;
  const std::uint32_t* first = nullptr;  // CSR by lower vertex (see Cache)
  const std::uint32_t* other = nullptr;
  const std::uint32_t* lower = nullptr;  // CSR slot → lower vertex
  const double* rest = nullptr;
  const double* k = nullptr;
  const Vec3* home = nullptr;
  const Vec3* ext = nullptr;
  const double* invMass = nullptr;
  const double* mass = nullptr;
  const double* stiffness = nullptr;  // Σ k at each vertex
  double homeK = 0, c = 0;
  double maxVertexStiffness = 0;
  Vec3 g = Vec3::Zero();
};

template <class T>
mesh::VertexProperty<T> requireV(const mesh::SurfaceMesh& m, const char* name) {
  auto p = m.getVertexProperty<T>(name);
  if (!p) throw MissingPropertyError(name);
  return p;
}

constexpr std::size_t kChunk = 256;  // springs per gather/compute/scatter chunk

constexpr std::uint32_t kNoSlot = ~std::uint32_t{0};

// A force buffer's vertex slots (4 doubles each) start on a 64-byte boundary inside
// the vector (sized 4n + 8): a slot never straddles a cache line, so the kernels'
// 4-wide read-modify-writes forward from store to load (a split line defeats that and
// costs more than the spring). Every slot is zero between sweeps, so a reallocation
// that moves the boundary changes nothing.
double* forceSlots(std::vector<double>& buf) {
  const auto p = reinterpret_cast<std::uintptr_t>(buf.data());
  return buf.data() + ((64 - p % 64) % 64) / sizeof(double);
}

void noteJournal(Cache& c, const mesh::SurfaceMesh& m) {
  c.topologyVersion = m.topologyVersion();
  c.layoutVersion = m.layoutVersion();
  c.journalV = m.editedVertices().size();
  c.journalE = m.editedEdges().size();
  c.journalF = m.editedFaces().size();
}

// Room to grow (a quarter, as the cutter reserves for its edits): the step's position
// and velocity buffers trade places with the mesh's every step, so the cutter adds its
// vertices to them in turn; with room just for n, each of its first additions after a
// trade copied the whole array into fresh pages (at 100k triangles ~1 ms of page faults
// a stroke, inside its remeshing).
void reserveRoom(std::vector<Vec3>& x, std::size_t n) {
  if (x.capacity() < n + 1) x.reserve(n + n / 4 + 256);
}

void sizeScratch(Cache& c, std::size_t n) {
  reserveRoom(c.xb, n);
  reserveRoom(c.vb, n);
  for (auto* buf : {&c.f, &c.f2, &c.xb, &c.vb, &c.scatter}) buf->resize(n, Vec3::Zero());
  for (auto* buf : {&c.f4, &c.scatter4}) buf->resize(4 * n + 8, 0.0);
}

// The shared K of the CSR springs (every one with k ≠ 0 has k·rest = K to 4 ulp), or
// nothing.
std::optional<double> sharedStiffness(const Cache& c, std::size_t ns) {
  std::optional<double> K;
  for (std::size_t q = 0; q < ns; ++q) {
    if (c.k[q] == 0.0) continue;  // adds nothing in either layout
    const double kr = c.k[q] * c.rest[q];
    if (!K) K = kr;
    if (!std::isfinite(kr) || std::abs(kr - *K) > 4.0 * std::numeric_limits<double>::epsilon() * std::abs(*K))
      return std::nullopt;
  }
  return K.value_or(0.0);
}

// The symplectic step's groups from the CSR: each vertex's neighbours in index order
// (the lower ones come from earlier vertices' CSR rows, in row order, then its own row,
// sorted), one rank per neighbour position; a group's lanes sorted by degree
// (descending, stable). Each block gets the number of ranks R that minimises R plus,
// for every lane of degree d > R, ⌈(d − R)/8⌉ tail ranks and kTailCost for summing
// them (blocks of like degrees: R is the largest, as plain padding would have it).
// Every rank of lane `lane` in block `blk` gets vertex i as its far end: l = 0, so a
// padding lane adds nothing and the AVX-512 step without the monitor's sums needs no
// k ≠ 0 test (one operation a rank fewer). Tail ranks are padded the same way. Lanes
// past n (no vertex) keep the group's first vertex; their results are not stored.
void pointLaneAtItself(Cache& c, std::size_t blk, std::size_t lane, std::size_t i) {
  for (std::uint32_t r = c.rankStart[blk]; r < c.rankStart[blk + 1]; ++r)
    c.rankX[detail::kLanes * r + lane] = static_cast<std::uint32_t>(3 * i);
}

// A tail's reduction (three horizontal sums and a masked add) in ranks' worth of work.
constexpr long kTailCost = 1;

// Tail ranks of a lane with `degree` springs in a block of `ranks` ranks.
long tailRanks(long degree, long ranks) {
  constexpr long L = static_cast<long>(detail::kLanes);
  return degree > ranks ? (degree - ranks + L - 1) / L : 0;
}

// Ranks of a block whose lanes have degrees deg (descending; −1: no vertex).
std::uint32_t blockRanks(const long* deg) {
  long best = std::max(0L, deg[0]), bestCost = best;
  for (long r = best - 1; r >= 0; --r) {
    long cost = r;
    for (std::size_t u = 0; u < detail::kLanes && deg[u] > r; ++u) cost += tailRanks(deg[u], r) + kTailCost;
    if (cost < bestCost) {
      best = r;
      bestCost = cost;
    }
  }
  return static_cast<std::uint32_t>(best);
}

void buildBlocks(Cache& c, std::size_t n) {
  constexpr std::size_t L = detail::kLanes, G = detail::kGroup;
  if (3 * n >= std::numeric_limits<std::uint32_t>::max()) throw PhysicsError("mesh too large for the spring cache");
  const std::size_t ns = c.first[n], ng = (n + G - 1) / G;
  std::vector<std::uint32_t> adjStart(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t q = c.first[i]; q < c.first[i + 1]; ++q) {
      ++adjStart[i + 1];
      ++adjStart[c.other[q] + 1];
    }
  for (std::size_t i = 0; i < n; ++i) adjStart[i + 1] += adjStart[i];
  std::vector<std::uint32_t> adjSlot(adjStart[n]), fill(adjStart.begin(), adjStart.end() - 1);
  std::vector<std::uint8_t> atUpper(adjStart[n]);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t q = c.first[i]; q < c.first[i + 1]; ++q) {
      adjSlot[fill[i]++] = q;
      const std::uint32_t at = fill[c.other[q]]++;
      adjSlot[at] = q;
      atUpper[at] = 1;
    }
  auto degree = [&](std::size_t i) { return i < n ? static_cast<long>(adjStart[i + 1] - adjStart[i]) : -1L; };
  c.rankStart.assign(2 * ng + 1, 0);
  c.tailStart.assign(ng + 1, 0);
  c.slotVertex.resize(G * ng);
  c.vertexSlot.resize(G * ng);
  for (std::size_t g = 0; g < ng; ++g) {
    std::uint8_t* order = c.slotVertex.data() + G * g;
    std::iota(order, order + G, std::uint8_t{0});
    std::stable_sort(order, order + G,
                     [&](std::uint8_t a, std::uint8_t b) { return degree(G * g + a) > degree(G * g + b); });
    std::uint32_t tails = 0;
    for (std::size_t slot = 0; slot < G; ++slot) c.vertexSlot[G * g + order[slot]] = static_cast<std::uint8_t>(slot);
    for (std::size_t h = 0; h < 2; ++h) {
      long deg[L];
      for (std::size_t u = 0; u < L; ++u) deg[u] = degree(G * g + order[L * h + u]);
      const std::uint32_t r = blockRanks(deg);
      c.rankStart[2 * g + h + 1] = c.rankStart[2 * g + h] + r;
      for (std::size_t u = 0; u < L; ++u) tails += static_cast<std::uint32_t>(tailRanks(deg[u], r));
    }
    c.tailStart[g + 1] = c.tailStart[g] + tails;
  }
  // Tail ranks after all blocks' ranks: absolute rank indices.
  const std::uint32_t tailBase = c.rankStart[2 * ng];
  for (std::uint32_t& t : c.tailStart) t += tailBase;
  const std::size_t ranks = c.tailStart[ng];
  const std::size_t lanes = L * ranks;
  const std::optional<double> K =
      detail::gPerSpringLanes.load(std::memory_order_relaxed) ? std::nullopt : sharedStiffness(c, ns);
  c.laneLayout = K ? detail::LaneLayout::SharedK : detail::LaneLayout::PerSpring;
  c.springK = K.value_or(0.0);
  c.laneRest = 0.0;
  if (K)
    for (std::size_t q = 0; q < ns; ++q)
      if (c.k[q] != 0.0) c.laneRest += 2.0 * c.rest[q];  // each spring has a lane at both ends
  c.rankX.assign(lanes, 0);
  c.rankK.assign(lanes, 0.0);
  c.rankRest.assign(K ? 0 : lanes, 0.0);
  c.rankRest.shrink_to_fit();
  c.tailSlot.assign(ranks, 0);
  c.halfSlot.assign(2 * ns, 0);
  for (std::size_t g = 0; g < ng; ++g) {
    const auto pad = static_cast<std::uint32_t>(3 * G * g);
    std::fill(c.rankX.begin() + static_cast<std::ptrdiff_t>(L * c.rankStart[2 * g]),
              c.rankX.begin() + static_cast<std::ptrdiff_t>(L * c.rankStart[2 * g + 2]), pad);
    std::uint32_t tail = c.tailStart[g];  // the next tail rank (by slot: block 0's first)
    for (std::size_t slot = 0; slot < G; ++slot) {
      const std::size_t i = G * g + c.slotVertex[G * g + slot];
      if (i >= n) continue;
      const std::size_t blk = 2 * g + slot / L, lane = slot % L;
      const std::uint32_t r = c.rankStart[blk + 1] - c.rankStart[blk];
      pointLaneAtItself(c, blk, lane, i);
      const auto own = static_cast<std::uint32_t>(tailRanks(degree(i), r));
      for (std::uint32_t t = tail; t < tail + own; ++t) {
        c.tailSlot[t] = static_cast<std::uint8_t>(slot);
        std::fill_n(c.rankX.begin() + static_cast<std::ptrdiff_t>(L * t), L, static_cast<std::uint32_t>(3 * i));
      }
      for (std::uint32_t a = adjStart[i]; a < adjStart[i + 1]; ++a) {
        const std::uint32_t q = adjSlot[a], pos = a - adjStart[i];
        const std::size_t at = pos < r ? L * (c.rankStart[blk] + pos) + lane : L * tail + (pos - r);
        // (a spring with k = 0 adds nothing: its lane points at its own vertex too)
        c.rankX[at] = 3 * static_cast<std::uint32_t>(c.k[q] == 0.0 ? i : atUpper[a] ? c.lower[q] : c.other[q]);
        c.rankK[at] = c.k[q];
        if (!K) c.rankRest[at] = c.rest[q];
        c.halfSlot[2 * q + atUpper[a]] = static_cast<std::uint32_t>(at);
      }
      tail += own;
    }
  }
  c.extraGroup.assign(ng, 0);
}

// One O(V + E) pass over the mesh's arrays.
void rebuildCache(Cache& c, const mesh::SurfaceMesh& m) {
  const auto& restP = m.getEdgeProperty<double>(kRestProp).vector();
  const auto& kP = m.getEdgeProperty<double>(kStiffnessProp).vector();
  const auto& massP = m.getVertexProperty<double>(kMassProp).vector();
  const std::size_t n = m.verticesSize();
  c.nVertexSlots = n;
  // Counting sort of the springs by their lower vertex.
  c.first.assign(n + 1, 0);
  for (mesh::Edge e : m.edges()) {
    const std::uint32_t a = m.vertex(e, 0).idx(), b = m.vertex(e, 1).idx();
    ++c.first[std::min(a, b) + 1];
  }
  c.maxOut = 0;
  for (std::size_t i = 0; i < n; ++i) {
    c.maxOut = std::max<std::size_t>(c.maxOut, c.first[i + 1]);
    c.first[i + 1] += c.first[i];
  }
  const std::size_t ns = c.first[n];
  c.other.resize(ns);
  c.rest.resize(ns);
  c.k.resize(ns);
  std::vector<std::uint32_t> edgeOf(ns);
  {
    std::vector<std::uint32_t> fill(c.first.begin(), c.first.end() - 1);
    for (mesh::Edge e : m.edges()) {
      const std::uint32_t a = m.vertex(e, 0).idx(), b = m.vertex(e, 1).idx();
      const std::uint32_t pos = fill[std::min(a, b)]++;
      c.other[pos] = std::max(a, b);
      c.rest[pos] = restP[e.idx()];
      c.k[pos] = kP[e.idx()];
      edgeOf[pos] = e.idx();
    }
  }
  // Each vertex's springs by the other vertex (insertion sort: a handful each).
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t s1 = c.first[i] + 1; s1 < c.first[i + 1]; ++s1)
      for (std::uint32_t t = s1; t > c.first[i] && c.other[t - 1] > c.other[t]; --t) {
        std::swap(c.other[t - 1], c.other[t]);
        std::swap(c.rest[t - 1], c.rest[t]);
        std::swap(c.k[t - 1], c.k[t]);
        std::swap(edgeOf[t - 1], edgeOf[t]);
      }
  c.lower.resize(ns);
  for (std::size_t i = 0; i < n; ++i)
    std::fill(c.lower.begin() + c.first[i], c.lower.begin() + c.first[i + 1], static_cast<std::uint32_t>(i));
  c.springs.resize(ns);
  c.nCsr = ns;
  c.liveSprings = ns;
  c.edgeSlot.assign(m.edgesSize(), kNoSlot);
  c.vertexStiffness.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t q = c.first[i]; q < c.first[i + 1]; ++q) {
      c.springs[q] = {static_cast<std::uint32_t>(i), c.other[q], c.rest[q], c.k[q]};
      c.edgeSlot[edgeOf[q]] = q;
      c.vertexStiffness[i] += c.k[q];
      c.vertexStiffness[c.other[q]] += c.k[q];
    }
  c.maxVertexStiffness = n ? *std::max_element(c.vertexStiffness.begin(), c.vertexStiffness.end()) : 0.0;
  c.invMass.assign(n, 0.0);
  c.mass.assign(n, 0.0);
  for (mesh::Vertex v : m.vertices()) {
    c.mass[v.idx()] = massP[v.idx()];
    c.invMass[v.idx()] = massP[v.idx()] > 0 ? 1.0 / massP[v.idx()] : 0.0;
  }
  buildBlocks(c, n);
  c.f.assign(n, Vec3::Zero());
  c.scatter.assign(n, Vec3::Zero());
  c.f4.assign(4 * n + 8, 0.0);
  c.scatter4.assign(4 * n + 8, 0.0);
  sizeScratch(c, n);
  c.forceZero = true;
  ++c.rebuilds;
}

// Applies the journal entries since the last update. Returns false when a rebuild is
// the better choice (too many added springs).
bool updateCache(Cache& c, const mesh::SurfaceMesh& m) {
  const auto ev = m.editedEdges().subspan(c.journalE);
  const auto fv = m.editedFaces().subspan(c.journalF);
  const auto vv = m.editedVertices().subspan(c.journalV);
  if (c.springs.size() - c.nCsr + ev.size() > std::max<std::size_t>(1024, c.nCsr / 8)) return false;
  const auto& restP = m.getEdgeProperty<double>(kRestProp).vector();
  const auto& kP = m.getEdgeProperty<double>(kStiffnessProp).vector();
  const auto& massP = m.getVertexProperty<double>(kMassProp).vector();
  const std::size_t n = m.verticesSize(), n0 = c.nVertexSlots;
  // New vertex slots: no CSR springs, massless until read below.
  c.first.resize(n + 1, c.first[n0]);
  c.invMass.resize(n, 0.0);
  c.mass.resize(n, 0.0);
  c.vertexStiffness.resize(n, 0.0);
  c.nVertexSlots = n;
  // New vertices in the slots of the last group with ranks (past n at the rebuild):
  // their padding lanes now point at themselves, as buildBlocks does for every vertex
  // (the AVX-512 step without the monitor's sums relies on it: see there).
  for (std::size_t i = n0; i < std::min(n, detail::kGroup * c.extraGroup.size()); ++i) {
    const std::size_t g = i / detail::kGroup, slot = c.vertexSlot[i];
    pointLaneAtItself(c, 2 * g + slot / detail::kLanes, slot % detail::kLanes, i);
  }
  // New groups of vertices: no ranks, lanes in vertex order.
  const std::size_t ng = (n + detail::kGroup - 1) / detail::kGroup;
  for (std::size_t g = c.extraGroup.size(); g < ng; ++g)
    for (std::size_t slot = 0; slot < detail::kGroup; ++slot) {
      c.slotVertex.push_back(static_cast<std::uint8_t>(slot));
      c.vertexSlot.push_back(static_cast<std::uint8_t>(slot));
    }
  c.rankStart.resize(2 * ng + 1, c.rankStart.back());
  c.tailStart.resize(ng + 1, c.tailStart.back());  // new groups: no tails (past the old ones)
  c.extraGroup.resize(ng, 0);
  c.edgeSlot.resize(m.edgesSize(), kNoSlot);
  std::vector<std::uint32_t> touched;
  for (mesh::Vertex v : vv) touched.push_back(v.idx());
  for (mesh::Face f : fv)
    for (mesh::Vertex v : m.vertices(f)) touched.push_back(v.idx());
  auto kill = [&](std::uint32_t slot) {
    Spring& sp = c.springs[slot];
    if (sp.k == 0.0 && sp.rest == 0.0) return;
    c.vertexStiffness[sp.i] -= sp.k;
    c.vertexStiffness[sp.j] -= sp.k;
    sp.k = sp.rest = 0.0;
    if (slot < c.nCsr) {
      if (c.laneLayout == detail::LaneLayout::SharedK && c.k[slot] != 0.0) c.laneRest -= 2.0 * c.rest[slot];
      c.k[slot] = c.rest[slot] = 0.0;
      for (int end = 0; end < 2; ++end) {
        c.rankK[c.halfSlot[2 * slot + end]] = 0.0;
        c.rankX[c.halfSlot[2 * slot + end]] = 3 * (end ? sp.j : sp.i);  // its own vertex, as padding
        if (c.laneLayout == detail::LaneLayout::PerSpring) c.rankRest[c.halfSlot[2 * slot + end]] = 0.0;
      }
    }
    --c.liveSprings;
  };
  std::vector<std::uint32_t> seen;
  seen.reserve(ev.size());
  for (mesh::Edge e : ev) {
    const std::uint32_t idx = e.idx();
    if (std::find(seen.begin(), seen.end(), idx) != seen.end()) continue;
    seen.push_back(idx);
    if (c.edgeSlot[idx] != kNoSlot) kill(c.edgeSlot[idx]);
    c.edgeSlot[idx] = kNoSlot;
    if (m.isDeleted(e)) continue;
    const std::uint32_t a = m.vertex(e, 0).idx(), b = m.vertex(e, 1).idx();
    touched.push_back(a);
    touched.push_back(b);
    const Spring sp{std::min(a, b), std::max(a, b), restP[idx], kP[idx]};
    c.edgeSlot[idx] = static_cast<std::uint32_t>(c.springs.size());
    c.springs.push_back(sp);
    c.extraGroup[sp.i / detail::kGroup] = c.extraGroup[sp.j / detail::kGroup] = 1;
    c.vertexStiffness[sp.i] += sp.k;
    c.vertexStiffness[sp.j] += sp.k;
    c.maxVertexStiffness = std::max({c.maxVertexStiffness, c.vertexStiffness[sp.i], c.vertexStiffness[sp.j]});
    ++c.liveSprings;
  }
  for (std::uint32_t v : touched) {
    const double mv = m.isDeleted(mesh::Vertex(v)) ? 0.0 : massP[v];
    c.mass[v] = mv;
    c.invMass[v] = mv > 0 ? 1.0 / mv : 0.0;
  }
  sizeScratch(c, n);
  ++c.localUpdates;
  return true;
}

// Returns true when the cache changed.
bool ensureCache(Dynamics& s, const mesh::SurfaceMesh& m) {
  Cache& c = s.cache;
  const bool sameLayout = c.layoutVersion == m.layoutVersion();
  if (sameLayout && c.topologyVersion == m.topologyVersion() && c.nVertexSlots == m.verticesSize() &&
      c.journalE == m.editedEdges().size() && c.journalF == m.editedFaces().size() &&
      c.journalV == m.editedVertices().size())
    return false;
  if (!hasTissueProperties(m)) throw MissingPropertyError(kHomeProp);
  const bool journalGrew = c.journalE <= m.editedEdges().size() && c.journalF <= m.editedFaces().size() &&
                           c.journalV <= m.editedVertices().size() && c.nVertexSlots <= m.verticesSize();
  if (!(sameLayout && journalGrew && updateCache(c, m))) rebuildCache(c, m);
  if (c.travelLayout != m.layoutVersion()) {  // renumbered: no group's travel is known any more
    if (!c.groupTravel.empty())
      c.groupTravel.assign((c.nVertexSlots + detail::kGroup - 1) / detail::kGroup,
                           std::numeric_limits<double>::infinity());
    c.travelLayout = m.layoutVersion();
  }
  noteJournal(c, m);
  s.energyBudget = std::numeric_limits<double>::quiet_NaN();  // cuts change the energy
  return true;
}

// Massless (deleted) vertices never move.
void zeroMasslessVelocities(const Cache& c, mesh::SurfaceMesh& m) {
  auto& v = m.getVertexProperty<Vec3>(kVelocityProp).vector();
  for (std::size_t i = 0; i < c.nVertexSlots && i < v.size(); ++i)
    if (c.invMass[i] == 0.0) v[i].setZero();
}

// The symplectic step's AVX-512 path loads every far end as 4 doubles (x, y, z and
// one it drops), so at the last vertex it reads one double past the positions: every
// array it reads positions from keeps one more vertex allocated (and zeroed, so that no
// tool sees an uninitialised read). Costs one reallocation (with room, reserveRoom)
// after a copy or a growth that filled the capacity, and an O(1) write a step.
void padPositions(std::vector<Vec3>& x) {
  if (x.capacity() == x.size()) reserveRoom(x, x.size());
  x.emplace_back(Vec3::Zero());
  x.pop_back();
}

// The cache of a step's dynamics, refreshed for this mesh; the step's position arrays
// (the mesh's and the one swapped with it each step) padded.
void prepare(Dynamics& d, mesh::SurfaceMesh& m) {
  if (ensureCache(d, m)) zeroMasslessVelocities(d.cache, m);
  padPositions(m.positions());
  padPositions(d.cache.xb);
}

View makeView(const Params& p, const Dynamics& s, const mesh::SurfaceMesh& m) {
  const Cache& c = s.cache;
  View w;
  w.springs = c.springs.data();
  w.nSprings = c.springs.size();
  w.nCsr = c.nCsr;
  w.n = c.nVertexSlots;
  w.first = c.first.data();
  w.other = c.other.data();
  w.lower = c.lower.data();
  w.rest = c.rest.data();
  w.k = c.k.data();
  w.home = m.getVertexProperty<Vec3>(kHomeProp).vector().data();
  w.ext = m.getVertexProperty<Vec3>(kForceProp).vector().data();
  w.invMass = c.invMass.data();
  w.mass = c.mass.data();
  w.stiffness = c.vertexStiffness.data();
  w.homeK = p.tissue.homeK;
  w.c = p.tissue.damping;
  w.maxVertexStiffness = c.maxVertexStiffness;
  w.g = p.tissue.gravity;
  return w;
}

inline const double* raw(const Vec3* p) { return p->data(); }
inline double* raw(Vec3* p) { return p->data(); }

// The force pass's spring sweep over all vertices at positions x, in chunks of
// vertices with up to cap springs. The kernel adds each spring's force to its lower
// vertex's slot in f4 and subtracts it from the far end's. Every spring touching a
// chunk's vertices from below was done earlier (in spring order), so their forces are
// then complete: done(v0, v1) takes them and zeroes their slots for the next sweep.
// Returns the sweep's spring energy.
template <class ChunkDone>
double springSweep(const View& w, detail::Kernel kern, const double* x, double* f4, std::size_t cap, ChunkDone&& done) {
  const std::uint32_t* __restrict first = w.first;
  const std::size_t vBegin = 0, vEnd = w.n;
  double pe = 0.0;
  std::size_t v0 = vBegin;
  while (v0 < vEnd) {
    // Take vertices while their springs fit (at least one vertex; at most cap).
    std::size_t v1 = v0 + 1;
    const std::uint32_t sBase = first[v0];
    while (v1 < vEnd && v1 - v0 < cap && first[v1 + 1] - sBase <= cap) ++v1;
    detail::SpringChunk ch;
    ch.x = x;
    ch.lo = w.lower + sBase;
    ch.oth = w.other + sBase;
    ch.rest = w.rest + sBase;
    ch.k = w.k + sBase;
    ch.f4 = f4;
    ch.writeLimit = w.n;
    ch.m = first[v1] - sBase;
    pe += detail::springForces(kern, ch);
    done(v0, v1);
    v0 = v1;
  }
  return 0.5 * pe;
}

// The springs added since the last rebuild, into f at both ends (before the sweep, so
// one and two threads sum every vertex's force in the same order). Returns their energy.
double addedSprings(const View& w, const double* __restrict x, double* __restrict f4) {
  double pe = 0.0;
  for (std::size_t s = w.nCsr; s < w.nSprings; ++s) {
    const Spring& sp = w.springs[s];
    const std::size_t i = sp.i, j = sp.j;
    const double ax = x[3 * j] - x[3 * i], ay = x[3 * j + 1] - x[3 * i + 1], az = x[3 * j + 2] - x[3 * i + 2];
    const double l = std::sqrt(ax * ax + ay * ay + az * az);
    const double kst = sp.k * (l - sp.rest);
    pe += kst * (l - sp.rest);
    const double q = l > 0.0 ? kst / l : 0.0;
    f4[4 * i] += q * ax;
    f4[4 * i + 1] += q * ay;
    f4[4 * i + 2] += q * az;
    f4[4 * j] -= q * ax;
    f4[4 * j + 1] -= q * ay;
    f4[4 * j + 2] -= q * az;
  }
  return 0.5 * pe;
}

struct PotentialParts {
  double spring = 0, home = 0;
};

// Full force into f (damping with v unless v is null; f need not be zeroed).
PotentialParts totalForceParts(const View& w, Cache& c, const Vec3* x, const Vec3* v, Vec3* f) {
  // The sweep scatters into a zeroed buffer; each finished total goes into f.
  double* acc = forceSlots(c.scatter4);
  PotentialParts e;
  double home = 0.0;
  const double added = addedSprings(w, raw(x), acc);
  const std::size_t cap = std::max(kChunk, c.maxOut);
  e.spring = added + springSweep(w, detail::activeKernel(), raw(x), acc, cap, [&](std::size_t v0, std::size_t v1) {
               for (std::size_t i = v0; i < v1; ++i) {
                 double* fa = acc + 4 * i;
                 const Vec3 fs(fa[0], fa[1], fa[2]);
                 std::fill_n(fa, 4, 0.0);
                 if (w.invMass[i] == 0.0) {
                   f[i].setZero();
                   continue;
                 }
                 const Vec3 dh = x[i] - w.home[i];
                 home += 0.5 * w.homeK * dh.squaredNorm();
                 f[i] = fs + w.ext[i] + w.mass[i] * w.g - w.homeK * dh;
                 if (v) f[i] -= (w.c * w.mass[i]) * v[i];
               }
             });
  e.home = home;
  return e;
}

double totalForces(const View& w, Cache& c, const Vec3* x, const Vec3* v, Vec3* f) {
  const PotentialParts e = totalForceParts(w, c, x, v, f);
  return e.spring + e.home;
}

// Spring energy at x (no forces).
double springPotential(const View& w, const Vec3* x) {
  double pe = 0.0;
  for (std::size_t s = 0; s < w.nSprings; ++s) {
    const Spring& sp = w.springs[s];
    const double stretch = (x[sp.j] - x[sp.i]).norm() - sp.rest;
    pe += 0.5 * sp.k * stretch * stretch;
  }
  return pe;
}

double homePotential(const View& w, const Vec3* x) {
  double pe = 0.0;
  for (std::size_t i = 0; i < w.n; ++i)
    if (w.invMass[i] != 0.0) pe += 0.5 * w.homeK * (x[i] - w.home[i]).squaredNorm();
  return pe;
}

// Spring and home energy at x (no forces).
double potential(const View& w, const Vec3* x) { return springPotential(w, x) + homePotential(w, x); }

double kinetic(const View& w, const Vec3* v) {
  double ke = 0.0;
  for (std::size_t i = 0; i < w.n; ++i) ke += 0.5 * w.mass[i] * v[i].squaredNorm();
  return ke;
}

// Energy of the state a step starts from.
struct E0 {
  double pe = 0, ke = 0;
};

struct Check {
  bool ok = true;
  const char* reason = "";
  double energy = 0.0;  // estimate after the step
  double work = 0.0;    // external work of the step (positive part)
};

// The monitor's test of a proposed step (x0, v0) → (x1, v1) against the budget.
Check checkStep(const StabilityOptions& o, const View& w, const Vec3* x0, const Vec3* x1, const Vec3* v1, E0 e0,
                double budget) {
  double ke = 0.0, work = 0.0, vmax2 = 0.0;
  bool finite = true;
  for (std::size_t i = 0; i < w.n; ++i) {
    const double v2 = v1[i].squaredNorm();
    finite = finite && std::isfinite(v2) && std::isfinite(x1[i].squaredNorm());
    ke += 0.5 * w.mass[i] * v2;
    vmax2 = std::max(vmax2, v2);
    work += (w.ext[i] + w.mass[i] * w.g).dot(x1[i] - x0[i]);
  }
  Check r;
  r.work = std::max(work, 0.0);
  if (!finite || !std::isfinite(ke)) return {false, "non-finite", 0, 0};
  if (!o.enabled) return r;
  r.energy = ke + potential(w, x1);
  if (vmax2 > o.maxSpeed * o.maxSpeed) return {false, "speed", 0, 0};
  const double ref = std::isfinite(budget) ? budget : e0.pe + e0.ke;
  if (r.energy > (1.0 + o.energyJump) * ref + r.work + o.absoluteSlack) return {false, "energy jump", 0, 0};
  return r;
}

// The budget after an accepted step (the monitor was on, so c.energy is set): raised by external work, relaxing toward
// the current energy from above, never following an energy rise.
double nextBudget(const StabilityOptions& o, double budget, const Check& c, E0 e0, double dt) {
  if (!o.enabled) return budget;
  double b = (std::isfinite(budget) ? budget : e0.pe + e0.ke) + c.work;
  if (c.energy < b) b = c.energy + (b - c.energy) * std::exp(-dt / o.budgetRelax);
  return b;
}

// ---- integrators: (x0, v0) → (x1, v1); return the energy at (x0, v0) ------------

E0 explicitEuler(const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt) {
  c.forceZero = false;
  const double pe = totalForces(w, c, x0, v0, c.f.data());
  for (std::size_t i = 0; i < w.n; ++i) {
    x1[i] = x0[i] + dt * v0[i];
    v1[i] = v0[i] + (dt * w.invMass[i]) * c.f[i];
  }
  return {pe, kinetic(w, v0)};
}

// What the symplectic sweep adds up on the way (the monitor's inputs). A value that
// is not finite in x1 or v1 makes ke1 or home1 not finite.
struct SweepSums {
  double spring0 = 0;   // spring energy at x0
  double ke1 = 0;       // kinetic energy at v1
  double home1 = 0;     // home energy at x1
  double v2 = 0;        // Σ |v1|² (Σ |x1 − x0|² = dt²·v2)
  double work = 0;      // external work (ext + gravity)·(x1 − x0)
  double maxComp2 = 0;  // largest squared velocity component (|v1|² ≤ 3 × it)
  double kv2 = 0;       // Σ_i K_i |v1_i|² (K_i: the sum of k at vertex i)
  // Energy at (x0, v0) apart from the springs: only needed when the monitor has no
  // budget yet, so it is a separate pass then (startEnergy).
  double home0 = 0, ke0 = 0;
  void add(const SweepSums& o) {
    spring0 += o.spring0;
    ke1 += o.ke1;
    home1 += o.home1;
    v2 += o.v2;
    work += o.work;
    maxComp2 = std::max(maxComp2, o.maxComp2);
    kv2 += o.kv2;
  }
};

struct SymplecticArgs {
  const View* w;
  const Cache* c;
  const Vec3 *x0, *v0;
  Vec3 *x1, *v1;
  double* f4;
  double dt;
  detail::Kernel kernel;
  bool energy;  // the monitor's sums (see symplecticEuler)
  bool rsqrt;   // detail::Factor::Rsqrt (both threads take the same)
  double* groupMove2 = nullptr;  // with energy: each group's move bound, squared (BlockStep)
  double* travel = nullptr;      // with groupMove2: summed (BlockStep::travel)
  double travelLimit = 0, travelPad = 0;
};

// Vertex groups [g0, g1) of the symplectic step: springs, integration, sums.
SweepSums symplecticGroups(const SymplecticArgs& a, std::size_t g0, std::size_t g1, std::vector<std::uint32_t>* past) {
  const View& w = *a.w;
  const Cache& c = *a.c;
  detail::BlockStep bs;
  bs.x0 = raw(a.x0);
  bs.v0 = raw(a.v0);
  bs.home = raw(w.home);
  bs.ext = raw(w.ext);
  bs.mass = w.mass;
  bs.stiffness = w.stiffness;
  bs.x1 = raw(a.x1);
  bs.v1 = raw(a.v1);
  bs.rankStart = c.rankStart.data();
  bs.rankX = c.rankX.data();
  bs.rankK = c.rankK.data();
  bs.tailStart = c.tailStart.data();
  bs.tailSlot = c.tailSlot.data();
  const bool shared = c.laneLayout == detail::LaneLayout::SharedK;
  bs.rankRest = shared ? nullptr : c.rankRest.data();
  bs.springK = shared ? c.springK : 0.0;
  bs.energy = a.energy;
  bs.rsqrt = a.rsqrt;
  bs.f4 = a.f4;
  bs.slotVertex = c.slotVertex.data();
  bs.vertexSlot = c.vertexSlot.data();
  bs.extra = c.extraGroup.data();
  bs.n = w.n;
  bs.g0 = g0;
  bs.g1 = g1;
  bs.groups = c.extraGroup.size();
  bs.dt = a.dt;
  bs.damp = 1.0 - a.dt * w.c;
  bs.homeK = w.homeK;
  bs.g[0] = w.g.x();
  bs.g[1] = w.g.y();
  bs.g[2] = w.g.z();
  bs.groupMove2 = a.groupMove2;
  bs.travel = a.travel;
  bs.travelLimit = a.travelLimit;
  bs.travelPad = a.travelPad;
  bs.past = past;
  // As maxMove's bound (advance), squared.
  bs.moveScale2 = a.dt * a.dt * (1.0 + 4e-12);
  detail::FinishSums acc;
  detail::blockStep(a.kernel, bs, acc);
  SweepSums s;
  s.spring0 = 0.25 * acc.pe;  // every spring was seen from both ends
  s.ke1 = 0.5 * acc.ke1;
  s.home1 = 0.5 * w.homeK * acc.home1;
  s.v2 = acc.v2;
  s.work = acc.work;
  s.maxComp2 = acc.maxComp2;
  s.kv2 = acc.kv2;
  return s;
}

// Two threads: the groups come in kChunks chunks that both threads take in turn from
// a shared counter, so a helper thread that gets its core late (a loaded machine)
// leaves more chunks to the stepping thread instead of making it wait for a fixed half.
// Each chunk's sums are kept apart and added in chunk order afterwards: the sums do not
// depend on which thread took which chunk (and no vertex's result does).
constexpr std::size_t kChunks = 32;
struct SymplecticJob {
  const SymplecticArgs* args;
  std::size_t groups = 0, chunks = 0;
  std::atomic<std::size_t> next{0};
  std::array<SweepSums, kChunks> sums{};
  std::vector<std::uint32_t>* past = nullptr;  // kChunks lists (travel summed)
  std::size_t bound(std::size_t k) const { return k * groups / chunks; }
  void work() {
    for (std::size_t k; (k = next.fetch_add(1, std::memory_order_relaxed)) < chunks;)
      sums[k] = symplecticGroups(*args, bound(k), bound(k + 1), past ? &past[k] : nullptr);
  }
  static void run(void* p) { static_cast<SymplecticJob*>(p)->work(); }
};

// v1 = (1 − dt·c)·v0 + dt·a(x0), x1 = x0 + dt·v1, in one pass over the vertex blocks
// (two threads: chunks of blocks taken in turn, see SymplecticJob; a vertex's result
// does not depend on which thread does it, so the result is bit-identical to one
// thread).
// energy off: the sums the monitor alone needs (spring energy, Σ K_i|v1_i|², kinetic
// energy, work, largest component) are not taken (spring0 then holds the added
// springs' energy only); v2 and home1 still show a non-finite step. groupMoves (with
// energy): each vertex group's move bound into c.groupMove2 (Dynamics::groupMoves2),
// else that is left empty.
SweepSums symplecticEuler(const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt,
                          int threads, bool energy = true, bool groupMoves = false,
                          double travelLimit = std::numeric_limits<double>::infinity(), double travelPad = 0.0) {
  double* f4 = forceSlots(c.f4);
  if (!c.forceZero) std::fill(c.f4.begin(), c.f4.end(), 0.0);
  c.forceZero = false;
  const detail::Kernel kern = detail::activeKernel();
  const std::size_t ng = c.extraGroup.size();
  groupMoves = groupMoves && energy;
  if (groupMoves)
    c.groupMove2.resize(ng);
  else
    c.groupMove2.clear();
  const bool travel = groupMoves && std::isfinite(travelLimit);
  if (travel) c.groupTravel.resize(ng, 0.0);  // (new groups hold new vertices: nothing moved them yet)
  const SymplecticArgs args{&w,
                            &c,
                            x0,
                            v0,
                            x1,
                            v1,
                            f4,
                            dt,
                            kern,
                            energy,
                            detail::activeFactor(kern) == detail::Factor::Rsqrt,
                            groupMoves ? c.groupMove2.data() : nullptr,
                            travel ? c.groupTravel.data() : nullptr,
                            travelLimit,
                            travelPad};
  const double added = addedSprings(w, raw(x0), f4);
  SweepSums sums;
  if (threads < 2 || w.n < 2048) {
    sums = symplecticGroups(args, 0, ng, travel ? &c.groupsPast : nullptr);
  } else {
    detail::Worker& worker = c.worker.get();
    SymplecticJob job;
    job.args = &args;
    job.groups = ng;
    job.chunks = std::min(kChunks, ng);
    if (travel) {
      c.pastChunks.resize(kChunks);
      job.past = c.pastChunks.data();
    }
    worker.start(&SymplecticJob::run, &job);
    job.work();
    if (!worker.takeBack()) worker.wait();
    for (std::size_t k = 0; k < job.chunks; ++k) sums.add(job.sums[k]);
    if (travel)  // in group order
      for (std::size_t k = 0; k < job.chunks; ++k) {
        c.groupsPast.insert(c.groupsPast.end(), c.pastChunks[k].begin(), c.pastChunks[k].end());
        c.pastChunks[k].clear();
      }
  }
  if (energy && c.laneLayout == detail::LaneLayout::SharedK) {
    // The lanes summed k·l² − 2K·l; the constant part K·rest of each lane, here. The
    // sum of the parts may round below 0 where the springs are at rest.
    sums.spring0 += 0.25 * c.springK * c.laneRest;
    if (sums.spring0 < 0.0) sums.spring0 = 0.0;  // (a NaN stays)
  }
  sums.spring0 += added;
  c.forceZero = true;
  return sums;
}

// The monitor's test from the sweep's sums. The spring energy after the step is
// bounded without another pass: each spring's length changes by at most
// |dx_i| + |dx_j|, so Σ k Δl² ≤ 2 Σ_i K_i |dx_i|² (K_i the sum of k at vertex i) and
// by the triangle inequality E_spring(x1) ≤ (√E_spring(x0) + dt·√(Σ_i K_i |v1_i|²))².
// Weighting by each vertex's own K_i (not the largest) keeps the bound tight when a
// cut leaves a few short stiff springs. Only when it does not clear the limit is the
// exact energy computed (one more pass), so the decision is the exact one.
// Home and kinetic energy at (x0, v0).
void startEnergy(const View& w, const Vec3* x0, const Vec3* v0, SweepSums& s) {
  s.home0 = homePotential(w, x0);
  s.ke0 = kinetic(w, v0);
}

// (A step without the monitor's sums has v2 and home1 only.)
bool finiteSums(const SweepSums& s) { return std::isfinite(s.ke1 + s.home1 + s.spring0 + s.work + s.v2); }

// Largest |v1|² (a pass; only when the sweep's component bound does not clear).
double maxSpeed2(const View& w, const Vec3* v1) {
  double m = 0.0;
  for (std::size_t i = 0; i < w.n; ++i) m = std::max(m, v1[i].squaredNorm());
  return m;
}

Check checkSymplectic(const StabilityOptions& o, const View& w, const Vec3* x1, const Vec3* v1, const SweepSums& s,
                      double budget, double dt) {
  Check r;
  r.work = std::max(s.work, 0.0);
  if (!finiteSums(s)) return {false, "non-finite", 0, 0};
  if (!o.enabled) return r;
  const double speed2 = o.maxSpeed * o.maxSpeed;
  if (3.0 * s.maxComp2 > speed2 && maxSpeed2(w, v1) > speed2) return {false, "speed", 0, 0};
  const double ref = std::isfinite(budget) ? budget : s.spring0 + s.home0 + s.ke0;
  const double limit = (1.0 + o.energyJump) * ref + r.work + o.absoluteSlack;
  const double root = std::sqrt(s.spring0) + dt * std::sqrt(std::min(s.kv2, w.maxVertexStiffness * s.v2));
  r.energy = s.ke1 + s.home1 + s.spring0;  // estimate (springs at x0) for the budget
  if (s.ke1 + s.home1 + root * root <= limit) return r;
  r.energy = s.ke1 + s.home1 + springPotential(w, x1);
  if (r.energy > limit) return {false, "energy jump", 0, 0};
  return r;
}

E0 verlet(const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt) {
  c.forceZero = false;
  const E0 e0{totalForces(w, c, x0, v0, c.f.data()), kinetic(w, v0)};
  for (std::size_t i = 0; i < w.n; ++i) {
    v1[i] = v0[i] + (0.5 * dt * w.invMass[i]) * c.f[i];  // half kick (v1 holds v_half)
    x1[i] = x0[i] + dt * v1[i];
  }
  totalForces(w, c, x1, nullptr, c.f2.data());
  // Second half kick with the damping taken at the end velocity (keeps order 2).
  const double denom = 1.0 + 0.5 * dt * w.c;
  for (std::size_t i = 0; i < w.n; ++i) v1[i] = (v1[i] + (0.5 * dt * w.invMass[i]) * c.f2[i]) / denom;
  return e0;
}

E0 rk4(const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt) {
  c.forceZero = false;
  const std::size_t n = w.n;
  for (auto* b : {&c.k1x, &c.k1v, &c.k2x, &c.k2v, &c.k3x, &c.k3v, &c.k4x, &c.k4v, &c.xt, &c.vt}) b->resize(n);
  auto deriv = [&](const Vec3* x, const Vec3* v, std::vector<Vec3>& kx, std::vector<Vec3>& kv) {
    const double pe = totalForces(w, c, x, v, c.f.data());
    for (std::size_t i = 0; i < n; ++i) {
      kx[i] = v[i];
      kv[i] = w.invMass[i] * c.f[i];
    }
    return pe;
  };
  const E0 e0{deriv(x0, v0, c.k1x, c.k1v), kinetic(w, v0)};
  for (std::size_t i = 0; i < n; ++i) {
    c.xt[i] = x0[i] + 0.5 * dt * c.k1x[i];
    c.vt[i] = v0[i] + 0.5 * dt * c.k1v[i];
  }
  deriv(c.xt.data(), c.vt.data(), c.k2x, c.k2v);
  for (std::size_t i = 0; i < n; ++i) {
    c.xt[i] = x0[i] + 0.5 * dt * c.k2x[i];
    c.vt[i] = v0[i] + 0.5 * dt * c.k2v[i];
  }
  deriv(c.xt.data(), c.vt.data(), c.k3x, c.k3v);
  for (std::size_t i = 0; i < n; ++i) {
    c.xt[i] = x0[i] + dt * c.k3x[i];
    c.vt[i] = v0[i] + dt * c.k3v[i];
  }
  deriv(c.xt.data(), c.vt.data(), c.k4x, c.k4v);
  for (std::size_t i = 0; i < n; ++i) {
    x1[i] = x0[i] + (dt / 6.0) * (c.k1x[i] + 2.0 * c.k2x[i] + 2.0 * c.k3x[i] + c.k4x[i]);
    v1[i] = v0[i] + (dt / 6.0) * (c.k1v[i] + 2.0 * c.k2v[i] + 2.0 * c.k3v[i] + c.k4v[i]);
  }
  return e0;
}

// (M(1 + dt·c) − dt²·J) Δv = dt·(f0 + dt·J·v0);  v1 = v0 + Δv;  x1 = x0 + dt·v1.
E0 implicitEuler(const Params& p, const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1,
                 double dt) {
  c.forceZero = false;
  const std::size_t n = w.n;
  const E0 e0{totalForces(w, c, x0, v0, c.f.data()), kinetic(w, v0)};
  using Trip = Eigen::Triplet<double>;
  std::vector<Trip> trips;
  trips.reserve(n * 3 + w.nSprings * 36);
  Eigen::VectorXd jv = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * n));  // J·v0
  const double dt2 = dt * dt;
  auto addBlock = [&](std::size_t r, std::size_t col, const Eigen::Matrix3d& B) {
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        trips.emplace_back(static_cast<int>(3 * r) + a, static_cast<int>(3 * col) + b, B(a, b));
  };
  for (std::size_t s = 0; s < w.nSprings; ++s) {
    const Spring& sp = w.springs[s];
    const Eigen::Matrix3d B = springStiffnessBlock(sp.k, sp.rest, x0[sp.j] - x0[sp.i]);  // ∂f_i/∂x_j
    const bool mi = w.invMass[sp.i] != 0.0, mj = w.invMass[sp.j] != 0.0;
    // J_ii = J_jj = −B, J_ij = J_ji = B; the matrix gets −dt²·J.
    if (mi) {
      addBlock(sp.i, sp.i, dt2 * B);
      jv.segment<3>(3 * static_cast<Eigen::Index>(sp.i)) += B * (v0[sp.j] - v0[sp.i]);
    }
    if (mj) {
      addBlock(sp.j, sp.j, dt2 * B);
      jv.segment<3>(3 * static_cast<Eigen::Index>(sp.j)) += B * (v0[sp.i] - v0[sp.j]);
    }
    if (mi && mj) {
      addBlock(sp.i, sp.j, -dt2 * B);
      addBlock(sp.j, sp.i, -dt2 * B);
    }
  }
  Eigen::VectorXd rhs(static_cast<Eigen::Index>(3 * n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = static_cast<Eigen::Index>(3 * i);
    if (w.invMass[i] == 0.0) {
      for (int a = 0; a < 3; ++a) trips.emplace_back(static_cast<int>(r) + a, static_cast<int>(r) + a, 1.0);
      rhs.segment<3>(r).setZero();
      continue;
    }
    const double diag = w.mass[i] * (1.0 + dt * w.c) + dt2 * w.homeK;
    for (int a = 0; a < 3; ++a) trips.emplace_back(static_cast<int>(r) + a, static_cast<int>(r) + a, diag);
    jv.segment<3>(r) -= w.homeK * v0[i];
    rhs.segment<3>(r) = dt * (c.f[i] + dt * Vec3(jv.segment<3>(r)));
  }
  Eigen::SparseMatrix<double> A(static_cast<Eigen::Index>(3 * n), static_cast<Eigen::Index>(3 * n));
  A.setFromTriplets(trips.begin(), trips.end());
  Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(p.cgTolerance);
  cg.setMaxIterations(p.cgMaxIterations);
  cg.compute(A);
  // Warm start from the explicit guess Δv ≈ dt·a.
  Eigen::VectorXd guess(static_cast<Eigen::Index>(3 * n));
  for (std::size_t i = 0; i < n; ++i) guess.segment<3>(3 * static_cast<Eigen::Index>(i)) = dt * w.invMass[i] * c.f[i];
  const Eigen::VectorXd dv = cg.solveWithGuess(rhs, guess);
  for (std::size_t i = 0; i < n; ++i) {
    v1[i] = v0[i] + Vec3(dv.segment<3>(3 * static_cast<Eigen::Index>(i)));
    x1[i] = x0[i] + dt * v1[i];
  }
  return e0;
}

// Prediction with the external, gravity and damping terms (damping implicit), then
// Gauss–Seidel sweeps over the spring and home constraints with multipliers reset each
// step; v1 = (x1 − x0)/dt.
E0 xpbd(const Params& p, const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt) {
  c.forceZero = false;
  const std::size_t n = w.n;
  const E0 e0{potential(w, x0), kinetic(w, v0)};
  const double damp = 1.0 / (1.0 + dt * w.c), dt2 = dt * dt;
  for (std::size_t i = 0; i < n; ++i) {
    if (w.invMass[i] == 0.0) {
      x1[i] = x0[i];
      v1[i].setZero();
      continue;
    }
    const Vec3 vp = damp * (v0[i] + dt * (w.invMass[i] * w.ext[i] + w.g));
    x1[i] = x0[i] + dt * vp;
  }
  c.lambda.assign(w.nSprings, 0.0);
  std::vector<Vec3>& lh = c.k1v;  // home multipliers
  lh.assign(n, Vec3::Zero());
  const double homeAlpha = w.homeK > 0.0 ? 1.0 / (w.homeK * dt2) : 0.0;
  for (int it = 0; it < std::max(1, p.xpbdIterations); ++it) {
    for (std::size_t s = 0; s < w.nSprings; ++s) {
      const Spring& sp = w.springs[s];
      const double wi = w.invMass[sp.i], wj = w.invMass[sp.j];
      if (sp.k <= 0.0 || wi + wj == 0.0) continue;
      const Vec3 d = x1[sp.j] - x1[sp.i];
      const double l = d.norm();
      if (!(l > 0.0)) continue;
      const double alpha = 1.0 / (sp.k * dt2);
      const double dl = (-(l - sp.rest) - alpha * c.lambda[s]) / (wi + wj + alpha);
      c.lambda[s] += dl;
      const Vec3 g = (dl / l) * d;
      x1[sp.i] -= wi * g;
      x1[sp.j] += wj * g;
    }
    if (w.homeK > 0.0)
      for (std::size_t i = 0; i < n; ++i) {
        const double wi = w.invMass[i];
        if (wi == 0.0) continue;
        const Vec3 dl = (-(x1[i] - w.home[i]) - homeAlpha * lh[i]) / (wi + homeAlpha);
        lh[i] += dl;
        x1[i] += wi * dl;
      }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (w.invMass[i] != 0.0) v1[i] = (x1[i] - x0[i]) / dt;
  return e0;
}

E0 integrate(Method m, const Params& p, const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1,
             double dt) {
  switch (m) {
    case Method::ExplicitEuler:
      return explicitEuler(w, c, x0, v0, x1, v1, dt);
    case Method::SymplecticEuler: {
      SweepSums s = symplecticEuler(w, c, x0, v0, x1, v1, dt, p.threads);
      startEnergy(w, x0, v0, s);
      return {s.spring0 + s.home0, s.ke0};
    }
    case Method::Verlet:
      return verlet(w, c, x0, v0, x1, v1, dt);
    case Method::Rk4:
      return rk4(w, c, x0, v0, x1, v1, dt);
    case Method::ImplicitEuler:
      return implicitEuler(p, w, c, x0, v0, x1, v1, dt);
    case Method::Xpbd:
      return xpbd(p, w, c, x0, v0, x1, v1, dt);
  }
  return {};
}

// One integrator step checked by the monitor.
struct Outcome {
  Check chk;
  E0 e0;
  double maxMove = std::numeric_limits<double>::infinity();  // per coordinate (Dynamics::maxMove)
};
Outcome advance(Method m, const Params& p, const StabilityOptions& o, const View& w, Cache& c, const Vec3* x0,
                const Vec3* v0, Vec3* x1, Vec3* v1, double dt, double budget) {
  if (m == Method::SymplecticEuler) {
    SweepSums s =
        symplecticEuler(w, c, x0, v0, x1, v1, dt, p.threads, o.enabled, p.groupMoves, p.travelLimit, p.travelPad);
    if (o.enabled && !std::isfinite(budget)) startEnergy(w, x0, v0, s);
    // x1 = x0 + dt v1 per coordinate, and maxComp2 is the largest squared component of
    // v1 (taken with the monitor's sums): the step's largest move, with room for roundings.
    const double move =
        o.enabled ? dt * std::sqrt(s.maxComp2) * (1.0 + 1e-12) : std::numeric_limits<double>::infinity();
    return {checkSymplectic(o, w, x1, v1, s, budget, dt), {s.spring0 + s.home0, s.ke0}, move};
  }
  const E0 e0 = integrate(m, p, w, c, x0, v0, x1, v1, dt);
  return {checkStep(o, w, x0, x1, v1, e0, budget), e0};
}

std::vector<Vec3>& velocities(mesh::SurfaceMesh& m) { return requireV<Vec3>(m, kVelocityProp).vector(); }

// Runs `substeps` monitored substeps of m from the state into (xb, vb); on success
// updates *budget.
bool attemptSubsteps(Method m, const Params& p, const View& w, Dynamics& s, mesh::SurfaceMesh& mesh, double dt,
                     int substeps, double* budget, const char** reason) {
  Cache& c = s.cache;
  const double h = dt / substeps;
  std::vector<Vec3> xs(mesh.positions()), vs(velocities(mesh));  // start copy; retries are rare
  padPositions(xs);  // the step reads positions from it (assignments below keep the capacity)
  double b = *budget;
  for (int k = 0; k < substeps; ++k) {
    const Outcome out = advance(m, p, p.stability, w, c, xs.data(), vs.data(), c.xb.data(), c.vb.data(), h, b);
    const Check& chk = out.chk;
    const E0 e0 = out.e0;
    if (!chk.ok) {
      *reason = chk.reason;
      return false;
    }
    b = nextBudget(p.stability, b, chk, e0, h);
    if (k + 1 < substeps) {
      xs = c.xb;
      vs = c.vb;
    }
  }
  *budget = b;
  return true;
}

void commit(Dynamics& s, mesh::SurfaceMesh& m) {
  std::swap(m.positions(), s.cache.xb);
  std::swap(velocities(m), s.cache.vb);
}

}  // namespace

// ---- public API -------------------------------------------------------------------

State makeState(mesh::SurfaceMesh m, const TissueParams& p) {
  State s;
  s.mesh = std::move(m);
  if (!hasTissueProperties(s.mesh)) attachTissueProperties(s.mesh, p);
  return s;
}

bool isFinite(const State& s) { return isFinite(s.mesh); }

bool isFinite(const mesh::SurfaceMesh& mesh) {
  for (const Vec3& x : mesh.positions())
    if (!x.allFinite()) return false;
  const auto v = mesh.getVertexProperty<Vec3>(kVelocityProp);
  if (v)
    for (const Vec3& u : v.vector())
      if (!u.allFinite()) return false;
  return true;
}

bool rawStep(const Params& params, State& state, Method method, double dt) {
  return rawStep(params, state, state.mesh, method, dt);
}

bool rawStep(const Params& params, Dynamics& state, mesh::SurfaceMesh& mesh, Method method, double dt) {
  FlushDenormals ftz;
  prepare(state, mesh);
  const View w = makeView(params, state, mesh);
  Cache& c = state.cache;
  bool finite = true;
  if (method == Method::SymplecticEuler)
    finite = finiteSums(symplecticEuler(w, c, mesh.positions().data(), velocities(mesh).data(), c.xb.data(),
                                        c.vb.data(), dt, params.threads, false));
  else
    integrate(method, params, w, c, mesh.positions().data(), velocities(mesh).data(), c.xb.data(), c.vb.data(), dt);
  commit(state, mesh);
  state.time += dt;
  ++state.steps;
  state.maxMove = std::numeric_limits<double>::infinity();
  return method == Method::SymplecticEuler ? finite : isFinite(mesh);
}

StepInfo activeStep(const Params& params, Dynamics& state, mesh::SurfaceMesh& mesh, double dt);  // active_region.cpp

StepInfo step(const Params& params, State& state, double dt) { return step(params, state, state.mesh, dt); }

StepInfo step(const Params& params, Dynamics& state, mesh::SurfaceMesh& mesh, double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) throw PhysicsError("step: dt must be positive and finite");
  FlushDenormals ftz;
  prepare(state, mesh);
  if (params.active.enabled && params.method == Method::SymplecticEuler) return activeStep(params, state, mesh, dt);
  const View w = makeView(params, state, mesh);
  Cache& c = state.cache;
  StepInfo info;
  info.activeVertices = mesh.nVertices();
  const Method m = params.method;
  const int sticky = state.stickyLeft > 0 ? state.stickySubsteps : 1;
  double budget = state.energyBudget;
  const char* reason = "";
  bool ok = false;
  // The move bound is known only for a first attempt that passed in one step.
  double maxMove = std::numeric_limits<double>::infinity();
  if (sticky == 1) {
    const Outcome out = advance(m, params, params.stability, w, c, mesh.positions().data(), velocities(mesh).data(),
                                c.xb.data(), c.vb.data(), dt, budget);
    ok = out.chk.ok;
    if (ok) {
      maxMove = out.maxMove;
      budget = nextBudget(params.stability, budget, out.chk, out.e0, dt);
    }
    reason = out.chk.reason;
  } else {
    ok = attemptSubsteps(m, params, w, state, mesh, dt, sticky, &budget, &reason);
    info.substeps = sticky;
  }
  info.accepted = ok;
  if (!ok) {
    ++state.stability.warnings;
    state.stability.lastReason = reason;
  }
  // Recovery: more substeps of the same method, then the implicit method.
  for (int n = 2 * sticky; !ok && m != Method::ImplicitEuler && n <= params.stability.maxSubsteps; n *= 2) {
    ++state.stability.substepRetries;
    ok = attemptSubsteps(m, params, w, state, mesh, dt, n, &budget, &reason);
    if (ok) {
      info.substeps = n;
      state.stickySubsteps = n;
      state.stickyLeft = params.stability.stickySteps;
    }
  }
  if (!ok) {
    ++state.stability.implicitFallbacks;
    info.implicitFallback = true;
    // Implicit Euler only dissipates; its step is checked for finiteness alone.
    Params ip = params;
    ip.stability.enabled = false;
    ok = attemptSubsteps(Method::ImplicitEuler, ip, w, state, mesh, dt, 1, &budget, &reason);
    if (!ok) state.stability.lastReason = reason;
  }
  if (!ok) {
    // Last resort: keep the last good positions, stop the motion.
    ++state.stability.velocityResets;
    c.xb = mesh.positions();
    for (auto& u : c.vb) u.setZero();
  }
  state.energyBudget = budget;
  if (state.stickyLeft > 0) --state.stickyLeft;
  commit(state, mesh);
  state.time += dt;
  ++state.steps;
  state.maxMove = maxMove;
  return info;
}

Energy energy(const Params& params, const State& state) { return energy(params, state, state.mesh); }

Energy energy(const Params& params, const Dynamics& state, const mesh::SurfaceMesh& mesh) {
  Dynamics& s = const_cast<Dynamics&>(state);  // the cache is derived data
  ensureCache(s, mesh);
  const View w = makeView(params, s, mesh);
  Energy e;
  const auto& x = mesh.positions();
  e.spring = springPotential(w, x.data());
  e.home = homePotential(w, x.data());
  e.kinetic = kinetic(w, mesh.getVertexProperty<Vec3>(kVelocityProp).vector().data());
  return e;
}

std::vector<Vec3> forces(const Params& params, const State& state) { return forces(params, state, state.mesh); }

std::vector<Vec3> forces(const Params& params, const Dynamics& state, const mesh::SurfaceMesh& mesh) {
  Dynamics& s = const_cast<Dynamics&>(state);
  ensureCache(s, mesh);
  const View w = makeView(params, s, mesh);
  std::vector<Vec3> f(w.n);
  totalForces(w, s.cache, mesh.positions().data(), mesh.getVertexProperty<Vec3>(kVelocityProp).vector().data(),
              f.data());
  return f;
}

double maxResidualForce(const Params& params, const State& state) {
  return maxResidualForce(params, state, state.mesh);
}

double maxResidualForce(const Params& params, const Dynamics& state, const mesh::SurfaceMesh& mesh) {
  Dynamics& s = const_cast<Dynamics&>(state);
  ensureCache(s, mesh);
  const View w = makeView(params, s, mesh);
  std::vector<Vec3> f(w.n);
  totalForces(w, s.cache, mesh.positions().data(), nullptr, f.data());
  double r = 0.0;
  for (const Vec3& u : f) r = std::max(r, u.norm());
  return r;
}

SettleResult settle(const Params& params, State& state, const SettleOptions& opt) {
  return settle(params, state, state.mesh, opt);
}

SettleResult settle(const Params& params, Dynamics& state, mesh::SurfaceMesh& mesh, const SettleOptions& opt) {
  SettleResult r;
  const double r0 = maxResidualForce(params, state, mesh);
  r.residual = r0;
  const auto maxSteps = static_cast<std::uint64_t>(std::ceil(opt.maxTime / opt.dt));
  const int every = std::max(1, opt.checkEvery);
  while (r.steps < maxSteps) {
    for (int k = 0; k < every && r.steps < maxSteps; ++k, ++r.steps) step(params, state, mesh, opt.dt);
    r.time = static_cast<double>(r.steps) * opt.dt;
    r.residual = maxResidualForce(params, state, mesh);
    // Progress on a log scale from the first residual to the tolerance.
    if (opt.progress) {
      double prog = 1.0;
      if (r.residual > opt.tolerance && r0 > opt.tolerance)
        prog = std::clamp(std::log(r0 / r.residual) / std::log(r0 / opt.tolerance), 0.0, 1.0);
      opt.progress(prog, r.residual);
    }
    double vmax = 0.0;
    for (const Vec3& u : velocities(mesh)) vmax = std::max(vmax, u.norm());
    // Settled: small residual and no motion left to carry the tissue past it.
    if (r.residual <= opt.tolerance && vmax <= opt.speedTolerance) {
      r.converged = true;
      break;
    }
    if (opt.cancel && opt.cancel()) break;
  }
  for (auto& u : velocities(mesh)) u.setZero();
  return r;
}

}  // namespace ld::physics
