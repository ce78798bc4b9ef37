// Collision timings: one segment–triangle test, BVH segment queries on a tissue slab
// of 1k/10k/100k/1M triangles (near-surface instrument segments and random ones),
// first-hit queries, full and local refit, local topology updates per edited face,
// build. Run briefly on a shared machine, e.g.
//   bench/collision_bench --benchmark_min_time=0.2
//   bench/collision_bench --benchmark_filter='Query(Near|Random)'
//   bench/collision_bench --benchmark_filter=LoopSample   (the collision side of a 1 ms sample)
// The slab is always 158 x 158 x 5 mm (closed, two layers); Arg(n) is the number of
// cells per side: 16 -> 1.1k, 50 -> 10k, 158 -> 100k, 500 -> 1M triangles.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "sim/collision/bvh.h"
#include "sim/collision/collision_world.h"
#include "sim/collision/motion_scan.h"
#include "sim/collision/swept.h"
#include "sim/collision/walk.h"
#include "tests/sim/collision/test_meshes.h"

namespace {

using Eigen::Vector3d;
using ld::collision::TriangleBvh;
using ld::mesh::SurfaceMesh;

constexpr double kSide = 158.0;

const SurfaceMesh& slabCells(int n) {
  static std::map<int, std::unique_ptr<SurfaceMesh>> cache;
  auto& p = cache[n];
  if (!p) p = std::make_unique<SurfaceMesh>(ld::collision::testing::slab(n, kSide / n, 5.0));
  return *p;
}
const SurfaceMesh& slab100k() { return slabCells(158); }

using Segments = std::vector<std::pair<Vector3d, Vector3d>>;

// Scalpel-like 20 mm segments through random points of the top, tilted up to ~35
// degrees, reaching through the bottom layer (2 hits each): an instrument at work.
Segments blades(std::size_t n) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> U(5.0, kSide - 5.0), T(-0.7, 0.7);
  Segments s;
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d p(U(rng), U(rng), 0.0);
    const Vector3d dir = Vector3d(T(rng), T(rng), -1.0).normalized();
    s.emplace_back(p - 6.0 * dir, p + 14.0 * dir);
  }
  return s;
}

// 20 mm segments, centre uniform in the slab's box grown by 10 mm, direction uniform:
// most miss, some graze a layer or a wall.
Segments randomSegments(std::size_t n) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> X(-10.0, kSide + 10.0), Z(-15.0, 10.0);
  std::normal_distribution<double> N(0.0, 1.0);
  Segments s;
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d c(X(rng), X(rng), Z(rng));
    const Vector3d d = Vector3d(N(rng), N(rng), N(rng)).normalized();
    s.emplace_back(c - 10.0 * d, c + 10.0 * d);
  }
  return s;
}

void BM_SegmentTriangle(benchmark::State& st) {
  const Vector3d v0(0, 0, 0), v1(1, 0, 0), v2(0, 1, 0), a(0.2, 0.3, 1), b(0.25, 0.3, -1);
  for (auto _ : st) benchmark::DoNotOptimize(ld::collision::intersectSegmentTriangle(a, b, v0, v1, v2));
}
BENCHMARK(BM_SegmentTriangle);

void runQueries(benchmark::State& st, const Segments& segs, double margin = 0.0) {
  const SurfaceMesh& m = slabCells(static_cast<int>(st.range(0)));
  TriangleBvh bvh(m);
  if (margin > 0) {
    bvh.setMotionMargin(m, margin);
    // Tell the tree everything may have moved by (almost) the margin: the slack is used
    // up and queries grow the boxes by the whole margin, the widest they get (right
    // after the refit above they would be as tight as without a margin).
    bvh.refitMoved(m, margin * (1.0 - 1e-6));
  }
  std::vector<ld::collision::SurfaceHit> hits;
  std::size_t i = 0, total = 0;
  const std::size_t mask = segs.size() - 1;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & mask];
    bvh.intersectSegment(m, a, b, hits);
    total += hits.size();
  }
  ld::collision::QueryCounters qc;
  for (const auto& [a, b] : segs) bvh.intersectSegment(m, a, b, hits, &qc);
  const auto n = static_cast<double>(segs.size());
  st.counters["triangles"] = static_cast<double>(m.nFaces());
  st.counters["hits_per_query"] = static_cast<double>(total) / static_cast<double>(st.iterations());
  st.counters["boxes_per_query"] = static_cast<double>(qc.nodes) / n;
  st.counters["tris_per_query"] = static_cast<double>(qc.faces) / n;
  st.counters["exact_per_query"] = static_cast<double>(qc.exact) / n;
}

