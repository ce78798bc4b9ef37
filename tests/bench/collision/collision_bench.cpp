// Collision timings: one segment–triangle test, BVH segment queries at ~100k
// triangles, full and local refit, local topology updates, build.
// Run briefly on a shared machine, e.g.
//   bench/collision_bench --benchmark_min_time=0.2
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "sim/collision/bvh.h"
#include "sim/collision/collision_world.h"
#include "sim/collision/swept.h"
#include "sim/collision/walk.h"
#include "tests/sim/collision/test_meshes.h"

namespace {

using Eigen::Vector3d;
using ld::collision::TriangleBvh;
using ld::mesh::SurfaceMesh;

// A closed slab 158 x 158 x 5 mm with 1 mm cells: 100 528 triangles, two layers.
const SurfaceMesh& slab100k() {
  static const SurfaceMesh m = ld::collision::testing::slab(158, 1.0, 5.0);
  return m;
}

// Scalpel-like 20 mm segments through random points of the top, tilted up to ~35
// degrees, reaching through the bottom layer (2 hits each).
std::vector<std::pair<Vector3d, Vector3d>> blades(std::size_t n) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> U(5.0, 153.0), T(-0.7, 0.7);
  std::vector<std::pair<Vector3d, Vector3d>> s;
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d p(U(rng), U(rng), 0.0);
    const Vector3d dir = Vector3d(T(rng), T(rng), -1.0).normalized();
    s.emplace_back(p - 6.0 * dir, p + 14.0 * dir);
  }
  return s;
}

void BM_SegmentTriangle(benchmark::State& st) {
  const Vector3d v0(0, 0, 0), v1(1, 0, 0), v2(0, 1, 0), a(0.2, 0.3, 1), b(0.25, 0.3, -1);
  for (auto _ : st) benchmark::DoNotOptimize(ld::collision::intersectSegmentTriangle(a, b, v0, v1, v2));
}
BENCHMARK(BM_SegmentTriangle);

void BM_BvhSegmentQuery100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  const TriangleBvh bvh(m);
  const auto segs = blades(1024);
  std::vector<ld::collision::SurfaceHit> hits;
  std::size_t i = 0, total = 0;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & 1023];
    bvh.intersectSegment(m, a, b, hits);
    total += hits.size();
  }
  ld::collision::QueryCounters qc;
  for (const auto& [a, b] : segs) bvh.intersectSegment(m, a, b, hits, &qc);
  st.counters["triangles"] = static_cast<double>(m.nFaces());
  st.counters["hits_per_query"] = static_cast<double>(total) / static_cast<double>(st.iterations());
  st.counters["boxes_per_query"] = static_cast<double>(qc.nodes) / static_cast<double>(segs.size());
  st.counters["tris_per_query"] = static_cast<double>(qc.faces) / static_cast<double>(segs.size());
}
BENCHMARK(BM_BvhSegmentQuery100k)->Unit(benchmark::kMicrosecond);

// A stroke as the loop sees it: the blade moves `range(0)` micrometres per sample
// along a wavy path across the slab (100 um = 100 mm/s at 1 kHz).
std::vector<std::pair<Vector3d, Vector3d>> stroke(double stepMm, std::size_t n) {
  std::vector<std::pair<Vector3d, Vector3d>> s;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = 10.0 + std::fmod(stepMm * static_cast<double>(i), 138.0);
    const Vector3d tip(x, 79.0 + 20.0 * std::sin(x / 15.0), -7.0);  // below the slab, edge up through both layers
    const Vector3d dir = Vector3d(0.3 * std::cos(x / 9.0), 0.2, -1.0).normalized();
    s.emplace_back(tip, tip - 20.0 * dir);
  }
  return s;
}

void BM_BvhSegmentQueryStroke100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  const TriangleBvh bvh(m);
  const auto segs = stroke(static_cast<double>(st.range(0)) * 1e-3, 4096);
  std::vector<ld::collision::SurfaceHit> hits;
  std::size_t i = 0, total = 0;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & 4095];
    bvh.intersectSegment(m, a, b, hits);
    total += hits.size();
  }
  st.counters["hits_per_query"] = static_cast<double>(total) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_BvhSegmentQueryStroke100k)->Arg(100)->ArgName("step_um")->Unit(benchmark::kMicrosecond);

// The thesis's fast path: the 1-ring of the last hit face.
void BM_NeighbourhoodQueryStroke100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  const TriangleBvh bvh(m);
  const auto segs = stroke(0.1, 4096);
  std::vector<ld::collision::SurfaceHit> hits;
  hits = bvh.intersectSegment(m, segs[0].first, segs[0].second);
  ld::mesh::Face last = hits.back().face;  // the top layer
  std::size_t i = 1, found = 0;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & 4095];
    ld::collision::intersectNeighbourhood(m, last, a, b, hits);
    if (!hits.empty()) {
      last = hits.back().face;
      ++found;
    } else {
      st.PauseTiming();
      hits = bvh.intersectSegment(m, a, b);
      last = hits.back().face;
      st.ResumeTiming();
    }
  }
  st.counters["found_locally"] = static_cast<double>(found) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_NeighbourhoodQueryStroke100k)->Unit(benchmark::kMicrosecond);

