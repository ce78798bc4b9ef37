#pragma once
// The thesis's surface mass-spring model and its integrators.
//
// Forces on vertex i (all in mN):
//   mesh springs   Σ_j k_ij (|x_j − x_i| − rest_ij) · (x_j − x_i)/|x_j − x_i|
//   home spring    −homeK · (x_i − home_i)
//   damping        −damping · m_i · v_i
//   gravity        m_i · g;  external  "v:force"
// Parameters (Params) are a value apart from the state (State); step() advances the
// state by dt. The state holds the mesh, whose properties (tissue_properties.h) are
// kept current after every step, so the cutter and the renderer read the mesh.
//
// A mesh owned elsewhere (a cutting::CutEngine object, the GUI's scene) is stepped in
// place: keep one Dynamics (everything a State has except the mesh) per mesh and call
// step(params, dynamics, mesh, dt); State is Dynamics + mesh and every State overload
// forwards to the in-place one, so both give bit-identical results. Topology edits
// between steps are picked up through mesh.topologyVersion().
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "sim/mesh/surface_mesh.h"
#include "sim/physics/tissue_properties.h"

namespace ld::physics {

enum class Method {
  ExplicitEuler,    // the thesis's: x += dt·v(t), v += dt·a(t)
  SymplecticEuler,  // v += dt·a(t), x += dt·v(t+dt)
  Verlet,           // velocity Verlet, damping treated implicitly in the second half kick
  Rk4,              // classic fourth-order Runge–Kutta
  ImplicitEuler,    // linearised backward Euler, conjugate gradients (Baraff & Witkin 1998)
  // Extended position-based dynamics (Macklin, Müller & Chentanez 2016): mesh and home
  // springs as compliant constraints (compliance 1/k) solved by Gauss–Seidel sweeps;
  // stable at any dt, softer than the model when the sweeps do not converge.
  Xpbd,
};

[[nodiscard]] std::string_view methodName(Method m);
// Throws UnknownNameError listing the valid names.
[[nodiscard]] Method methodFromName(std::string_view name);  // xpbd included
// The five methods of the charts and experiments (xpbd is selectable by name only).
[[nodiscard]] std::span<const Method> allMethods();
[[nodiscard]] int convergenceOrder(Method m);  // 1, 1, 2, 4, 1; xpbd 1

struct StabilityOptions {
  bool enabled = true;
  // A step is rejected when a value is not finite, a speed exceeds maxSpeed, or the
  // energy after it (kinetic at the new velocities + potential at the old positions,
  // which costs no extra pass) exceeds (1 + energyJump) × the budget plus the external
  // work of the step. The budget starts at the tissue's energy, grows only by
  // external work, and relaxes toward the current energy with time constant
  // budgetRelax, so a slow instability cannot creep up step by step.
  double energyJump = 0.5;
  double budgetRelax = 0.5;     // [s]
  double absoluteSlack = 1e-9;  // [mJ] for states at rest
  double maxSpeed = 1e6;        // [mm/s]
  int maxSubsteps = 16;         // retries with 2, 4, … substeps before going implicit
  int stickySteps = 200;        // keep the substep count that worked for this many steps
};

struct ActiveRegionOptions {
  bool enabled = false;
  // A vertex is active while its net force (without damping) is above
  // forceThreshold or its speed above speedThreshold; active vertices wake their
  // neighbours; vertices with an external force are always awake (contact).
  double forceThreshold = 0.2;  // [mN]
  double speedThreshold = 1.0;  // [mm/s]
  int sleepAfter = 20;          // quiet steps before a vertex sleeps
  // Look at every vertex's external force each step (O(vertices)). Off, only vertices
  // named with wake() (and the awake ones) are looked at, so a step costs in proportion
  // to the awake region: what a large tissue touched in one place needs.
  bool scanExternalForces = true;
};

struct Params {
  TissueParams tissue;
  Method method = Method::SymplecticEuler;
  StabilityOptions stability;
  ActiveRegionOptions active;
  int threads = 1;  // 1 or 2 worker threads for the symplectic step
  double cgTolerance = 1e-8;
  int cgMaxIterations = 200;
  int xpbdIterations = 4;  // Gauss–Seidel sweeps per xpbd step
  // The symplectic step also writes each vertex group's move bound
  // (Dynamics::groupMoves2; ~1 % of the step's instructions, so only for a caller that
  // reads it).
  bool groupMoves = false;
  // With groupMoves and a finite travelLimit, each group's bound is also summed, plus
  // travelPad a step (the consumer's room for the rounding of x + dx), into
  // Dynamics::groupTravel(), and a group whose sum passes travelLimit is listed
  // (Dynamics::groupsPastLimit()): a collision tree then looks only at those, with no
  // pass over all the vertices (TriangleBvh::refitTravelled).
  double travelLimit = std::numeric_limits<double>::infinity();
  double travelPad = 0.0;
};

// What the stability monitor recorded.
struct StabilityLog {
  std::uint64_t warnings = 0;           // steps whose first attempt was rejected
  std::uint64_t substepRetries = 0;     // retries with substeps
  std::uint64_t implicitFallbacks = 0;  // steps finished with the implicit method
  std::uint64_t velocityResets = 0;     // last resort: kept the old state, zeroed velocities
  std::string lastReason;               // "non-finite", "energy jump", "speed"
};

struct Energy {
  double kinetic = 0, spring = 0, home = 0;
  [[nodiscard]] double total() const { return kinetic + spring + home; }
};

namespace detail {
class Worker;  // a helper thread for the two-thread step (mass_spring.cpp)
// Owns the helper thread; copying a state gives the copy no thread (it starts its own
// when it needs one).
class WorkerSlot {
 public:
  WorkerSlot();
  ~WorkerSlot();
  WorkerSlot(const WorkerSlot&);
  WorkerSlot& operator=(const WorkerSlot&);
  WorkerSlot(WorkerSlot&&) noexcept;
  WorkerSlot& operator=(WorkerSlot&&) noexcept;
  Worker& get();