void BM_QueryNear(benchmark::State& st) { runQueries(st, blades(1024)); }
BENCHMARK(BM_QueryNear)->Arg(16)->Arg(50)->Arg(158)->Arg(500)->ArgName("cells")->Unit(benchmark::kMicrosecond);

// The same with fat boxes (setMotionMargin, range(1) um) at their widest: what the
// margin costs a query at most.
void BM_QueryNearFat(benchmark::State& st) { runQueries(st, blades(1024), st.range(1) * 1e-3); }
BENCHMARK(BM_QueryNearFat)
    ->Args({50, 250})
    ->Args({158, 100})
    ->Args({158, 250})
    ->Args({158, 500})
    ->ArgNames({"cells", "margin_um"})
    ->Unit(benchmark::kMicrosecond);

void BM_QueryRandom(benchmark::State& st) { runQueries(st, randomSegments(1024)); }
BENCHMARK(BM_QueryRandom)->Arg(16)->Arg(50)->Arg(158)->Arg(500)->ArgName("cells")->Unit(benchmark::kMicrosecond);

// Only the first contact (near-to-far with pruning) and the yes/no test.
void BM_FirstHitNear(benchmark::State& st) {
  const SurfaceMesh& m = slabCells(static_cast<int>(st.range(0)));
  const TriangleBvh bvh(m);
  const auto segs = blades(1024);
  ld::collision::SurfaceHit h;
  std::size_t i = 0, found = 0;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & 1023];
    found += bvh.firstHit(m, a, b, h) ? 1 : 0;
  }
  st.counters["found"] = static_cast<double>(found) / static_cast<double>(st.iterations());
  ld::collision::QueryCounters qc;
  for (const auto& [a, b] : segs) bvh.firstHit(m, a, b, h, &qc);
  st.counters["boxes_per_query"] = static_cast<double>(qc.nodes) / 1024.0;
  st.counters["tris_per_query"] = static_cast<double>(qc.faces) / 1024.0;
}
BENCHMARK(BM_FirstHitNear)->Arg(158)->ArgName("cells")->Unit(benchmark::kMicrosecond);

void BM_AnyHitRandom(benchmark::State& st) {
  const SurfaceMesh& m = slabCells(static_cast<int>(st.range(0)));
  const TriangleBvh bvh(m);
  const auto segs = randomSegments(1024);
  std::size_t i = 0, found = 0;
  for (auto _ : st) {
    const auto& [a, b] = segs[i++ & 1023];
    found += bvh.anyHit(m, a, b) ? 1 : 0;
  }
  st.counters["found"] = static_cast<double>(found) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_AnyHitRandom)->Arg(158)->ArgName("cells")->Unit(benchmark::kMicrosecond);

