#include "sim/physics/experiments.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <numbers>
#include <sstream>

#include "sim/physics/physics_error.h"
#include "sim/physics/scenes.h"

namespace ld::physics {

using Vec3 = Eigen::Vector3d;

namespace {

// Settles a fresh state (implicit Euler: the equilibrium does not depend on the
// method, and it is stable on sliver meshes too), then pushes the top centre 5 mm down.
void settleAndPush(Scene& s) {
  Params settleParams = s.params;
  settleParams.method = Method::ImplicitEuler;
  SettleOptions so;
  so.dt = 5e-3;
  so.tolerance = 1e-4;
  so.speedTolerance = 1e-3;
  so.maxTime = 10.0;
  settle(settleParams, s.initial, so);
  s.pushed = topCentreVertex(s.initial.mesh);
  if (s.pushed.isValid()) s.initial.mesh.position(s.pushed).z() -= 5.0;
  s.initial.stability = {};
  s.initial.time = 0;
  s.initial.steps = 0;
}

}  // namespace

bool isBuiltinScene(const std::string& name) {
  return name == "oscillator" || name == "patch-release" || name == "sliver";
}

Scene builtinScene(const std::string& name, double scale) {
  Scene s;
  s.name = name;
  if (name == "oscillator") {
    s.analytic = true;
    s.omega = 2.0 * std::numbers::pi;
    s.damping = 0.5;
    s.x0 = 1.0;
    s.params.tissue.uniformMass = true;
    s.params.tissue.vertexMass = 1.0;
    s.params.tissue.homeK = s.omega * s.omega;
    s.params.tissue.damping = s.damping;
    mesh::SurfaceMesh m;
    m.addVertex(Vec3::Zero());
    s.initial = makeState(std::move(m), s.params.tissue);
    s.initial.mesh.positions()[0] = Vec3(s.x0, 0, 0);
    return s;
  }
  if (name == "patch-release") {
    s.initial = makeState(makeSlab(80, 60, 5, 4.0 * scale), s.params.tissue);
  } else if (name == "sliver") {
    s.initial = makeState(makeSliverSlab(80, 60, 5, 4.0 * scale, 0.05), s.params.tissue);
  } else {
    throw UnknownNameError("unknown scene '" + name + "' (oscillator, patch-release, sliver, or a model file)");
  }
  settleAndPush(s);
  return s;
}

Scene sceneFromMesh(mesh::SurfaceMesh m, const std::string& name) {
  Scene s;
  s.name = name;
  s.initial = makeState(std::move(m), s.params.tissue);
  settleAndPush(s);
  return s;
}

namespace {

double sceneEnergy(const Scene& s, const State& st) { return energy(s.params, st).total(); }

int stepsPer(double interval, double dt) { return std::max(1, static_cast<int>(std::lround(interval / dt))); }

}  // namespace

Trajectory runScene(const Scene& sc, Method method, double dt, double duration, int checkpoints, bool monitor,
                    BenchResult* result) {
  Params p = sc.params;
  p.method = method;
  p.stability.enabled = monitor;
  State st = sc.initial;
  const int per = stepsPer(duration / checkpoints, dt);
  const double e0 = sceneEnergy(sc, st);
  Trajectory out;
  std::uint64_t steps = 0;
  double cpu = 0;  // CPU time of this process: robust on a shared machine
  bool stable = true;
  for (int c = 0; c < checkpoints; ++c) {
    if (stable) {
      const std::clock_t c0 = std::clock();
      for (int k = 0; k < per; ++k) {
        if (monitor)
          step(p, st, dt);
        else
          rawStep(p, st, method, dt);
      }
      cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
      steps += static_cast<std::uint64_t>(per);
      stable = isFinite(st) && sceneEnergy(sc, st) <= 1.5 * e0 + 1e-12;
    }
    out.push_back(stable ? st.mesh.positions()
                         : std::vector<Vec3>(st.mesh.positions().size(),
                                             Vec3::Constant(std::numeric_limits<double>::quiet_NaN())));
  }
  if (result) {
    // Short stable runs are repeated until 5 ms of CPU time have been measured.
    std::uint64_t timed = steps;
    while (stable && cpu < 5e-3 && steps > 0) {
      State again = sc.initial;
      const std::clock_t c0 = std::clock();
      for (std::uint64_t k = 0; k < steps; ++k) {
        if (monitor)
          step(p, again, dt);
        else
          rawStep(p, again, method, dt);
      }
      cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
      timed += steps;
    }
    result->usPerStep = timed ? 1e6 * cpu / static_cast<double>(timed) : 0.0;
    result->scene = sc.name;
    result->method = method;
    result->dt = dt;
    result->duration = duration;
    result->steps = steps;
    result->stable = stable;
    result->warnings = st.stability.warnings;
    result->vertices = st.mesh.nVertices();
    result->triangles = st.mesh.nFaces();
  }
  return out;
}

Trajectory referenceTrajectory(const Scene& sc, double dtRef, double duration, int checkpoints) {
  if (!sc.analytic) return runScene(sc, Method::Rk4, dtRef, duration, checkpoints, false, nullptr);
  Trajectory out;
  const double c = sc.damping, w0 = sc.omega;
  const double wd = std::sqrt(w0 * w0 - 0.25 * c * c);
  for (int k = 1; k <= checkpoints; ++k) {
    const double t = duration * k / checkpoints;
    const double x = sc.x0 * std::exp(-0.5 * c * t) * (std::cos(wd * t) + 0.5 * c / wd * std::sin(wd * t));
    out.push_back({Vec3(x, 0, 0)});
  }
  return out;
}

void compareTrajectories(const Trajectory& run, const Trajectory& ref, BenchResult& r) {
  double sum = 0, mx = 0;
  std::size_t n = 0;
  for (std::size_t c = 0; c < run.size() && c < ref.size(); ++c)
    for (std::size_t i = 0; i < run[c].size() && i < ref[c].size(); ++i) {
      const double d = (run[c][i] - ref[c][i]).norm();
      if (!std::isfinite(d)) {
        r.errorRms = r.errorMax = std::numeric_limits<double>::infinity();
        return;
      }
      sum += d * d;
      mx = std::max(mx, d);
      ++n;
    }
  r.errorRms = n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
  r.errorMax = mx;
}

BenchResult benchScene(const Scene& s, Method method, double dt, double duration, bool monitor) {
  if (!(dt > 0) || !(duration >= dt)) throw PhysicsError("bench: need dt > 0 and duration >= dt");
  // Checkpoints on common steps of the run and of the reference (dt/64).
  const int total = stepsPer(duration, dt);
  const int checkpoints = std::clamp(total, 1, 20);
  const double span = dt * (total / checkpoints) * checkpoints;
  BenchResult r;
  const Trajectory run = runScene(s, method, dt, span, checkpoints, monitor, &r);
  const Trajectory ref = referenceTrajectory(s, dt / 64.0, span, checkpoints);
  compareTrajectories(run, ref, r);
  r.stable = r.stable && std::isfinite(r.errorMax);
  return r;
}

ActiveComparison compareActiveRegion(const Scene& sc, double dt, double duration) {
  ActiveComparison out;
  State full = sc.initial;
  const auto v = sc.pushed;
  if (!v.isValid()) return out;
  full.mesh.position(v).z() += 5.0;  // undo the scene's push: start settled
  State act = full;
  Params pf = sc.params;
  pf.method = Method::SymplecticEuler;
  Params pa = pf;
  pa.active.enabled = true;
  const auto n = static_cast<std::uint64_t>(std::lround(duration / dt));
  double cpuFull = 0, cpuActive = 0, worked = 0, total = 0;
  for (std::uint64_t k = 0; k < n; ++k) {
    const Vec3 f = k < n / 2 ? Vec3(0, 0, -5.0) : Vec3::Zero();
    full.mesh.getVertexProperty<Vec3>(kForceProp)[v] = f;
    act.mesh.getVertexProperty<Vec3>(kForceProp)[v] = f;
    std::clock_t c0 = std::clock();
    step(pf, full, dt);
    std::clock_t c1 = std::clock();
    worked += static_cast<double>(step(pa, act, dt).activeVertices);
    std::clock_t c2 = std::clock();
    cpuFull += static_cast<double>(c1 - c0);
    cpuActive += static_cast<double>(c2 - c1);
    total += static_cast<double>(act.mesh.nVertices());
    const auto& a = full.mesh.positions();
    const auto& b = act.mesh.positions();
    for (std::size_t i = 0; i < a.size(); ++i) out.maxDifference = std::max(out.maxDifference, (a[i] - b[i]).norm());
  }
  out.steps = n;
  out.workFraction = total > 0 ? worked / total : 1.0;
  if (n > 0) {
    out.usPerStepFull = 1e6 * cpuFull / CLOCKS_PER_SEC / static_cast<double>(n);
    out.usPerStepActive = 1e6 * cpuActive / CLOCKS_PER_SEC / static_cast<double>(n);
  }
  return out;
}

namespace {

bool stableAt(const Scene& s, Method method, double dt, int steps) {
  Params p = s.params;
  p.method = method;
  p.stability.enabled = false;
  State st = s.initial;
  const double e0 = sceneEnergy(s, st);
  for (int k = 1; k <= steps; ++k) {
    if (!rawStep(p, st, method, dt)) return false;
    if ((k % 10 == 0 || k == steps) && !(sceneEnergy(s, st) <= 1.5 * e0 + 1e-12)) return false;
  }
  return true;
}

}  // namespace

double largestStableDt(const Scene& s, Method method, double lo, double hi, int steps, int iterations, bool* capped) {
  if (capped) *capped = false;
  if (stableAt(s, method, hi, steps)) {
    if (capped) *capped = true;
    return hi;
  }
  if (!stableAt(s, method, lo, steps)) return lo;
  for (int i = 0; i < iterations; ++i) {
    const double mid = std::sqrt(lo * hi);
    (stableAt(s, method, mid, steps) ? lo : hi) = mid;
  }
  return lo;
}

std::vector<BenchResult> speedAccuracySweep(const Progress& progress) {
  std::vector<BenchResult> rows;
  const std::vector<double> ladder{1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1, 2, 4, 8};  // ms
  for (const std::string name : {"oscillator", "patch-release", "sliver"}) {
    const Scene s = builtinScene(name, name == "oscillator" ? 1.0 : 2.0);
    const double duration = s.analytic ? 2.048 : 0.128;
    const int checkpoints = 16;
    const Trajectory ref = referenceTrajectory(s, 1e-3 / 128, duration, checkpoints);
    for (Method m : allMethods())
      for (double ms : ladder) {
        BenchResult r;
        const Trajectory run = runScene(s, m, ms * 1e-3, duration, checkpoints, false, &r);
        compareTrajectories(run, ref, r);
        r.stable = r.stable && std::isfinite(r.errorMax);
        rows.push_back(r);
        if (progress) {
          std::ostringstream os;
          os << name << " " << methodName(m) << " dt=" << ms << "ms err=" << r.errorRms
             << (r.stable ? "" : " unstable");
          progress(os.str());
        }
      }
  }
  return rows;
}

std::vector<StabilityRow> stabilitySweep(const Progress& progress) {
  std::vector<StabilityRow> rows;
  const double lo = 1e-6, hi = 0.05;
  const int steps = 300, iterations = 14;
  auto run = [&](const std::string& sweep, double x, const Scene& s) {
    for (Method m : allMethods()) {
      StabilityRow r;
      r.sweep = sweep;
      r.x = x;
      r.method = m;
      r.largestStableDt = largestStableDt(s, m, lo, hi, steps, iterations, &r.capped);
      rows.push_back(r);
      if (progress) {
        std::ostringstream os;
        os << sweep << " " << x << " " << methodName(m) << " dt_max=" << r.largestStableDt << (r.capped ? "+" : "");
        progress(os.str());
      }
    }
  };
  for (double K : {1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0}) {
    Scene s;
    s.name = "stiffness";
    s.params.tissue.K = K;
    s.initial = makeState(makeGrid(8, 8, 4.0), s.params.tissue);
    s.initial.mesh.position(nearestVertex(s.initial.mesh, Vec3(16, 16, 0))).z() -= 2.0;
    run("stiffness", K, s);
  }
  for (double w : {2.0, 1.0, 0.5, 0.2, 0.1, 0.05, 0.02}) {
    Scene s;
    s.name = "min_edge";
    s.initial = makeState(makeSliverSlab(24, 16, 4, 4, w), s.params.tissue);
    double minEdge = std::numeric_limits<double>::infinity();
    for (auto e : s.initial.mesh.edges()) minEdge = std::min(minEdge, s.initial.mesh.edgeLength(e));
    s.initial.mesh.position(topCentreVertex(s.initial.mesh)).z() -= 2.0;
    run("min_edge", minEdge, s);
  }
  return rows;
}

}  // namespace ld::physics
