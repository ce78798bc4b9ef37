// Step cost of each integrator on the default slab at 1k … 1M triangles, in time per
// step and ns per spring; the symplectic step on 1 and 2 threads, with and without the
// stability monitor, and after 1000 cut triangles.
//   physics_bench --benchmark_min_time=0.2
#include <benchmark/benchmark.h>

#include <map>
#include <random>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"

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
// springs), so that the benchmark measures arithmetic, not NaN handling.
constexpr double kDt = 1e-6;

void runSteps(benchmark::State& bs, Method m, bool monitor, int threads) {
  const int tris = static_cast<int>(bs.range(0));
  State s = baseState(tris);
  Params p;
  p.method = m;
  p.stability.enabled = monitor;
  p.threads = threads;
  step(p, s, kDt);  // builds the cache
  for (auto _ : bs) {
    if (monitor)
      step(p, s, kDt);
    else
      rawStep(p, s, m, kDt);
    benchmark::ClobberMemory();
  }
  const double springs = static_cast<double>(s.mesh.nEdges());
  bs.counters["triangles"] = static_cast<double>(s.mesh.nFaces());
  bs.counters["springs"] = springs;
  bs.counters["ns_per_spring"] =
      benchmark::Counter(springs * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_ExplicitEuler(benchmark::State& bs) { runSteps(bs, Method::ExplicitEuler, false, 1); }
void BM_Symplectic(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, false, 1); }
void BM_Symplectic2Threads(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, false, 2); }
void BM_SymplecticMonitored(benchmark::State& bs) { runSteps(bs, Method::SymplecticEuler, true, 1); }
void BM_Verlet(benchmark::State& bs) { runSteps(bs, Method::Verlet, false, 1); }
void BM_Rk4(benchmark::State& bs) { runSteps(bs, Method::Rk4, false, 1); }
void BM_ImplicitEuler(benchmark::State& bs) { runSteps(bs, Method::ImplicitEuler, false, 1); }

#define LD_SIZES ->Arg(1000)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMicrosecond)
BENCHMARK(BM_ExplicitEuler) LD_SIZES;
BENCHMARK(BM_Symplectic) LD_SIZES;
BENCHMARK(BM_Symplectic2Threads) LD_SIZES;
BENCHMARK(BM_SymplecticMonitored) LD_SIZES;
BENCHMARK(BM_Verlet) LD_SIZES;
BENCHMARK(BM_Rk4) LD_SIZES;
// Assembling and solving the sparse system each step: 1M triangles would take seconds.
BENCHMARK(BM_ImplicitEuler)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);

// The symplectic step on 100k triangles after 1000 triangles were cut (simulated by
// splitting 1000 faces and running the cutter's hooks): new vertices and springs are
// appended at the end of the arrays, so memory order no longer follows the mesh.
void BM_SymplecticAfterCuts(benchmark::State& bs) {
  const int cuts = static_cast<int>(bs.range(0));
  State s = baseState(100000);
  Params p;
  std::mt19937 rng(1);
  std::uniform_int_distribution<std::size_t> pick(0, s.mesh.facesSize() - 1);
  for (int c = 0; c < cuts; ++c) {
    mesh::Face f(pick(rng));
    if (!s.mesh.isValid(f)) continue;
    const auto vs = s.mesh.vertices(f);
    const auto v = s.mesh.splitFace(f, s.mesh.centroid(f));
    initVertexInFace(s.mesh, v, vs[0], vs[1], vs[2], Eigen::Vector3d::Constant(1.0 / 3.0), p.tissue);
  }
  rawStep(p, s, Method::SymplecticEuler, kDt);
  for (auto _ : bs) {
    rawStep(p, s, Method::SymplecticEuler, kDt);
    benchmark::ClobberMemory();
  }
  const double springs = static_cast<double>(s.mesh.nEdges());
  bs.counters["triangles"] = static_cast<double>(s.mesh.nFaces());
  bs.counters["ns_per_spring"] =
      benchmark::Counter(springs * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SymplecticAfterCuts)->Arg(0)->Arg(1000)->Unit(benchmark::kMicrosecond);

// Rebuilding the spring cache after a topology edit (what one cut costs the physics).
void BM_CacheRebuild(benchmark::State& bs) {
  State s = baseState(static_cast<int>(bs.range(0)));
  Params p;
  for (auto _ : bs) {
    s.invalidate();
    rawStep(p, s, Method::SymplecticEuler, kDt);
  }
}
BENCHMARK(BM_CacheRebuild)->Arg(100000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace ld::physics

BENCHMARK_MAIN();