// A stroke as the loop sees it: the blade moves `range(0)` micrometres per sample
// along a wavy path across the slab (100 um = 100 mm/s at 1 kHz).
Segments stroke(double stepMm, std::size_t n) {
  Segments s;
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

void BM_BvhBuild(benchmark::State& st) {
  const SurfaceMesh& m = slabCells(static_cast<int>(st.range(0)));
  for (auto _ : st) {
    TriangleBvh bvh(m);
    benchmark::DoNotOptimize(bvh.stats().nodes);
  }
  TriangleBvh bvh(m);
  const auto s = bvh.stats();
  st.counters["triangles"] = static_cast<double>(m.nFaces());
  st.counters["leaves"] = static_cast<double>(s.leaves);
  st.counters["depth"] = static_cast<double>(s.maxDepth);
  st.counters["MB"] = static_cast<double>(s.bytes) / 1e6;
}
BENCHMARK(BM_BvhBuild)->Arg(158)->Arg(500)->ArgName("cells")->Unit(benchmark::kMillisecond)->Iterations(3);

// Physics moved every vertex: the full bottom-up refit.
void BM_BvhRefitFull(benchmark::State& st) {
  SurfaceMesh m = slabCells(static_cast<int>(st.range(0)));
  TriangleBvh bvh(m);
  double z = 0;
  for (auto _ : st) {
    m.position(ld::mesh::Vertex(0u)).z() = (z += 1e-6);
    bvh.refit(m);
  }
  st.counters["triangles"] = static_cast<double>(m.nFaces());
}
BENCHMARK(BM_BvhRefitFull)->Arg(16)->Arg(50)->Arg(158)->Arg(500)->ArgName("cells")->Unit(benchmark::kMicrosecond);

// The moving-tissue benchmarks' scene and step: slab of range(0) cells, fat boxes of
// range(1) um (0: tight boxes, full refits), amplitude range(2) um, a sine sag shape,
// blades; step() (timed) refits as the physics' callers do (fat boxes with the step's
// bound, or a full refit without a margin), then makes 4 blade queries.
constexpr std::size_t kMoveGroup = 16;  // physics::Dynamics::kMoveGroup

struct MovingScene {
  SurfaceMesh m;
  double margin, amp;
  TriangleBvh bvh;
  std::vector<Vector3d> rest;
  std::vector<double> shape;
  Segments segs = blades(1024);
  std::vector<ld::collision::SurfaceHit> out;
  std::size_t k = 0, reanchored = 0, hits = 0;
  explicit MovingScene(const benchmark::State& st)
      : m(slabCells(static_cast<int>(st.range(0)))),
        margin(static_cast<double>(st.range(1)) * 1e-3),
        amp(static_cast<double>(st.range(2)) * 1e-3),
        bvh(m),
        rest(m.positions().begin(), m.positions().end()),
        shape(rest.size()) {
    if (margin > 0) bvh.setMotionMargin(m, margin);
    for (std::size_t v = 0; v < rest.size(); ++v)
      shape[v] = std::sin(rest[v].x() * 3.14159 / kSide) * std::sin(rest[v].y() * 3.14159 / kSide);
  }
  // With travel (physics::Dynamics::groupTravel: each 16 vertices' moves summed, the
  // groups past the tree's limit listed) the tree looks only at the listed groups
  // (refitTravelled).
  std::vector<double> travel;
  std::vector<std::uint32_t> past;
  void step(double bound, bool summed = false) {
    reanchored += margin <= 0 ? (bvh.refit(m), m.nVertices())
                  : summed    ? bvh.refitTravelled(m, travel, past, kMoveGroup)
                              : bvh.refitMoved(m, bound);
    past.clear();
    for (int q = 0; q < 4; ++q) {
      const auto& s = segs[(4 * k + static_cast<std::size_t>(q)) % segs.size()];
      bvh.intersectSegment(m, s.first, s.second, out);
      hits += out.size();
    }
    ++k;
  }
  void counters(benchmark::State& st) const {
    const auto n = static_cast<double>(st.iterations());
    st.counters["triangles"] = static_cast<double>(m.nFaces());
    st.counters["reanchored"] = static_cast<double>(reanchored) / n;
    st.counters["passes"] = margin > 0 ? static_cast<double>(bvh.motionPasses()) / n : 1.0;
    st.counters["hits"] = static_cast<double>(hits) / n;
  }
};

// Moving tissue with fat boxes (setMotionMargin, range(1) um): every vertex moves each
// step (a standing wave of amplitude range(2) um, period 200 steps, plus a slow sag
// of 1 um per step, the kind of motion the CLI's physics makes), then refitMoved()
// and four blade queries (what cut --physics on does per physics step), with the
// step's largest move as the bound when range(3) = 1 (as the CLI passes the physics'
// Dynamics::maxMove). Margin 0: refit() as before. Time per step; / 4 gives the CLI's
// collision_us_per_query (refit charged to the queries). passes: share of steps that
// read the vertices; reanchored: vertices per step whose leaves were refitted.
void BM_BvhMovingTissue(benchmark::State& st) {
  MovingScene sc(st);
  double lastW = 0.0;
  for (auto _ : st) {
    st.PauseTiming();
    const double w = sc.amp * std::sin(2.0 * 3.14159 * static_cast<double>(sc.k) / 200.0) -
                     1e-3 * static_cast<double>(sc.k % 1000);
    for (std::size_t v = 0; v < sc.rest.size(); ++v) sc.m.positions()[v].z() = sc.rest[v].z() + w * sc.shape[v];
    st.ResumeTiming();
    // range(3) = 1: with the physics' bound on the step's moves (Dynamics::maxMove).
    const double bound = st.range(3) ? std::abs(w - lastW) : std::numeric_limits<double>::infinity();
    lastW = w;
    sc.step(bound);
  }
  sc.counters(st);
}
BENCHMARK(BM_BvhMovingTissue)
    ->Args({50, 0, 100, 0})
    ->Args({50, 250, 100, 0})
    ->Args({50, 250, 100, 1})
    ->Args({158, 0, 100, 0})
    ->Args({158, 250, 100, 0})
    ->Args({158, 250, 100, 1})
    ->Args({158, 100, 100, 1})
    ->Args({158, 500, 100, 1})
    ->ArgNames({"cells", "margin_um", "amp_um", "bound"})
    ->Unit(benchmark::kMicrosecond);

// The same loop with the kind of motion the physics step makes on the 100k slab (probed
// with physics::step: a settling rim, a patch pulled by a grasper, a cut's wound
// retracting): a few vertices move fast and set the step's bound (Dynamics::maxMove =
// dt max|v|, 0.02-0.05 mm a step, up to 0.45 mm after cuts), the bulk barely moves. Here
// a bump of radius 5 mm, amplitude range(2) um and period 40 steps travels slowly over
// the top while everything sags by 20 um (period 400 steps); the bound is the step's
// largest move, so passes come every few steps and re-anchor only the bump: the pass's
// scan over every vertex is most of the cost (BM_BvhMovingTissue's coherent sag instead
// makes most passes full refits). range(3) = 1: with each group of 16 vertices' moves
// summed (Dynamics::groupTravel, untimed as the physics' part) instead, so only the
// bump's groups are looked at.
void BM_BvhMovingTissueLocal(benchmark::State& st) {
  MovingScene sc(st);
  std::vector<double> groups;
  for (auto _ : st) {
    st.PauseTiming();
    const double t = static_cast<double>(sc.k);
    const double sag = 0.02 * std::sin(2.0 * 3.14159 * t / 400.0);
    const double bump = sc.amp * std::sin(2.0 * 3.14159 * t / 40.0);
    const Vector3d c(0.3 * kSide + std::fmod(0.01 * t, 0.4 * kSide), 0.5 * kSide, 0.0);
    double bound = 0.0;
    groups.assign(st.range(3) ? (sc.rest.size() + kMoveGroup - 1) / kMoveGroup : 0, 0.0);
    for (std::size_t v = 0; v < sc.rest.size(); ++v) {
      const double r2 = (sc.rest[v] - c).head<2>().squaredNorm();
      const double z = sc.rest[v].z() + sag * sc.shape[v] + (r2 < 25.0 ? bump * (1.0 - r2 / 25.0) : 0.0);
      const double d = std::abs(z - sc.m.positions()[v].z());
      bound = std::max(bound, d);
      if (!groups.empty()) groups[v / kMoveGroup] = std::max(groups[v / kMoveGroup], d);
      sc.m.positions()[v].z() = z;
    }
    sc.travel.resize(groups.size(), 0.0);
    for (std::size_t g = 0; g < groups.size(); ++g)
      if (!((sc.travel[g] += groups[g] + sc.bvh.travelPad()) <= sc.bvh.travelLimit()))
        sc.past.push_back(static_cast<std::uint32_t>(g));
    st.ResumeTiming();
    sc.step(bound, !groups.empty());
  }
  sc.counters(st);
}
BENCHMARK(BM_BvhMovingTissueLocal)
    ->Args({158, 0, 300, 0})
    ->Args({158, 250, 300, 0})
    ->Args({158, 250, 300, 1})
    ->ArgNames({"cells", "margin_um", "bump_um", "travel"})
    ->Unit(benchmark::kMicrosecond);

// The fat-box pass's scan alone (refitMoved without a bound over vertices that all stay
// within the margin: nothing re-anchored) with the scan build range(1) forced (0
// portable, 1 SSE2, 2 AVX2, 3 AVX-512; skipped when this CPU lacks it). Before each pass
// (untimed) every z is written, as the physics' position update does.
void BM_BvhMotionScan(benchmark::State& st) {
  const auto kernel = static_cast<ld::collision::ScanKernel>(st.range(1));
  if (!ld::collision::forceScanKernel(kernel)) {
    st.SkipWithError("scan build not supported here");
    return;
  }
  SurfaceMesh m = slabCells(static_cast<int>(st.range(0)));
  TriangleBvh bvh(m);
  bvh.setMotionMargin(m, 0.25);
  std::size_t k = 0, reanchored = 0;
  for (auto _ : st) {
    st.PauseTiming();
    const double dz = (++k % 2) ? 1e-3 : -1e-3;
    for (Vector3d& p : m.positions()) p.z() += dz;
    st.ResumeTiming();
    reanchored += bvh.refitMoved(m);
  }
  ld::collision::forceScanKernel(std::nullopt);
  st.counters["vertices"] = static_cast<double>(m.nVertices());
  st.counters["reanchored"] = static_cast<double>(reanchored);
  st.SetLabel(std::string(ld::collision::scanKernelName(kernel)));
}
BENCHMARK(BM_BvhMotionScan)
    ->Args({158, 1})
    ->Args({158, 2})
    ->Args({158, 3})
    ->ArgNames({"cells", "kernel"})
    ->Unit(benchmark::kMicrosecond);

// Local refit after a region of `range(0)` vertices moved (the active region).
void BM_BvhRefitLocal100k(benchmark::State& st) {
  SurfaceMesh m = slab100k();
  TriangleBvh bvh(m);
  std::vector<ld::mesh::Vertex> moved;
  for (std::int64_t i = 0; i < st.range(0); ++i) moved.emplace_back(static_cast<std::uint32_t>(20000 + i));
  for (auto _ : st) {
    for (auto v : moved) m.position(v).z() += 1e-6;
    bvh.refitVertices(m, moved);
  }
  st.counters["vertices"] = static_cast<double>(st.range(0));
}
BENCHMARK(BM_BvhRefitLocal100k)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

// A cut as the cutter makes it: the face under the blade (found with the tree) is
// split, then one of its edges, moving along a wavy line over the top; then
// TriangleBvh::sync() reads the mesh's edit journal. Only sync() is timed (manual
// time, per cut step); us_per_edited_face divides by the journal entries, the
// rebuilds the policy triggers included. query_us_after: near-surface query cost
// after all the edits (tree quality).
void BM_BvhSyncPerEditedFace100k(benchmark::State& st) {
  SurfaceMesh m = slab100k();
  TriangleBvh bvh(m);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(0.2, 0.8);
  std::size_t faces = 0, k = 0;
  double seconds = 0.0;
  std::vector<ld::collision::SurfaceHit> hits;
  for (auto _ : st) {
    const double x = 5.0 + std::fmod(0.05 * static_cast<double>(k), kSide - 10.0);
    const double y = 79.0 + 30.0 * std::sin(x / 20.0) + 0.01 * static_cast<double>(k / 3000);
    ++k;
    bvh.intersectSegment(m, Vector3d(x, y, 1.0), Vector3d(x, y, -1.0), hits);
    const std::size_t before = m.editedFaces().size();
    if (!hits.empty()) {
      const ld::mesh::Face f = hits[0].face;
      const auto& vs = m.vertices(f);
      const double u = U(rng), v = U(rng) * (1 - u);
      m.splitFace(f, m.position(vs[0]) + u * (m.position(vs[1]) - m.position(vs[0])) +
                         v * (m.position(vs[2]) - m.position(vs[0])));
      const ld::mesh::Edge ed = m.edges(f)[0];
      m.splitEdge(ed, 0.5 * (m.position(m.vertex(ed, 0)) + m.position(m.vertex(ed, 1))));
    }
    const auto t0 = std::chrono::steady_clock::now();
    bvh.sync(m);
    const auto t1 = std::chrono::steady_clock::now();
    faces += m.editedFaces().size() - before;
    const double dt = std::chrono::duration<double>(t1 - t0).count();
    seconds += dt;
    st.SetIterationTime(dt);
  }
  st.counters["edited_faces"] = static_cast<double>(faces);
  st.counters["us_per_edited_face"] = faces ? 1e6 * seconds / static_cast<double>(faces) : 0.0;
  st.counters["builds"] = static_cast<double>(bvh.stats().builds);
  // Best of 5 rounds (the machine is shared: one preemption would dominate).
  const auto segs = blades(1024);
  double best = 1e30;
  for (int round = 0; round < 5; ++round) {
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& [a, b] : segs) bvh.intersectSegment(m, a, b, hits);
    const auto t1 = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double, std::micro>(t1 - t0).count() / 1024.0);
  }
  st.counters["query_us_after"] = best;
  ld::collision::QueryCounters qc;
  for (const auto& [a, b] : segs) bvh.intersectSegment(m, a, b, hits, &qc);
  st.counters["boxes_per_query_after"] = static_cast<double>(qc.nodes) / 1024.0;
}
BENCHMARK(BM_BvhSyncPerEditedFace100k)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(30000);