 private:
  std::unique_ptr<Worker> worker_;
};

// 64-byte aligned storage (vector loads of a rank never straddle a cache line).
template <class T>
struct CacheLineAllocator {
  using value_type = T;
  CacheLineAllocator() = default;
  template <class U>
  CacheLineAllocator(const CacheLineAllocator<U>&) {}  // NOLINT: rebinding
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new (n * sizeof(T), std::align_val_t{64})); }
  void deallocate(T* p, std::size_t) { ::operator delete (p, std::align_val_t{64}); }
  friend bool operator==(const CacheLineAllocator&, const CacheLineAllocator&) { return true; }
};

// The symplectic step's spring lanes (Cache::laneLayout): SharedK = far end and k
// (12 bytes, one K for the mesh), PerSpring = far end, k and rest (20 bytes).
enum class LaneLayout { SharedK, PerSpring };
// For tests and benchmarks: build the per-spring lanes even where K is shared (takes
// effect at the next cache rebuild; false = choose by the springs).
void forcePerSpringLanes(bool on);

struct Spring {
  std::uint32_t i, j;  // i < j
  double rest, k;
};
// Compact arrays derived from the mesh. Topology edits are applied locally from the
// mesh's edit journal (editedVertices/Edges/Faces): a changed or deleted edge's slot
// is zeroed (k = rest = 0), live edited edges are appended after the CSR part as
// "added" springs (summed in a short pass before the sweep), and the masses of the
// touched vertices are re-read. A full O(V + E) rebuild happens on a new
// layoutVersion() (compaction, copy, assignment), after Dynamics::invalidate(), or
// when the added springs exceed an eighth of the CSR ones. Every spring is
// stored once, at its lower vertex (CSR: springs of vertex i are
// [first[i], first[i+1]), sorted by the other vertex): the force pass of the other
// integrators sweeps it. The symplectic step has its own vertex-centric copy (each
// spring at both ends, in groups of 16 vertices; see spring_kernel.h), so it sums
// forces, integrates and does the monitor's bookkeeping in one pass with no scatter.
// Memory order follows the mesh's vertex order.
struct Cache {
  std::uint64_t topologyVersion = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t layoutVersion = std::numeric_limits<std::uint64_t>::max();
  std::size_t journalV = 0, journalE = 0, journalF = 0;  // journal entries applied
  std::size_t nVertexSlots = 0;
  // All springs as a list (other integrators, active region): [0, nCsr) are the CSR
  // slots in CSR order, the rest were added since the last rebuild. Dead ones have
  // k = rest = 0.
  std::vector<Spring> springs;
  std::size_t nCsr = 0;
  std::size_t liveSprings = 0;
  std::vector<std::uint32_t> edgeSlot;  // edge index → index in springs (or ~0)
  std::vector<double> vertexStiffness;  // Σ k of the springs at each vertex
  std::vector<std::uint32_t> first, other;
  std::vector<std::uint32_t> lower;  // CSR slot → its lower vertex (for the kernels)
  std::vector<double> rest, k;
  double maxVertexStiffness = 0.0;  // max over vertices of the sum of k of its springs
  // The symplectic step's vertex-centric layout (spring_kernel.h, BlockStep): groups
  // of 16 vertices, two blocks of 8 lanes each (lanes sorted by degree: slotVertex,
  // vertexSlot), each block with ranks of 8 lanes (offset 3·j of the far end, k, rest
  // of every incident spring: each spring appears at both ends). halfSlot[2q],
  // halfSlot[2q + 1]: where CSR slot q sits (8·rank + lane) at its lower and its upper
  // end, so an edit can zero both. extraGroup: groups touched by added springs (their
  // forces go through f4). tailStart (per group, absolute rank indices past the
  // blocks' ranks) and tailSlot (per tail rank, the lane slot 0–15 it sums for): a
  // vertex of much higher degree than the rest of its block (a cut's groove bottom
  // fans 20–30 springs among vertices of 4–6) keeps the springs past its block's rank
  // count in tail ranks of its own, 8 of them a rank, instead of padding every lane.
  // Lane layout (spring_kernel.h): when every spring with k ≠ 0 has k·rest = one K to
  // rounding (4 ulp; tissue_properties gives every edge k = K / rest, at load and after
  // cuts), the lanes carry the far end and k only (12 bytes; rankRest empty, springK =
  // K, laneRest = Σ rest over the live lanes for the energy's constant part); otherwise
  // far end, k and rest (20 bytes).
  LaneLayout laneLayout = LaneLayout::PerSpring;
  double springK = 0.0, laneRest = 0.0;
  std::vector<std::uint32_t> rankStart, rankX, halfSlot, tailStart;
  std::vector<std::uint8_t> tailSlot;
  std::vector<double, CacheLineAllocator<double>> rankK, rankRest;
  std::vector<std::uint8_t> slotVertex, vertexSlot, extraGroup;
  std::size_t maxOut = 0;  // most springs at one vertex
  bool forceZero = false;  // f is all zero (the symplectic step leaves it so)
  WorkerSlot worker;
  std::vector<double> invMass;  // 0 for deleted vertices (they never move)
  std::vector<double> mass;
  // Scratch (kept to avoid allocations per step).
  std::vector<Eigen::Vector3d> f, f2, xb, vb, k1x, k1v, k2x, k2v, k3x, k3v, k4x, k4v, xt, vt;
  std::vector<Eigen::Vector3d> scatter;  // zero between sweeps (forces of finished vertices)
  // The added springs' forces for the symplectic step and the force pass's
  // accumulator, 4 doubles a vertex (x, y, z, unused: one 4-wide update per spring
  // end); zero between steps.
  std::vector<double> f4, scatter4;
  std::vector<double> groupMove2;  // the symplectic step's bound per vertex group (Dynamics::groupMoves2)
  std::vector<double> groupTravel;                                         // the bounds summed (Dynamics::groupTravel)
  std::uint64_t travelLayout = std::numeric_limits<std::uint64_t>::max();  // the mesh layout it is for
  std::vector<std::uint32_t> groupsPast;                                   // Dynamics::groupsPastLimit
  std::vector<std::vector<std::uint32_t>> pastChunks;  // step scratch: groupsPast per chunk of the step
  std::vector<double> lambda;  // xpbd multipliers (springs)
  std::uint64_t rebuilds = 0;
  std::uint64_t localUpdates = 0;
};
struct ActiveSet {
  std::vector<std::uint8_t> awake;  // 0 asleep, 1 awake, 2 fell asleep this step
  std::vector<std::uint16_t> quiet;
  std::vector<std::uint32_t> list;                                      // awake vertices (kept between steps)
  std::vector<std::uint32_t> moved;                                     // vertices the last active step integrated
  std::uint64_t movedStep = std::numeric_limits<std::uint64_t>::max();  // Dynamics::steps after it
  std::vector<std::uint32_t> pending;                                   // named by wake(), woken at the next step
  std::vector<std::uint8_t> loud;                                       // step scratch
  std::vector<std::uint32_t> csrStart, csrSpring;                       // vertex → incident springs
  // Springs the cache added after the CSR above was built: (vertex, spring) pairs,
  // sorted by vertex (a cut adds a handful at a time).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> added;
  std::vector<std::uint8_t> hasAdded;  // per vertex: it has pairs in `added`
  // What the set was last brought up to: the cache's rebuild count and spring count,
  // the mesh's layout and journal sizes. A topology edit in place wakes only what it
  // touched; a new layout (indices renumbered) starts with every vertex awake.
  std::uint64_t rebuilds = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t layoutVersion = std::numeric_limits<std::uint64_t>::max();
  std::size_t springsSeen = 0, journalV = 0, journalE = 0, journalF = 0;
  std::uint64_t restarts = 0;           // times every vertex was woken (layout changes)
  std::vector<Eigen::Vector3d> x0, v0;  // the listed vertices at the step's start (for a fallback)
};
}  // namespace detail

