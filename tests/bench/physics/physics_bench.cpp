// Step cost of each integrator on slabs of 1k, 10k, 100k and 1M triangles (time per
// step and ns per spring, CPU time of the stepping thread); the symplectic step on
// one and two threads, with and without the stability monitor, and on each compiled
// kernel path (scalar, AVX2, AVX-512: BM_SymplecticKernel), with the per-spring
// lanes instead of the shared-K ones (BM_SymplecticPerSpringLanes), with sqrt and div
// for the force factor instead of rsqrt and Newton (BM_SymplecticSqrtDiv, and the last
// argument of BM_SymplecticKernel); the symplectic step of
// the default slab before and after ~1000 triangles cut with the CutEngine (stepped
// in place on the engine's mesh); the cost of a topology edit to the physics.
//   physics_bench                                     (all, about a minute)
//   physics_bench --benchmark_filter='Symplectic'     (the targets)
//   physics_bench --benchmark_filter='MonitoredGroups' (the collision tree's inputs)
// xpbd (a sixth method, by name only) at all sizes too.
// 1M triangles: not for implicit Euler (assembling and solving the sparse system takes
// seconds per step there) nor RK4 (four force passes; the 100k figure scales).
#include <benchmark/benchmark.h>

#include <map>
#include <random>

#include "sim/cutting/cutter.h"
#include "sim/io/mesh_io.h"
#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"
#include "sim/physics/spring_kernel.h"
#include "tests/sim/cutting/cut_test_meshes.h"

namespace ld::physics {
namespace {

// Meshes are built once per size (the 1M-triangle one takes a moment).
const State& baseState(int triangles) {
  static std::map<int, State> cache;
  auto it = cache.find(triangles);
  if (it == cache.end()) {
    Params p;
    it = cache.emplace(triangles, makeState(makeSlabWithTriangles(triangles), p.tissue)).first;
  }
  return it->second;
}

// A step small enough to be stable on every size (the finest mesh has the stiffest
// springs), so that the benchmark measures arithmetic, not recovery.
constexpr double kDt = 1e-6;

void perSpring(benchmark::State& bs, const Dynamics& d, const mesh::SurfaceMesh& m) {
  const double springs = static_cast<double>(d.cache.liveSprings);
  bs.counters["triangles"] = static_cast<double>(m.nFaces());
  bs.counters["springs"] = springs;
  // Share of the symplectic step's spring lanes that hold a spring (the rest pad a
  // block of 8 vertices to its rank count, or a vertex's tail ranks).
  if (!d.cache.rankX.empty()) bs.counters["lane_fill"] = 2.0 * springs / static_cast<double>(d.cache.rankX.size());
  bs.counters["ns_per_spring"] =
      benchmark::Counter(springs * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// groups: 1 also the per-group move bounds (Params::groupMoves), 2 also their sums
// against a limit (Params::travelLimit, as `cut --physics on` steps for its collision
// tree; the listed groups are cleared each step as the tree would take them).
void runSteps(benchmark::State& bs, Method m, bool monitor, int threads, int groups = 0) {
  FlushDenormals ftz;
  const int tris = static_cast<int>(bs.range(0));
  State s = baseState(tris);
  Params p;
  p.method = m;
  p.stability.enabled = monitor;
  p.threads = threads;
  p.groupMoves = groups > 0;
  if (groups > 1) {
    p.travelLimit = 0.125;
    p.travelPad = 1e-13;
  }
  step(p, s, kDt);  // builds the cache
  for (auto _ : bs) {
    if (monitor)
      step(p, s, kDt);
    else
      rawStep(p, s, m, kDt);
    s.clearGroupsPastLimit();
    benchmark::ClobberMemory();
  }
  perSpring(bs, s, s.mesh);
}

void BM_ExplicitEuler(benchmark::State& bs) { runSteps(bs, Method::ExplicitEuler, false, 1); }
void BM_Symplectic(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, false, 1); }
void BM_Symplectic2Threads(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, false, 2); }
void BM_SymplecticMonitored(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, true, 1); }
void BM_SymplecticMonitored2Threads(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, true, 2); }
// The monitored step as `cut --physics on` takes it (range(1): 0 plain, 1 with the
// group bounds, 2 with their sums for the collision tree): what the tree's inputs cost.
void BM_SymplecticMonitoredGroups(benchmark::State& bs) {
  runSteps(bs, Method::SymplecticEuler, true, 1, static_cast<int>(bs.range(1)));
}
void BM_Verlet(benchmark::State& bs) { runSteps(bs, Method::Verlet, false, 1); }
void BM_Rk4(benchmark::State& bs) { runSteps(bs, Method::Rk4, false, 1); }
void BM_ImplicitEuler(benchmark::State& bs) { runSteps(bs, Method::ImplicitEuler, false, 1); }
void BM_Xpbd(benchmark::State& bs) { runSteps(bs, Method::Xpbd, false, 1); }  // 4 Gauss–Seidel sweeps