// Wall time of the whole edit + sync loop per edited face (amortised rebuilds included).
void BM_BvhEditAndSync100k(benchmark::State& st) {
  SurfaceMesh m = slab100k();
  TriangleBvh bvh(m);
  const bool sync = st.range(0) != 0;
  std::mt19937_64 rng(2);
  std::size_t journal0 = m.editedFaces().size();
  for (auto _ : st) {
    const ld::mesh::Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
    if (!m.isValid(f)) continue;
    const auto& vs = m.vertices(f);
    const Vector3d c = (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0;
    m.splitFace(f, c);
    const ld::mesh::Edge e = m.edges(f)[0];
    m.splitEdge(e, 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1))));
    if (sync) bvh.sync(m);
  }
  st.counters["builds"] = static_cast<double>(bvh.stats().builds);
  st.counters["edited_faces_per_iter"] =
      static_cast<double>(m.editedFaces().size() - journal0) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_BvhEditAndSync100k)->Arg(0)->Arg(1)->ArgName("sync")->Unit(benchmark::kMicrosecond)->Iterations(20000);

// ---- the collision side of one 1 ms loop sample --------------------------------
// Per sample: physics has moved the vertices (all of them, or only an active region
// of radius range(1) mm around the scalpel), the tree is refitted accordingly, then
// the DESIGN.md instrument segments are queried: the scalpel's blade (one segment),
// the other hand's grasper (two jaws) and the scalpel's swept test from the previous
// sample (what the cutter needs). Only that collision work is timed (manual wall
// time); the counters give its thread CPU time per sample (cpu_us, split into
// refit_cpu_us, query_cpu_us, sweep_cpu_us) and the region's vertices. The scalpel cuts 2 mm deep at 100 mm/s along x;
// range(1) == 0 means full physics (every vertex moved, full refit).
struct LoopScene {
  SurfaceMesh mesh;
  std::vector<std::vector<std::uint32_t>> regions;  // per sample of the cycle
  std::vector<ld::instruments::Pose> scalpel;
  ld::instruments::Pose grasper;
};

