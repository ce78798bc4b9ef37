#include "sim/physics/mass_spring.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
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

namespace ld::physics {

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
  }
  return "?";
}

Method methodFromName(std::string_view name) {
  for (Method m : kMethods)
    if (methodName(m) == name) return m;
  std::string all;
  for (Method m : kMethods) all += (all.empty() ? "" : ", ") + std::string(methodName(m));
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

// Runs one job at a time on its own thread. The handoff spins briefly (a step is
// shorter than a wake-up from sleep) and then sleeps on the atomic, so an idle
// worker costs nothing.
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
    go_.fetch_add(1, std::memory_order_release);
    go_.notify_one();
  }
  void wait() {
    const std::uint32_t target = go_.load(std::memory_order_relaxed);
    for (int i = 0; i < 20000; ++i)
      if (done_.load(std::memory_order_acquire) == target) return;
    for (std::uint32_t d = done_.load(std::memory_order_acquire); d != target;
         d = done_.load(std::memory_order_acquire))
      done_.wait(d);
  }

 private:
  void loop() {
    std::uint32_t seen = 0;
    for (;;) {
      std::uint32_t g = go_.load(std::memory_order_acquire);
      for (int i = 0; i < 20000 && g == seen; ++i) g = go_.load(std::memory_order_acquire);
      while (g == seen) {
        go_.wait(seen);
        g = go_.load(std::memory_order_acquire);
      }
      seen = g;
      if (quit_.load()) return;
      {
        FlushDenormals ftz;
        fn_(ctx_);
      }
      done_.store(seen, std::memory_order_release);
      done_.notify_one();
    }
  }
  void (*fn_)(void*) = nullptr;
  void* ctx_ = nullptr;
  std::atomic<std::uint32_t> go_{0}, done_{0};
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