// The solver's state apart from the mesh it moves.
struct Dynamics {
  double time = 0.0;
  std::uint64_t steps = 0;
  StabilityLog stability;
  int stickySubsteps = 1;
  int stickyLeft = 0;
  // The monitor's energy budget [mJ]: the energy the tissue may have, raised only by
  // external work and relaxing toward the current energy. NaN = take the next state's.
  double energyBudget = std::numeric_limits<double>::quiet_NaN();
  detail::Cache cache;
  detail::ActiveSet active;
  // After step(): a bound on how far any vertex moved in it, per coordinate [mm] (for
  // a collision tree with fat boxes: TriangleBvh::refitMoved). +inf when unknown (a
  // method other than symplectic Euler, the monitor off, substeps, a fallback, the
  // active-region step, rawStep).
  double maxMove = std::numeric_limits<double>::infinity();
  // After step() with Params::groupMoves, when maxMove is finite: per group of
  // kMoveGroup consecutive vertices (vertex v in group v / kMoveGroup), the square of a
  // bound on how far any of them moved in it, per coordinate [mm²], as maxMove up to
  // the rounding of x + dx (what groupTravel sums). Empty without Params::groupMoves or
  // when maxMove is not finite.
  static constexpr std::size_t kMoveGroup = 16;
  [[nodiscard]] std::span<const double> groupMoves2() const {
    if (!std::isfinite(maxMove)) return {};
    return cache.groupMove2;
  }