constexpr std::size_t kLoopCycle = 512;

LoopScene& loopScene(int cells, int radiusMm) {
  static std::map<std::pair<int, int>, std::unique_ptr<LoopScene>> cache;
  auto& p = cache[{cells, radiusMm}];
  if (p) return *p;
  p = std::make_unique<LoopScene>();
  LoopScene& sc = *p;
  sc.mesh = slabCells(cells);
  for (std::size_t k = 0; k < kLoopCycle; ++k) {
    ld::instruments::Pose pose;
    pose.tip = Vector3d(40.0 + 0.1 * static_cast<double>(k), 79.0, -2.0);
    pose.dir = Vector3d(0.2, 0.1, -1.0).normalized();
    pose.up = Vector3d(1, 0, 0.2).normalized();
    pose.up = (pose.up - pose.up.dot(pose.dir) * pose.dir).normalized();
    sc.scalpel.push_back(pose);
  }
  sc.grasper.tip = Vector3d(60.0, 95.0, -1.0);
  sc.grasper.dir = Vector3d(0.0, -0.3, -1.0).normalized();
  sc.grasper.up = Vector3d(1, 0, 0);
  sc.grasper.jaw = 0.5;
  if (radiusMm > 0) {
    // Vertices within the radius of the blade's entry point, bucketed on a grid.
    const double r = radiusMm;
    const double cell = r;
    std::map<std::pair<long, long>, std::vector<std::uint32_t>> grid;
    for (ld::mesh::Vertex v : sc.mesh.vertices()) {
      const Vector3d& q = sc.mesh.position(v);
      grid[{std::lround(std::floor(q.x() / cell)), std::lround(std::floor(q.y() / cell))}].push_back(
          static_cast<std::uint32_t>(v.idx()));
    }
    for (std::size_t k = 0; k < kLoopCycle; ++k) {
      const Vector3d c = sc.scalpel[k].tip;
      std::vector<std::uint32_t> region;
      const long gx = std::lround(std::floor(c.x() / cell)), gy = std::lround(std::floor(c.y() / cell));
      for (long i = gx - 1; i <= gx + 1; ++i)
        for (long j = gy - 1; j <= gy + 1; ++j) {
          const auto it = grid.find({i, j});
          if (it == grid.end()) continue;
          for (std::uint32_t v : it->second)
            if ((sc.mesh.positions()[v] - c).head<2>().norm() < r) region.push_back(v);
        }
      sc.regions.push_back(std::move(region));
    }
  }
  return sc;
}