namespace {

struct View {
  const Spring* springs = nullptr;
  std::size_t nSprings = 0;
  std::size_t n = 0;
  const Vec3* home = nullptr;
  const Vec3* ext = nullptr;
  const double* invMass = nullptr;
  const double* mass = nullptr;
  double homeK = 0, c = 0;
  Vec3 g = Vec3::Zero();
};

template <class T>
mesh::VertexProperty<T> requireV(const mesh::SurfaceMesh& m, const char* name) {
  auto p = m.getVertexProperty<T>(name);
  if (!p) throw MissingPropertyError(name);
  return p;
}

// Returns true when the cache was rebuilt.
bool ensureCache(Dynamics& s, const mesh::SurfaceMesh& m) {
  Cache& c = s.cache;
  if (c.topologyVersion == m.topologyVersion() && c.nVertexSlots == m.verticesSize()) return false;
  if (!hasTissueProperties(m)) throw MissingPropertyError(kHomeProp);
  const auto rest = m.getEdgeProperty<double>(kRestProp);
  const auto k = m.getEdgeProperty<double>(kStiffnessProp);
  const auto mass = m.getVertexProperty<double>(kMassProp);
  c.springs.clear();
  c.springs.reserve(m.nEdges());
  for (mesh::Edge e : m.edges()) c.springs.push_back({m.vertex(e, 0).idx(), m.vertex(e, 1).idx(), rest[e], k[e]});
  const std::size_t n = m.verticesSize();
  c.nVertexSlots = n;
  c.invMass.assign(n, 0.0);
  c.mass.assign(n, 0.0);
  for (mesh::Vertex v : m.vertices()) {
    c.mass[v.idx()] = mass[v];
    c.invMass[v.idx()] = mass[v] > 0 ? 1.0 / mass[v] : 0.0;
  }
  for (auto* buf : {&c.f, &c.f2, &c.xb, &c.vb}) buf->assign(n, Vec3::Zero());
  c.forceZero = true;
  c.topologyVersion = m.topologyVersion();
  ++c.rebuilds;
  s.energyBudget = std::numeric_limits<double>::quiet_NaN();  // cuts change the energy
  return true;
}

// Massless (deleted) vertices never move.
void zeroMasslessVelocities(const Cache& c, mesh::SurfaceMesh& m) {
  auto& v = m.getVertexProperty<Vec3>(kVelocityProp).vector();
  for (std::size_t i = 0; i < c.nVertexSlots && i < v.size(); ++i)
    if (c.invMass[i] == 0.0) v[i].setZero();
}

// The cache of a step's dynamics, refreshed for this mesh.
void prepare(Dynamics& d, mesh::SurfaceMesh& m) {
  if (ensureCache(d, m)) zeroMasslessVelocities(d.cache, m);
}

View makeView(const Params& p, const Dynamics& s, const mesh::SurfaceMesh& m) {
  const Cache& c = s.cache;
  View w;
  w.springs = c.springs.data();
  w.nSprings = c.springs.size();
  w.n = c.nVertexSlots;
  w.home = m.getVertexProperty<Vec3>(kHomeProp).vector().data();
  w.ext = m.getVertexProperty<Vec3>(kForceProp).vector().data();
  w.invMass = c.invMass.data();
  w.mass = c.mass.data();
  w.homeK = p.tissue.homeK;
  w.c = p.tissue.damping;
  w.g = p.tissue.gravity;
  return w;
}

// Spring forces of springs [begin, end) scattered into f; returns their energy.
// Springs are sorted by their first vertex, so the first vertex's force is summed in
// registers and stored once per run (no store-to-load chain through f[i]).
double springRange(const View& w, const Vec3* x, Vec3* f, std::size_t begin, std::size_t end) {
  double pe = 0.0;
  std::size_t s = begin;
  while (s < end) {
    const std::uint32_t i = w.springs[s].i;
    const Vec3 xi = x[i];
    Vec3 acc = Vec3::Zero();
    for (; s < end && w.springs[s].i == i; ++s) {
      const Spring& sp = w.springs[s];
      const Vec3 d = x[sp.j] - xi;
      const double l = d.norm();
      const double stretch = l - sp.rest;
      pe += 0.5 * sp.k * stretch * stretch;
      if (l > 0.0) {
        const Vec3 fi = (sp.k * stretch / l) * d;
        acc += fi;
        f[sp.j] -= fi;
      }
    }
    f[i] += acc;
  }
  return pe;
}

// All spring forces scattered into f (which must be zeroed); returns their energy.
double springForces(const View& w, const Vec3* x, Vec3* f) { return springRange(w, x, f, 0, w.nSprings); }

// Full force (damping with v unless v is null); returns spring + home energy.
double totalForces(const View& w, const Vec3* x, const Vec3* v, Vec3* f) {
  for (std::size_t i = 0; i < w.n; ++i) f[i].setZero();
  double pe = springForces(w, x, f);
  for (std::size_t i = 0; i < w.n; ++i) {
    if (w.invMass[i] == 0.0) {
      f[i].setZero();
      continue;
    }
    const Vec3 dh = x[i] - w.home[i];
    pe += 0.5 * w.homeK * dh.squaredNorm();
    f[i] += w.ext[i] + w.mass[i] * w.g - w.homeK * dh;
    if (v) f[i] -= (w.c * w.mass[i]) * v[i];
  }
  return pe;
}

// Spring and home energy at x (no forces).
double potential(const View& w, const Vec3* x) {
  double pe = 0.0;
  for (std::size_t s = 0; s < w.nSprings; ++s) {
    const Spring& sp = w.springs[s];
    const double stretch = (x[sp.j] - x[sp.i]).norm() - sp.rest;
    pe += 0.5 * sp.k * stretch * stretch;
  }
  for (std::size_t i = 0; i < w.n; ++i)
    if (w.invMass[i] != 0.0) pe += 0.5 * w.homeK * (x[i] - w.home[i]).squaredNorm();
  return pe;
}

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
  const double pe = totalForces(w, x0, v0, c.f.data());
  for (std::size_t i = 0; i < w.n; ++i) {
    x1[i] = x0[i] + dt * v0[i];
    v1[i] = v0[i] + (dt * w.invMass[i]) * c.f[i];
  }
  return {pe, kinetic(w, v0)};
}