  // With Params::groupMoves and a finite Params::travelLimit: per group (as above), a
  // bound on how far (per coordinate) any of its vertices moved since the consumer last
  // lowered the entry: the steps' bounds summed (a rejected attempt's too), plus
  // Params::travelPad a step. Entries of new groups start at 0; after the vertices were
  // renumbered (a new layoutVersion()) every entry is +inf. Holds the moves of the steps
  // whose maxMove was finite; a step that moved vertices otherwise (maxMove +inf) is not
  // in it, so a consumer must then check the vertices another way.
  [[nodiscard]] std::span<double> groupTravel() { return cache.groupTravel; }
  // The groups whose travel went past Params::travelLimit (or is not a number) in a
  // step since clearGroupsPastLimit(), in order, possibly repeated.
  [[nodiscard]] std::span<const std::uint32_t> groupsPastLimit() const { return cache.groupsPast; }
  void clearGroupsPastLimit() { cache.groupsPast.clear(); }

  // Call after changing masses, rest lengths or stiffnesses without a topology edit.
  void invalidate() {
    cache.topologyVersion = std::numeric_limits<std::uint64_t>::max();
    cache.layoutVersion = std::numeric_limits<std::uint64_t>::max();
    energyBudget = std::numeric_limits<double>::quiet_NaN();
  }
};