// The symplectic step (no monitor) on each compiled kernel path: range(1) = 0 scalar,
// 1 AVX2+FMA, 2 AVX-512 (skipped where the CPU lacks it); range(2) = threads.
// Arguments: triangles, kernel path (0 scalar, 1 AVX2, 2 AVX-512), threads, force
// factor (0 sqrt and div, 1 rsqrt and Newton; the scalar path always divides).
void BM_SymplecticKernel(benchmark::State& bs) {
  const auto kern = static_cast<detail::Kernel>(bs.range(1));
  if (!detail::forceKernel(kern)) {
    bs.SkipWithError("kernel not supported on this CPU");
    return;
  }
  const auto fac = static_cast<detail::Factor>(bs.range(3));
  detail::forceFactor(fac);
  runSteps(bs, Method::SymplecticEuler, false, static_cast<int>(bs.range(2)));
  detail::forceKernel(std::nullopt);
  detail::forceFactor(std::nullopt);
  bs.SetLabel(std::string(detail::kernelName(kern)) + " " + std::string(detail::factorName(fac)));
}

// The symplectic step (best path, one thread, no monitor) with sqrt and div for the
// force factor instead of rsqrt and Newton steps: BM_Symplectic's comparison.
void BM_SymplecticSqrtDiv(benchmark::State& bs) {
  detail::forceFactor(detail::Factor::SqrtDiv);
  runSteps(bs, Method::SymplecticEuler, false, 1);
  detail::forceFactor(std::nullopt);
}

// The symplectic step (one thread, no monitor) with the per-spring lanes (far end, k,
// rest: 20 bytes) instead of the shared-K ones (12 bytes) the tissue's springs get:
// the layouts side by side (mass_spring.h, LaneLayout).
void BM_SymplecticPerSpringLanes(benchmark::State& bs) {
  detail::forcePerSpringLanes(true);  // the copy in runSteps is a new layout: rebuilt
  runSteps(bs, Method::SymplecticEuler, false, 1);
  detail::forcePerSpringLanes(false);
}

#define LD_SMALL ->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond)->MinTime(0.1)
#define LD_SIZES LD_SMALL->Arg(1000000)
BENCHMARK(BM_Symplectic) LD_SIZES;
BENCHMARK(BM_Symplectic2Threads) LD_SIZES->UseRealTime();
BENCHMARK(BM_SymplecticMonitored) LD_SIZES;
BENCHMARK(BM_SymplecticPerSpringLanes) LD_SIZES;
BENCHMARK(BM_SymplecticMonitored2Threads) LD_SIZES->UseRealTime();
BENCHMARK(BM_SymplecticMonitoredGroups)
    ->ArgsProduct({{10000, 100000}, {0, 1, 2}})
    ->ArgNames({"triangles", "groups"})
    ->Unit(benchmark::kMicrosecond)
    ->MinTime(0.2);
BENCHMARK(BM_SymplecticSqrtDiv) LD_SIZES;
BENCHMARK(BM_SymplecticKernel)
    ->ArgsProduct({{10000, 100000}, {0, 1, 2}, {1, 2}, {0, 1}})
    ->Unit(benchmark::kMicrosecond)
    ->MinTime(0.1)
    ->UseRealTime();
BENCHMARK(BM_ExplicitEuler) LD_SIZES;
BENCHMARK(BM_Verlet) LD_SIZES;
BENCHMARK(BM_Rk4) LD_SMALL;
BENCHMARK(BM_ImplicitEuler) LD_SMALL;
BENCHMARK(BM_Xpbd) LD_SIZES;

// ---- cutting -------------------------------------------------------------------

// The default model (or, triangles > 0, a generated slab of about that many
// triangles placed like it: centred, top face at z = 2.5) with the tissue properties,
// in a CutEngine (which owns it).
struct CutScene {
  cutting::CutEngine engine;
  int id = 0;
  Params params;
  Dynamics dyn;
  long trianglesCut = 0;
  double depth = 2.0;  // of the groove strokes' tip [mm]
  // massFloorDt > 0: selective mass scaling (TissueParams::massFloorDt) for the
  // physics and the cutter's hooks.
  explicit CutScene(double massFloorDt = 0.0, int triangles = 0) : engine(cutParams(massFloorDt)) {
    params.tissue.massFloorDt = massFloorDt;
    mesh::SurfaceMesh m =
        triangles > 0 ? placedSlab(triangles) : io::readMesh(LD_RESOURCES_DIR "/models/tissue_slab.obj");
    attachTissueProperties(m, params.tissue);
    id = engine.addObject(std::move(m));
  }
  mesh::SurfaceMesh placedSlab(int triangles) {
    mesh::SurfaceMesh m = makeSlabWithTriangles(triangles);
    const auto b = m.bounds();
    const Eigen::Vector3d shift(-b.center().x(), -b.center().y(), 2.5 - b.max.z());
    for (auto& x : m.positions()) x += shift;
    depth = std::min(2.0, 0.5 * (b.max.z() - b.min.z()));  // a groove, not a cut through
    return m;
  }
  static cutting::CutParams cutParams(double massFloorDt) {
    cutting::CutParams cp;
    cp.tissue.massFloorDt = massFloorDt;
    return cp;
  }
  mesh::SurfaceMesh& mesh() { return engine.object(id).mesh; }
  // Groove strokes across the top (tip 2 mm deep) until `target` triangles are cut,
  // the physics stepping in place between strokes, as in a session.
  void cut(long target) {
    for (int k = 0; engine.stats().trianglesCut < target && k < 60; ++k) {
      const double y = -27.0 + 1.37 * k;
      const double z = 2.5 - depth;
      cutting::test::stroke(engine, Eigen::Vector3d(-45, y, z), Eigen::Vector3d(45, y + 0.9, z),
                            Eigen::Vector3d(0, 0, -1), 200.0, 1000.0);
      for (int i = 0; i < 5; ++i) step(params, dyn, mesh(), 1e-4);
    }
    trianglesCut = engine.stats().trianglesCut;
  }
};

