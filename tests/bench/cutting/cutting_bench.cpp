// Remeshing cost per cut triangle, triangles added per cut triangle, and the physics
// step before and after 1000 cut triangles.
//   cutting_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "sim/cutting/cutter.h"
#include "sim/cutting/mesh_checks.h"
#include "sim/physics/mass_spring.h"
#include "tests/sim/cutting/cut_test_meshes.h"

namespace {

using ld::cutting::test::Vec3;

// The default slab's size and resolution (80 x 60 x 5 mm, 54 x 40 x 4 cells).
ld::mesh::SurfaceMesh slab() {
  return ld::cutting::test::makeBox(Vec3(-40, -30, -2.5), Vec3(40, 30, 2.5), {54, 40, 4});
}

// The same slab at about 100k triangles (180 x 134 x 4 cells: 101k faces).
ld::mesh::SurfaceMesh slab100k() {
  return ld::cutting::test::makeBox(Vec3(-40, -30, -2.5), Vec3(40, 30, 2.5), {180, 134, 4});
}

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Smallest angle of the cut's walls (face kind 1 groove wall, 2 side wall) [degrees].
double wallAngleDeg(const ld::mesh::SurfaceMesh& m) {
  double worst = 180.0;
  const auto kinds = m.getFaceProperty<int>(ld::cutting::kFaceKindProp);
  if (!kinds) return worst;
  for (auto f : m.faces()) {
    if (kinds[f] == 0) continue;
    const auto& v = m.vertices(f);
    const Vec3 p[3] = {m.position(v[0]), m.position(v[1]), m.position(v[2])};
    for (int i = 0; i < 3; ++i) {
      const Vec3 a = p[(i + 1) % 3] - p[i], b = p[(i + 2) % 3] - p[i];
      worst = std::min(worst, std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI);
    }
  }
  return worst;
}

// FNV-1a over bytes.
std::uint64_t fnv(std::uint64_t h, const void* data, std::size_t n) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ULL;
  return h;
}

// Hashes of the final meshes, low 32 bits (exact in a double counter):
//   geometry  the triangles as sorted corner coordinates, sorted (independent of numbering);
//   indices   every object's face corner indices in face order and its positions' bits.
std::array<double, 2> meshHashes(const ld::cutting::CutEngine& e) {
  std::uint64_t geo = 1469598103934665603ULL, idx = geo;
  for (const auto& o : e.objects()) {
    const auto& m = o.mesh;
    std::vector<std::array<double, 9>> tris;
    for (auto f : m.faces()) {
      const auto& v = m.vertices(f);
      std::array<std::array<double, 3>, 3> c{};
      for (int i = 0; i < 3; ++i) {
        const Vec3 p = m.position(v[i]);
        c[i] = {p.x(), p.y(), p.z()};
        const int vi = static_cast<int>(v[i].idx());
        idx = fnv(idx, &vi, sizeof vi);
      }
      std::sort(c.begin(), c.end());
      tris.push_back({c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2], c[2][0], c[2][1], c[2][2]});
    }
    std::sort(tris.begin(), tris.end());
    for (const auto& t : tris) geo = fnv(geo, t.data(), sizeof(double) * t.size());
    for (auto v : m.vertices()) {
      const Vec3 p = m.position(v);
      const double xyz[3] = {p.x(), p.y(), p.z()};
      idx = fnv(idx, xyz, sizeof xyz);
    }
  }
  return {static_cast<double>(geo & 0xffffffffULL), static_cast<double>(idx & 0xffffffffULL)};
}

// Parallel strokes across the slab: cut-through (tip below) or groove (tip inside).
void cutStrokes(ld::cutting::CutEngine& e, int strokes, double tipZ) {
  for (int s = 0; s < strokes; ++s) {
    const double y = -25.0 + 50.0 * (s + 0.37) / strokes;
    ld::cutting::test::stroke(e, Vec3(-45, y, tipZ), Vec3(45, y + 3.1, tipZ), Vec3(0, 0, -1), 100.0, 1000.0);
  }
}