struct State : Dynamics {
  mesh::SurfaceMesh mesh;  // positions and tissue properties
};

// Builds a state from a mesh; attaches the tissue properties when they are missing.
[[nodiscard]] State makeState(mesh::SurfaceMesh m, const TissueParams& p);

struct StepInfo {
  bool accepted = true;  // first attempt passed the monitor
  int substeps = 1;
  bool implicitFallback = false;
  std::size_t activeVertices = 0;  // vertices integrated (all, unless active-region mode)
};

// Advances the state by dt with params.method, under the stability monitor.
// The state never receives a non-finite value.
StepInfo step(const Params& params, State& state, double dt);
// The same on a mesh owned elsewhere (in place; the mesh needs the tissue properties).
StepInfo step(const Params& params, Dynamics& dynamics, mesh::SurfaceMesh& mesh, double dt);

// Active-region mode: the vertices a contact touches (external force set) wake at the
// next step and stay awake while their force is not zero. Needed with
// ActiveRegionOptions::scanExternalForces off; the names wait for the next active step.
void wake(Dynamics& dynamics, std::span<const mesh::Vertex> vertices);

// The vertices (indices) the last step moved, for a collision tree's local refit: in
// active-region mode the vertices that step integrated (those that fell asleep in it
// included); nullopt when every vertex may have moved (a full step, or none yet).
[[nodiscard]] std::optional<std::span<const std::uint32_t>> movedVertices(const Dynamics& dynamics);

// One raw step of `method` without the monitor (for analysis; may diverge).
// Returns false when the result is not finite (the state is still updated).
bool rawStep(const Params& params, State& state, Method method, double dt);
bool rawStep(const Params& params, Dynamics& dynamics, mesh::SurfaceMesh& mesh, Method method, double dt);

// The queries below refresh the dynamics' cache (derived data) when it is stale.
[[nodiscard]] Energy energy(const Params& params, const State& state);
[[nodiscard]] Energy energy(const Params& params, const Dynamics& dynamics, const mesh::SurfaceMesh& mesh);
// Largest norm of the net static force (springs, home, gravity, external) on a vertex.
[[nodiscard]] double maxResidualForce(const Params& params, const State& state);
[[nodiscard]] double maxResidualForce(const Params& params, const Dynamics& dynamics, const mesh::SurfaceMesh& mesh);
// Net force on every vertex slot (damping included), for tests and the oracle.
[[nodiscard]] std::vector<Eigen::Vector3d> forces(const Params& params, const State& state);
[[nodiscard]] std::vector<Eigen::Vector3d> forces(const Params& params, const Dynamics& dynamics,
                                                  const mesh::SurfaceMesh& mesh);

struct SettleOptions {
  double dt = 1e-3;
  double tolerance = 1e-3;       // [mN] residual force at which the tissue counts as settled
  double speedTolerance = 0.01;  // [mm/s] and no vertex faster than this
  double maxTime = 20.0;         // [s] simulated
  int checkEvery = 10;           // steps between residual checks
  // progress in [0, 1] (estimated from the residual's decay) and the residual.
  std::function<void(double progress, double residual)> progress;
  std::function<bool()> cancel;  // checked with the residual; true ends settling
};
struct SettleResult {
  bool converged = false;
  std::uint64_t steps = 0;
  double time = 0.0;
  double residual = 0.0;
};
// Runs the dynamics until the residual force falls under the tolerance, then zeroes
// the velocities (the thesis's start positions).
SettleResult settle(const Params& params, State& state, const SettleOptions& opt = {});
SettleResult settle(const Params& params, Dynamics& dynamics, mesh::SurfaceMesh& mesh, const SettleOptions& opt = {});

// True when every position and velocity is finite.
[[nodiscard]] bool isFinite(const State& state);
[[nodiscard]] bool isFinite(const mesh::SurfaceMesh& mesh);

// Sets flush-to-zero and denormals-are-zero for this thread while alive.
class FlushDenormals {
 public:
  FlushDenormals();
  ~FlushDenormals();
  FlushDenormals(const FlushDenormals&) = delete;
  FlushDenormals& operator=(const FlushDenormals&) = delete;

 private:
  unsigned saved_ = 0;
};

}  // namespace ld::physics