// range(0): triangles to cut (0 = before); range(1): 1 = rebuild the cache from
// scratch after cutting (otherwise it has followed the edits locally); range(2): 1 =
// with the stability monitor (substeps it needs for new stiff springs show here);
// range(3): 1 = with the mass floor for the 0.1 ms step; range(4): triangles of a
// generated slab (0 = the default model, 10k triangles).
void BM_SymplecticAfterCuts(benchmark::State& bs) {
  FlushDenormals ftz;
  CutScene sc(bs.range(3) == 1 ? 1e-4 : 0.0, static_cast<int>(bs.range(4)));
  step(sc.params, sc.dyn, sc.mesh(), 1e-4);
  sc.cut(bs.range(0));
  if (bs.range(1) == 1) sc.dyn.invalidate();
  step(sc.params, sc.dyn, sc.mesh(), 1e-4);
  const bool monitor = bs.range(2) == 1;
  int substeps = 1;
  for (auto _ : bs) {
    if (monitor)
      substeps = step(sc.params, sc.dyn, sc.mesh(), 1e-4).substeps;
    else
      rawStep(sc.params, sc.dyn, sc.mesh(), Method::SymplecticEuler, 1e-4);
    benchmark::ClobberMemory();
  }
  perSpring(bs, sc.dyn, sc.mesh());
  bs.counters["substeps"] = substeps;
  bs.counters["triangles_cut"] = static_cast<double>(sc.trianglesCut);
  bs.counters["added_springs"] = static_cast<double>(sc.dyn.cache.springs.size() - sc.dyn.cache.nCsr);
  bs.counters["vertices"] = static_cast<double>(sc.mesh().nVertices());
}
BENCHMARK(BM_SymplecticAfterCuts)
    ->Args({0, 0, 0, 0, 0})
    ->Args({1000, 0, 0, 0, 0})
    ->Args({1000, 1, 0, 0, 0})
    ->Args({0, 0, 1, 0, 0})
    ->Args({1000, 0, 1, 0, 0})
    ->Args({0, 0, 1, 1, 0})
    ->Args({1000, 0, 1, 1, 0})
    ->Args({0, 0, 0, 0, 100000})
    ->Args({1000, 0, 0, 0, 100000})
    ->Args({1000, 1, 0, 0, 100000})
    ->Args({0, 0, 1, 1, 100000})
    ->Args({1000, 0, 1, 1, 100000})
    ->Unit(benchmark::kMicrosecond)
    ->MinTime(0.2);

// What a topology edit costs the physics: one edge split with the tissue hooks, then
// a step (the cache follows the edit locally); compare with BM_SymplecticMonitored.
void BM_StepAfterEdgeSplit(benchmark::State& bs) {
  FlushDenormals ftz;
  State s = baseState(static_cast<int>(bs.range(0)));
  Params p;
  step(p, s, kDt);
  std::mt19937 rng(1);
  for (auto _ : bs) {
    bs.PauseTiming();
    mesh::Edge e(static_cast<int>(rng() % s.mesh.edgesSize()));
    while (!s.mesh.isValid(e)) e = mesh::Edge(static_cast<int>(rng() % s.mesh.edgesSize()));
    const auto a = s.mesh.vertex(e, 0), b = s.mesh.vertex(e, 1);
    const auto v = s.mesh.splitEdge(e, 0.5 * (s.mesh.position(a) + s.mesh.position(b)));
    initVertexOnEdge(s.mesh, v, a, b, 0.5, p.tissue);
    bs.ResumeTiming();
    step(p, s, kDt);
  }
  perSpring(bs, s, s.mesh);
  bs.counters["rebuilds"] = static_cast<double>(s.cache.rebuilds);
}
BENCHMARK(BM_StepAfterEdgeSplit)->Arg(100000)->Unit(benchmark::kMicrosecond)->Iterations(200);

// Rebuilding the spring cache from scratch (a new layout: compaction, copy).
void BM_CacheRebuild(benchmark::State& bs) {
  State s = baseState(static_cast<int>(bs.range(0)));
  Params p;
  for (auto _ : bs) {
    s.invalidate();
    rawStep(p, s, Method::SymplecticEuler, kDt);
  }
}
BENCHMARK(BM_CacheRebuild)->Arg(100000)->Unit(benchmark::kMicrosecond)->MinTime(0.1);

}  // namespace
}  // namespace ld::physics

BENCHMARK_MAIN();