// Counters (per run, the last iteration's):
//   remesh_us_per_cut_triangle  CutStats::remeshSeconds / trianglesCut: monotonic time
//                               in the edits of samples that walked or edited the mesh
//                               (collision queries and separation excluded);
//   stroke_us_per_cut_triangle  thread CPU time of the whole strokes (everything: queries,
//                               samples that changed nothing, separation) / trianglesCut;
//   separation_ms               CutStats::separationSeconds (finding and splitting off
//                               freed pieces);
//   separations, longest_front  CutStats: pieces freed (4 for the through-cut), most
//                               vertices a cut's front had (tip to the other layer);
//   bottom_slides               CutStats::bottomSlides (groove-bottom vertices moved on);
//   min_angle_deg, min_area_mm2 the meshes' smallest triangle angle and area;
//   wall_min_angle_deg          the same angle over the cut's walls only;
//   mesh_hash_geometry/_indices the final meshes' hashes (meshHashes): an optimisation
//                               that keeps the result keeps these.
void remeshRun(benchmark::State& state, const ld::mesh::SurfaceMesh& base, int kind) {
  // 0: cut-through, 1: groove 2 mm deep, 2: shallow groove 0.4 mm deep (the hook's
  // usual depth: long, low walls), 3: groove deepening through the bottom mid-stroke.
  const double tipZ = kind == 0 ? -4.0 : (kind == 2 ? 2.1 : 0.5);
  double wallMinAngle = 0, us = 0, perTri = 0, collUs = 0, slowPerTri = 0, minAngle = 0, minArea = 0, strokeUs = 0,
         sepMs = 0;
  std::array<double, 2> hashes{};
  long cut = 0, separations = 0, longestFront = 0, slides = 0;
  for (auto _ : state) {
    state.PauseTiming();
    ld::cutting::CutEngine e;
    e.addObject(base);
    state.ResumeTiming();
    const double t0 = threadCpuSeconds();
    if (kind == 3) {
      for (int k = 0; k < 4; ++k) {
        const double y = -25.0 + 50.0 * (k + 0.37) / 4;
        ld::cutting::test::polyStroke(
            e, {Vec3(-30, y, 0.5), Vec3(-10, y + 1, 0.5), Vec3(10, y + 2, -4), Vec3(30, y + 3, -4)}, Vec3(0, 0, -1),
            100.0, 1000.0, [](ld::cutting::CutEngine&) {});
      }
    } else {
      cutStrokes(e, 4, tipZ);
    }
    const double strokeSeconds = threadCpuSeconds() - t0;
    const auto& st = e.stats();
    us = st.remeshMicrosPerCutTriangle();
    cut = st.trianglesCut;
    separations = st.separations;
    longestFront = st.longestFront;
    slides = st.bottomSlides;
    strokeUs = strokeSeconds * 1e6 / static_cast<double>(std::max(1L, st.trianglesCut));
    sepMs = st.separationSeconds * 1e3;
    perTri = static_cast<double>(st.trianglesAdded) / static_cast<double>(std::max(1L, st.trianglesCut));
    collUs = st.collisionQueries > 0 ? st.collisionSeconds * 1e6 / static_cast<double>(st.collisionQueries) : 0.0;
    slowPerTri = static_cast<double>(st.slowSamples) / static_cast<double>(std::max(1L, st.trianglesCut));
    state.PauseTiming();
    minAngle = 180.0;
    minArea = 1e300;
    wallMinAngle = 180.0;
    for (const auto& o : e.objects()) {
      const auto q = ld::cutting::measureQuality(o.mesh);
      minAngle = std::min(minAngle, q.minAngleDeg);
      minArea = std::min(minArea, q.minArea);
      wallMinAngle = std::min(wallMinAngle, wallAngleDeg(o.mesh));
    }
    hashes = meshHashes(e);
    state.ResumeTiming();
  }
  state.counters["min_angle_deg"] = minAngle;
  state.counters["min_area_mm2"] = minArea;
  state.counters["wall_min_angle_deg"] = wallMinAngle;
  state.counters["collision_us_per_query"] = collUs;
  state.counters["slow_samples_per_cut_triangle"] = slowPerTri;
  state.counters["remesh_us_per_cut_triangle"] = us;
  state.counters["stroke_us_per_cut_triangle"] = strokeUs;
  state.counters["separation_ms"] = sepMs;
  state.counters["triangles_added_per_cut_triangle"] = perTri;
  state.counters["triangles_cut"] = static_cast<double>(cut);
  state.counters["separations"] = static_cast<double>(separations);
  state.counters["longest_front"] = static_cast<double>(longestFront);
  state.counters["bottom_slides"] = static_cast<double>(slides);
  state.counters["mesh_hash_geometry"] = hashes[0];
  state.counters["mesh_hash_indices"] = hashes[1];
}