// The symplectic step's vertex pass over [begin, end): consumes f (and zeroes it for
// the next step), returns the home energy and the kinetic energy at v0.
E0 symplecticVertices(const View& w, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, Vec3* f, double dt,
                      std::size_t begin, std::size_t end) {
  double pe = 0.0, ke = 0.0;
  const double damp = 1.0 - dt * w.c;
  for (std::size_t i = begin; i < end; ++i) {
    const double im = w.invMass[i];
    const Vec3 dh = x0[i] - w.home[i];
    pe += 0.5 * w.homeK * dh.squaredNorm();
    ke += 0.5 * w.mass[i] * v0[i].squaredNorm();
    if (im == 0.0) {
      x1[i] = x0[i];
      v1[i].setZero();
    } else {
      const Vec3 a = im * (f[i] + w.ext[i] - w.homeK * dh) + w.g;
      v1[i] = damp * v0[i] + dt * a;
      x1[i] = x0[i] + dt * v1[i];
    }
    f[i].setZero();
  }
  return {pe, ke};
}

struct SymplecticJob {
  const View* w;
  const Vec3 *x0, *v0;
  Vec3 *x1, *v1, *f;
  double dt;
  std::size_t sBegin, sEnd, vBegin, vEnd;
  int phase;
  double pe, ke;
  static void run(void* p) {
    auto* j = static_cast<SymplecticJob*>(p);
    if (j->phase == 0) {
      j->pe = springRange(*j->w, j->x0, j->f, j->sBegin, j->sEnd);
    } else {
      const E0 e = symplecticVertices(*j->w, j->x0, j->v0, j->x1, j->v1, j->f, j->dt, j->vBegin, j->vEnd);
      j->pe = e.pe;
      j->ke = e.ke;
    }
  }
};

E0 symplecticEuler(const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt,
                   int threads) {
  Vec3* f = c.f.data();
  if (!c.forceZero)
    for (std::size_t i = 0; i < w.n; ++i) f[i].setZero();
  E0 e;
  if (threads < 2 || w.n < 2048) {
    e.pe = springRange(w, x0, f, 0, w.nSprings);
    const E0 ev = symplecticVertices(w, x0, v0, x1, v1, f, dt, 0, w.n);
    e.pe += ev.pe;
    e.ke = ev.ke;
  } else {
    // Phase 0: the two spring groups in parallel (they touch disjoint vertices), then
    // the crossing springs here; phase 1: the two vertex halves in parallel.
    detail::Worker& worker = c.worker.get();
    SymplecticJob job{&w, x0, v0, x1, v1, f, dt, c.splitA, c.splitB, c.splitVertex, w.n, 0, 0.0, 0.0};
    worker.start(&SymplecticJob::run, &job);
    e.pe = springRange(w, x0, f, 0, c.splitA);
    worker.wait();
    e.pe += job.pe + springRange(w, x0, f, c.splitB, w.nSprings);
    job.phase = 1;
    worker.start(&SymplecticJob::run, &job);
    const E0 ev = symplecticVertices(w, x0, v0, x1, v1, f, dt, 0, c.splitVertex);
    worker.wait();
    e.pe += ev.pe + job.pe;
    e.ke = ev.ke + job.ke;
  }
  c.forceZero = true;
  return e;
}

