// Active-region mode on large tissues: one vertex pushed (5 mN for 300 steps, released
// for 300, repeated), 1 ms steps, only the awake region integrated. Contacts are named
// with wake() and the O(vertices) force scan is off, so a step costs in proportion to
// the region; the mass floor (TissueParams::massFloorDt) keeps 1 ms steps stable on
// these fine meshes, as in the window. Counters: awake vertices per step (mean) and
// their share of the tissue.
//   active_region_bench                       (100k and 1M triangles, a minute)
// The tissue starts at rest (rest ratio 1: no pre-stretch to settle first, which at 1M
// triangles would take minutes); the full step at the same size is in physics_bench.
#include <benchmark/benchmark.h>

#include <map>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"

namespace ld::physics {
namespace {

Params activeParams() {
  Params p;
  p.tissue.restRatio = 1.0;
  p.tissue.massFloorDt = 1e-3;  // 1 ms steps stay stable on the fine meshes
  p.active.enabled = true;
  p.active.scanExternalForces = false;
  return p;
}

State& restingState(int triangles) {
  static std::map<int, State> cache;
  auto it = cache.find(triangles);
  if (it == cache.end()) {
    const Params p = activeParams();
    it = cache.emplace(triangles, makeState(makeSlabWithTriangles(triangles), p.tissue)).first;
    for (int i = 0; i < 40; ++i) step(p, it->second, 1e-3);  // every vertex falls asleep
  }
  return it->second;
}

void BM_ActiveRegionPush(benchmark::State& bs) {
  FlushDenormals ftz;
  const Params p = activeParams();
  State& s = restingState(static_cast<int>(bs.range(0)));
  const mesh::Vertex v = topCentreVertex(s.mesh);
  auto& force = s.mesh.getVertexProperty<Eigen::Vector3d>(kForceProp)[v];
  double awake = 0.0;
  long steps = 0;
  for (auto _ : bs) {
    const bool on = steps % 600 < 300;
    if (steps % 600 == 0) wake(s, std::span<const mesh::Vertex>(&v, 1));
    force = on ? Eigen::Vector3d(0, 0, -5.0) : Eigen::Vector3d::Zero();
    awake += static_cast<double>(step(p, s, 1e-3).activeVertices);
    ++steps;
  }
  force.setZero();
  bs.counters["awake_vertices"] = awake / static_cast<double>(steps);
  bs.counters["awake_share"] = awake / static_cast<double>(steps) / static_cast<double>(s.mesh.nVertices());
  bs.counters["triangles"] = static_cast<double>(s.mesh.nFaces());
}

BENCHMARK(BM_ActiveRegionPush)->Arg(100000)->Arg(1000000)->Iterations(1200)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace ld::physics

BENCHMARK_MAIN();