void BM_SweepStroke100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  const TriangleBvh bvh(m);
  const auto segs = stroke(static_cast<double>(st.range(0)) * 1e-3, 4096);
  std::size_t i = 0, faces = 0;
  for (auto _ : st) {
    const std::size_t k = i++ % 4095;
    const auto c =
        ld::collision::sweepSegment(m, &bvh, segs[k].first, segs[k].second, segs[k + 1].first, segs[k + 1].second);
    faces += c.faces.size();
  }
  st.counters["faces_per_sweep"] = static_cast<double>(faces) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_SweepStroke100k)->Arg(100)->Arg(2000)->ArgName("step_um")->Unit(benchmark::kMicrosecond);

void BM_WorldScalpelQuery100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  ld::collision::CollisionWorld world;
  world.add(m);
  const auto segs = stroke(0.1, 4096);
  std::size_t i = 0;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & 4095];
    ld::instruments::Pose p;
    p.tip = a;
    p.dir = (a - b).normalized();
    p.up = p.dir.unitOrthogonal();
    benchmark::DoNotOptimize(world.query(ld::instruments::Tool::Scalpel, p));
  }
}
BENCHMARK(BM_WorldScalpelQuery100k)->Unit(benchmark::kMicrosecond);

void BM_BruteForceSegmentQuery100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  const auto segs = blades(16);
  std::size_t i = 0;
  for (auto _ : st)
    benchmark::DoNotOptimize(ld::collision::intersectSegment(m, segs[i & 15].first, segs[i & 15].second)), ++i;
}
BENCHMARK(BM_BruteForceSegmentQuery100k)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_BvhBuild100k(benchmark::State& st) {
  const SurfaceMesh& m = slab100k();
  for (auto _ : st) {
    TriangleBvh bvh(m);
    benchmark::DoNotOptimize(bvh.stats().nodes);
  }
}
BENCHMARK(BM_BvhBuild100k)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_BvhRefitFull100k(benchmark::State& st) {
  SurfaceMesh m = slab100k();
  TriangleBvh bvh(m);
  double z = 0;
  for (auto _ : st) {
    m.position(ld::mesh::Vertex(0u)).z() = (z += 1e-6);
    bvh.refit(m);
  }
  st.counters["triangles"] = static_cast<double>(m.nFaces());
}
BENCHMARK(BM_BvhRefitFull100k)->Unit(benchmark::kMicrosecond);

// Local refit after a region of `range(0)` vertices moved (the active region).
void BM_BvhRefitLocal100k(benchmark::State& st) {
  SurfaceMesh m = slab100k();
  TriangleBvh bvh(m);
  std::vector<ld::mesh::Vertex> moved;
  for (std::int64_t i = 0; i < st.range(0); ++i) moved.emplace_back(static_cast<std::uint32_t>(20000 + i));
  double z = 0;
  for (auto _ : st) {
    z += 1e-6;
    for (auto v : moved) m.position(v).z() += 1e-6;
    bvh.refitVertices(m, moved);
  }
  st.counters["vertices"] = static_cast<double>(st.range(0));
}
BENCHMARK(BM_BvhRefitLocal100k)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

// One cut-like edit (split a face, then split one of its edges) plus the tree's
// local sync; the mesh edit alone is measured separately to subtract.
void BM_BvhLocalUpdate100k(benchmark::State& st) {
  SurfaceMesh m = slab100k();
  TriangleBvh bvh(m);
  const bool sync = st.range(0) != 0;
  std::mt19937_64 rng(2);
  std::size_t edits = 0;
  for (auto _ : st) {
    const ld::mesh::Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
    if (!m.isValid(f)) continue;
    const auto& vs = m.vertices(f);
    const Vector3d c = (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0;
    m.splitFace(f, c);
    const ld::mesh::Edge e = m.edges(f)[0];
    m.splitEdge(e, 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1))));
    if (sync) bvh.sync(m);
    ++edits;
  }
  st.counters["builds"] = static_cast<double>(bvh.stats().builds);
  st.counters["new_faces_per_iter"] = 3.0;  // 2 from the face split, 1-2 from the edge split
}
BENCHMARK(BM_BvhLocalUpdate100k)->Arg(0)->Arg(1)->ArgName("sync")->Unit(benchmark::kMicrosecond)->Iterations(20000);

}  // namespace

BENCHMARK_MAIN();
