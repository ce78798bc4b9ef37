// Cost of one SurfaceMesh edit (ns and heap allocations per edit) on closed slabs of
// about 10k and 100k triangles carrying the tissue properties, as the cutter sees
// them. Each run starts from a fresh slab and does a fixed number of edits at random
// places (cold memory, as between the cutter's samples); no timer pauses.
//   mesh_bench --benchmark_counters_tabular=true            (about 3 s)
//   mesh_bench --benchmark_filter='reserved:1' ...           (steady state only)
// Counters: allocs_per_edit (operator new calls inside the timed loop, per edit),
// ns_per_edit (CPU; printed with SI prefixes, e.g. "1.2ks" = 1200 ns), edits (done;
// the slits can run out of row edges), faces (after the run). Args: tris, reserved
// (see slabFor). Time per iteration is per edit except BM_DeleteAddFace (a pair).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <new>
#include <vector>

#include "sim/mesh/surface_mesh.h"
#include "sim/physics/scenes.h"
#include "sim/physics/tissue_properties.h"

// ---- allocation counting: every global operator new of this program -----------------
namespace {
std::uint64_t gAllocations = 0;

void* countedAlloc(std::size_t n) {
  ++gAllocations;
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* countedAlignedAlloc(std::size_t n, std::align_val_t al) {
  ++gAllocations;
  const auto a = static_cast<std::size_t>(al);
  if (void* p = std::aligned_alloc(a, (std::max<std::size_t>(n, 1) + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) { return countedAlloc(n); }
void* operator new[](std::size_t n) { return countedAlloc(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  ++gAllocations;
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  ++gAllocations;
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new(std::size_t n, std::align_val_t al) { return countedAlignedAlloc(n, al); }
void* operator new[](std::size_t n, std::align_val_t al) { return countedAlignedAlloc(n, al); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace ld::mesh {
namespace {

constexpr int kEdits = 4000;
constexpr int kSlitEdits = 800;  // row edges available on the 10k slab: about 1000

// A slab with the tissue properties, built once per size and copied per run; the copy
// is made before the timed loop (like the cutter's addObject).
const SurfaceMesh& baseSlab(int triangles) {
  static std::map<int, SurfaceMesh> cache;
  auto it = cache.find(triangles);
  if (it == cache.end()) {
    SurfaceMesh m = physics::makeSlabWithTriangles(triangles);
    physics::attachTissueProperties(m, physics::TissueParams{});
    it = cache.emplace(triangles, std::move(m)).first;
  }
  return it->second;
}

// The slab for a run: range(0) triangles; range(1) = 1 reserves room for the run's
// growth first (SurfaceMesh::reserve), so that the edits are measured without the
// property arrays' reallocations (0: a fresh copy, as after the cutter's addObject,
// whose first edits reallocate every array once; amortized over the run).
SurfaceMesh slabFor(const benchmark::State& state) {
  SurfaceMesh m = baseSlab(static_cast<int>(state.range(0)));
  if (state.range(1) != 0) {
    const std::size_t n = 4 * static_cast<std::size_t>(kEdits);
    m.reserve(m.verticesSize() + n, m.edgesSize() + 3 * n, m.facesSize() + 2 * n);
  }
  return m;
}

// Small, fast, deterministic random numbers (the generator must not dominate).
struct Rng {
  std::uint64_t s = 0x9E3779B97F4A7C15ull;
  std::uint32_t operator()(std::size_t n) {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return static_cast<std::uint32_t>(s % n);
  }
};

void finish(benchmark::State& state, const SurfaceMesh& m, std::uint64_t allocs, long edits) {
  state.counters["allocs_per_edit"] = static_cast<double>(allocs) / static_cast<double>(std::max(1L, edits));
  state.counters["faces"] = static_cast<double>(m.nFaces());
  state.counters["edits"] = static_cast<double>(edits);
  state.counters["ns_per_edit"] = benchmark::Counter(static_cast<double>(std::max(1L, edits)) * 1e-9,
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_SplitEdge(benchmark::State& state) {
  SurfaceMesh m = slabFor(state);
  Rng rng;
  const std::uint64_t a0 = gAllocations;
  for (auto _ : state) {
    const Edge e(rng(m.edgesSize()));  // split edges stay live: every index is one
    benchmark::DoNotOptimize(m.splitEdge(e, 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1)))));
  }
  finish(state, m, gAllocations - a0, static_cast<long>(state.iterations()));
}

void BM_SplitFace(benchmark::State& state) {
  SurfaceMesh m = slabFor(state);
  Rng rng;
  const std::uint64_t a0 = gAllocations;
  for (auto _ : state) {
    const Face f(rng(m.facesSize()));  // split faces stay live
    benchmark::DoNotOptimize(m.splitFace(f, m.centroid(f)));
  }
  finish(state, m, gAllocations - a0, static_cast<long>(state.iterations()));
}

// Half of the faces around a random vertex, as a connected run (walked across the
// edges at v; a stack buffer, so the walk itself does not allocate).
void BM_SplitVertexFan(benchmark::State& state) {
  SurfaceMesh m = slabFor(state);
  Rng rng;
  long edits = 0;
  const std::uint64_t a0 = gAllocations;
  for (auto _ : state) {
    std::array<Face, 32> fan{};
    std::size_t n = 0, valence = 0;
    Vertex v;
    while (true) {
      v = Vertex(rng(m.verticesSize()));
      valence = m.valence(v);
      if (valence >= 4 && valence <= 32) break;
    }
    Edge prev = m.edges(v)[0];
    Face f = m.face(prev, 0);
    while (n < valence / 2) {
      fan[n++] = f;
      // The other edge of f at v, and the face across it.
      const int i = m.localIndex(f, v);
      const auto& fe = m.edges(f);
      Edge next = fe[static_cast<std::size_t>(i)] == prev ? fe[static_cast<std::size_t>((i + 2) % 3)]
                                                          : fe[static_cast<std::size_t>(i)];
      const Face g = m.otherFace(next, f);
      if (!g.isValid()) break;
      prev = next;
      f = g;
    }
    if (m.splitVertex(v, std::span<const Face>(fan.data(), n)).isValid()) ++edits;
  }
  finish(state, m, gAllocations - a0, edits);
}

// Slits along the rows of the top surface's lattice: each row starts at a small hole
// (one face deleted before the timed loop), and each edit separates the next edge
// of the row, splitting the vertex at the slit's end (what the cutter does per edge).
void BM_SeparateEdge(benchmark::State& state) {
  SurfaceMesh m = slabFor(state);
  double zTop = -1e300;
  for (Vertex v : m.vertices()) zTop = std::max(zTop, m.position(v).z());
  std::map<double, std::vector<Vertex>> rows;  // y -> top vertices
  for (Vertex v : m.vertices())
    if (m.position(v).z() == zTop) rows[m.position(v).y()].push_back(v);
  std::vector<Edge> order;
  std::size_t row = 0;
  for (auto& [y, vs] : rows) {
    if (row++ % 2 == 0 || vs.size() < 4) continue;  // every other row, away from each other
    std::sort(vs.begin(), vs.end(), [&](Vertex a, Vertex b) { return m.position(a).x() < m.position(b).x(); });
    // Open a hole at the second vertex so that the slit can start there.
    const Edge first = m.findEdge(vs[1], vs[2]);
    if (!first.isValid() || m.isBoundary(first)) continue;
    m.deleteFace(m.face(first, 0));
    for (std::size_t i = 2; i + 2 < vs.size(); ++i) {
      const Edge e = m.findEdge(vs[i], vs[i + 1]);
      if (e.isValid()) order.push_back(e);
    }
  }
  std::size_t next = 0;
  long edits = 0;
  const std::uint64_t a0 = gAllocations;
  for (auto _ : state) {
    if (next == order.size()) continue;  // out of row edges: `edits` says how many were done
    const Edge e = order[next++];
    if (m.isValid(e) && !m.isBoundary(e) && m.separateEdge(e).isValid()) ++edits;
  }
  finish(state, m, gAllocations - a0, edits);
}

// deleteFace of a random face, then addFace of the same triangle (a new handle).
void BM_DeleteAddFace(benchmark::State& state) {
  SurfaceMesh m = slabFor(state);
  Rng rng;
  long edits = 0;
  const std::uint64_t a0 = gAllocations;
  for (auto _ : state) {
    Face f(rng(m.facesSize()));
    while (m.isDeleted(f)) f = Face(rng(m.facesSize()));
    const auto vs = m.vertices(f);
    m.deleteFace(f);
    benchmark::DoNotOptimize(m.addFace(vs[0], vs[1], vs[2]));
    edits += 2;
  }
  finish(state, m, gAllocations - a0, edits);
}

// Time per iteration is per edit, except for BM_DeleteAddFace (two edits; see
// ns_per_edit) and BM_SeparateEdge (see edits).
#define LD_MESH_EDIT_BENCH(fn, n)              \
  BENCHMARK(fn)                                \
      ->ArgsProduct({{10000, 100000}, {0, 1}}) \
      ->ArgNames({"tris", "reserved"})         \
      ->Iterations(n)                          \
      ->Repetitions(3)                         \
      ->Unit(benchmark::kNanosecond)

LD_MESH_EDIT_BENCH(BM_SplitEdge, kEdits);
LD_MESH_EDIT_BENCH(BM_SplitFace, kEdits);
LD_MESH_EDIT_BENCH(BM_SplitVertexFan, kEdits);
LD_MESH_EDIT_BENCH(BM_SeparateEdge, kSlitEdits);
LD_MESH_EDIT_BENCH(BM_DeleteAddFace, kEdits / 2);

}  // namespace
}  // namespace ld::mesh

BENCHMARK_MAIN();