void BM_Remesh(benchmark::State& state) {
  static const auto base = slab();
  remeshRun(state, base, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_Remesh)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond)->Iterations(3);

// The same strokes on the 100k-triangle slab (0: through, 1: groove).
void BM_Remesh100k(benchmark::State& state) {
  static const auto base = slab100k();
  remeshRun(state, base, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_Remesh100k)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(2);

// The monitored 1 ms step (as the window, the CLI and the task runner run it) before
// and after ~1000 cut triangles. range(0): triangles to cut; range(1): 0 the default
// slab (10k triangles), 1 the 100k slab; range(2): 1 = the mass floor for the step
// (TissueParams::massFloorDt = dt, what every caller sets), 0 = none (the cuts' short,
// light edges then force substeps: the `substeps` counter shows them; 10k only, the
// 100k slab without the floor falls back to the implicit step, ~0.3 s a step).
// The 10k slab gains ~45 % springs from 1000 cut triangles, the 100k slab ~5 %: the
// 1.3x target is about the second; `springs` lets one read the cost per spring.
void BM_PhysicsStepAfterCuts(benchmark::State& state) {
  ld::cutting::CutEngine e;
  e.addObject(state.range(1) == 1 ? slab100k() : slab());
  if (state.range(0) > 0) {
    int strokes = 0;
    while (e.stats().trianglesCut < state.range(0) && strokes < 40) {
      const double y = -27.0 + 1.37 * strokes;
      ld::cutting::test::stroke(e, Vec3(-45, y, 0.5), Vec3(45, y + 0.9, 0.5), Vec3(0, 0, -1), 200.0, 1000.0);
      ++strokes;
    }
  }
  constexpr double dt = 1e-3;
  ld::physics::TissueParams tp;
  tp.massFloorDt = state.range(2) == 1 ? dt : 0.0;
  ld::physics::Params pp;
  auto st = ld::physics::makeState(e.objects()[0].mesh, tp);
  for (int i = 0; i < 10; ++i) ld::physics::step(pp, st, dt);
  double substeps = 0;
  long steps = 0;
  for (auto _ : state) {
    substeps += ld::physics::step(pp, st, dt).substeps;
    ++steps;
  }
  state.counters["substeps"] = substeps / static_cast<double>(std::max(1L, steps));
  state.counters["springs"] = static_cast<double>(st.mesh.nEdges());
  state.counters["triangles_cut"] = static_cast<double>(e.stats().trianglesCut);
  state.counters["faces"] = static_cast<double>(st.mesh.nFaces());
  state.counters["lanes"] = static_cast<double>(st.cache.rankX.size());  // spring lanes of the step, padding included
  state.counters["vertices"] = static_cast<double>(st.mesh.nVertices());
  // ranks of 8 lanes that sum a high-degree vertex's springs past its block's rank count
  state.counters["tail_ranks"] = static_cast<double>(st.cache.tailStart.back() - st.cache.rankStart.back());
}
BENCHMARK(BM_PhysicsStepAfterCuts)
    ->ArgsProduct({{0, 1000}, {0, 1}, {1}})
    ->Args({0, 0, 0})
    ->Args({1000, 0, 0})
    ->ArgNames({"cut", "100k", "mass_floor"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