E0 verlet(const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1, double dt) {
  c.forceZero = false;
  const E0 e0{totalForces(w, x0, v0, c.f.data()), kinetic(w, v0)};
  for (std::size_t i = 0; i < w.n; ++i) {
    v1[i] = v0[i] + (0.5 * dt * w.invMass[i]) * c.f[i];  // half kick (v1 holds v_half)
    x1[i] = x0[i] + dt * v1[i];
  }
  totalForces(w, x1, nullptr, c.f2.data());
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
    const double pe = totalForces(w, x, v, c.f.data());
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
  const E0 e0{totalForces(w, x0, v0, c.f.data()), kinetic(w, v0)};
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

E0 integrate(Method m, const Params& p, const View& w, Cache& c, const Vec3* x0, const Vec3* v0, Vec3* x1, Vec3* v1,
             double dt) {
  switch (m) {
    case Method::ExplicitEuler:
      return explicitEuler(w, c, x0, v0, x1, v1, dt);
    case Method::SymplecticEuler:
      return symplecticEuler(w, c, x0, v0, x1, v1, dt, p.threads);
    case Method::Verlet:
      return verlet(w, c, x0, v0, x1, v1, dt);
    case Method::Rk4:
      return rk4(w, c, x0, v0, x1, v1, dt);
    case Method::ImplicitEuler:
      return implicitEuler(p, w, c, x0, v0, x1, v1, dt);
  }
  return {};
}

std::vector<Vec3>& velocities(mesh::SurfaceMesh& m) { return requireV<Vec3>(m, kVelocityProp).vector(); }

// Runs `substeps` monitored substeps of m from the state into (xb, vb); on success
// updates *budget.
bool attemptSubsteps(Method m, const Params& p, const View& w, Dynamics& s, mesh::SurfaceMesh& mesh, double dt,
                     int substeps, double* budget, const char** reason) {
  Cache& c = s.cache;
  const double h = dt / substeps;
  std::vector<Vec3> xs(mesh.positions()), vs(velocities(mesh));  // start copy; retries are rare
  double b = *budget;
  for (int k = 0; k < substeps; ++k) {
    const E0 e0 = integrate(m, p, w, c, xs.data(), vs.data(), c.xb.data(), c.vb.data(), h);
    const Check chk = checkStep(p.stability, w, xs.data(), c.xb.data(), c.vb.data(), e0, b);
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
  integrate(method, params, w, c, mesh.positions().data(), velocities(mesh).data(), c.xb.data(), c.vb.data(), dt);
  commit(state, mesh);
  state.time += dt;
  ++state.steps;
  return isFinite(mesh);
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
  if (sticky == 1) {
    const E0 e0 =
        integrate(m, params, w, c, mesh.positions().data(), velocities(mesh).data(), c.xb.data(), c.vb.data(), dt);
    const Check chk = checkStep(params.stability, w, mesh.positions().data(), c.xb.data(), c.vb.data(), e0, budget);
    ok = chk.ok;
    if (ok) budget = nextBudget(params.stability, budget, chk, e0, dt);
    reason = chk.reason;
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
  return info;
}

Energy energy(const Params& params, const State& state) { return energy(params, state, state.mesh); }

Energy energy(const Params& params, const Dynamics& state, const mesh::SurfaceMesh& mesh) {
  Dynamics& s = const_cast<Dynamics&>(state);  // the cache is derived data
  ensureCache(s, mesh);
  const View w = makeView(params, s, mesh);
  std::vector<Vec3> f(w.n, Vec3::Zero());
  Energy e;
  const auto& x = mesh.positions();
  e.spring = springForces(w, x.data(), f.data());
  for (std::size_t i = 0; i < w.n; ++i)
    if (w.invMass[i] != 0.0) e.home += 0.5 * w.homeK * (x[i] - w.home[i]).squaredNorm();
  e.kinetic = kinetic(w, mesh.getVertexProperty<Vec3>(kVelocityProp).vector().data());
  return e;
}

std::vector<Vec3> forces(const Params& params, const State& state) { return forces(params, state, state.mesh); }

std::vector<Vec3> forces(const Params& params, const Dynamics& state, const mesh::SurfaceMesh& mesh) {
  Dynamics& s = const_cast<Dynamics&>(state);
  ensureCache(s, mesh);
  const View w = makeView(params, s, mesh);
  std::vector<Vec3> f(w.n);
  totalForces(w, mesh.positions().data(), mesh.getVertexProperty<Vec3>(kVelocityProp).vector().data(), f.data());
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
  totalForces(w, mesh.positions().data(), nullptr, f.data());
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