// Thread CPU time [s]: on a shared machine the wall time of a few microseconds is
// mostly other processes' time slices; this is what the sample itself costs.
double threadSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void BM_LoopSample(benchmark::State& st) {
  const int cells = static_cast<int>(st.range(0));
  const int radius = static_cast<int>(st.range(1));
  const double margin = st.range(2) * 1e-3;  // fat boxes [mm] (full physics only)
  LoopScene& sc = loopScene(cells, radius);
  SurfaceMesh& m = sc.mesh;
  ld::collision::CollisionWorld world;
  const auto id = world.add(m);
  if (margin > 0) world.setMotionMargin(id, margin);
  std::size_t k = 1, regionVertices = 0;
  double refitS = 0, queryS = 0, sweepS = 0;
  std::size_t hits = 0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : st) {
    const std::size_t i = k % kLoopCycle;
    const double d = (k & 1) ? 0.01 : -0.01;  // "physics": a small motion, back and forth
    if (radius > 0) {
      for (std::uint32_t v : sc.regions[i]) m.positions()[v].z() += d;
      regionVertices += sc.regions[i].size();
    } else {
      for (Vector3d& p : m.positions()) p.z() += d;
    }
    const auto w0 = Clock::now();
    const double t0 = threadSeconds();
    if (radius > 0) {
      world.refitVertices(id, std::span<const std::uint32_t>(sc.regions[i]));
    } else if (margin > 0) {
      world.refitMoved(id);
    } else {
      world.refit();
    }
    const double t1 = threadSeconds();
    const auto blade = world.query(ld::instruments::Tool::Scalpel, sc.scalpel[i]);
    const auto jaws = world.query(ld::instruments::Tool::Grasper, sc.grasper);
    const double t2 = threadSeconds();
    const auto swept = world.sweep(ld::instruments::Tool::Scalpel, sc.scalpel[(k - 1) % kLoopCycle], sc.scalpel[i]);
    const double t3 = threadSeconds();
    const auto w1 = Clock::now();
    for (const auto& s : blade) hits += s.hits.size();
    for (const auto& s : jaws) hits += s.hits.size();
    benchmark::DoNotOptimize(swept.data());
    refitS += t1 - t0;
    queryS += t2 - t1;
    sweepS += t3 - t2;
    st.SetIterationTime(std::chrono::duration<double>(w1 - w0).count());
    ++k;
  }
  const auto n = static_cast<double>(st.iterations());
  st.counters["triangles"] = static_cast<double>(m.nFaces());
  st.counters["region_vertices"] = radius > 0 ? static_cast<double>(regionVertices) / n : 0.0;
  st.counters["cpu_us"] = 1e6 * (refitS + queryS + sweepS) / n;
  st.counters["refit_cpu_us"] = 1e6 * refitS / n;
  st.counters["query_cpu_us"] = 1e6 * queryS / n;
  st.counters["sweep_cpu_us"] = 1e6 * sweepS / n;
  st.counters["hits"] = static_cast<double>(hits) / n;
}
BENCHMARK(BM_LoopSample)
    ->Args({158, 0, 0})
    ->Args({158, 0, 250})
    ->Args({158, 5, 0})
    ->Args({158, 10, 0})
    ->Args({500, 0, 0})
    ->Args({500, 0, 250})
    ->Args({500, 5, 0})
    ->Args({500, 10, 0})
    ->ArgNames({"cells", "region_mm", "margin_um"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

// Separation: a 100k-triangle object loses a piece (range(0) percent of its faces,
// a corner of the slab); after the compaction the tree is remapped (range(1) = 1)
// or rebuilt (0). Only that is timed.
void BM_BvhAfterCompaction100k(benchmark::State& st) {
  const double frac = static_cast<double>(st.range(0)) / 100.0;
  const bool remap = st.range(1) != 0;
  double seconds = 0;
  for (auto _ : st) {
    SurfaceMesh m = slab100k();
    TriangleBvh bvh(m);
    for (ld::mesh::Face f : m.faces()) {
      const auto& vs = m.vertices(f);
      if (m.position(vs[0]).x() < kSide * std::sqrt(frac) && m.position(vs[0]).y() < kSide * std::sqrt(frac))
        m.deleteFace(f);
    }
    const ld::mesh::Compaction c = m.garbageCollection();
    const auto t0 = std::chrono::steady_clock::now();
    if (remap) {
      bvh.remap(m, c);
    } else {
      bvh.build(m);
    }
    const auto t1 = std::chrono::steady_clock::now();
    const double dt = std::chrono::duration<double>(t1 - t0).count();
    seconds += dt;
    st.SetIterationTime(dt);
  }
}
BENCHMARK(BM_BvhAfterCompaction100k)
    ->Args({10, 0})
    ->Args({10, 1})
    ->ArgNames({"piece_pct", "remap"})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);

}  // namespace

BENCHMARK_MAIN();
