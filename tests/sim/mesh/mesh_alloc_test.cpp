// Heap allocations of the edits in steady state: none once the property arrays have
// room (a vertex's edge list is inline up to 10 edges), bar a list outgrowing that.
// This program replaces the global operator new to count (its own executable, so that
// no other suite runs with it).
#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#include <gtest/gtest.h>

#include "sim/mesh/surface_mesh.h"
#include "tests/sim/mesh/grid_mesh.h"

namespace {
std::uint64_t gAllocations = 0;
void* counted(std::size_t n) {
  ++gAllocations;
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace ld::mesh {
namespace {

// n x n grid with an edge and a face property, copied (as the cutter copies a model),
// with room reserved for `edits` more edits.
SurfaceMesh copiedGrid(int n, std::size_t edits) {
  SurfaceMesh m = test::grid(n);
  m.addVertexProperty<Point>("v:home", Point::Zero());
  m.addEdgeProperty<double>("e:rest", 1.0);
  m.addFaceProperty<int>("f:tag", 2);
  SurfaceMesh copy = m;
  copy.reserve(copy.verticesSize() + edits, copy.edgesSize() + 4 * edits, copy.facesSize() + 3 * edits);
  return copy;
}

// Spread over the grid so that most edits touch vertices no earlier edit touched
// (their edge lists are the copy's).
std::uint32_t spread(std::size_t i, std::size_t n) { return static_cast<std::uint32_t>((i * 7919) % n); }

constexpr std::size_t kEdits = 300;

// reserve() gives the journal room too; a vertex whose edge list outgrows its inline
// room allocates, a few times a run (0-2 of 300 edits here; a std::vector per vertex
// list made it one per edit).
constexpr double kBound = 0.05;

// Edits far from where the tests work (the last rows), so that the journal and the
// edits' scratch buffers have grown to a steady state before counting.
void warmUp(SurfaceMesh& m) {
  for (int i = 0; i < 100; ++i) {
    const Face f(static_cast<std::uint32_t>(m.facesSize() - 1 - static_cast<std::size_t>(i % 40)));
    m.splitFace(f, m.centroid(f));
  }
  for (std::uint32_t i = 0; i < 5; ++i) {  // a short slit into row 28 (31 vertices a row)
    const Edge e = m.findEdge(Vertex(28 * 31 + i), Vertex(28 * 31 + i + 1));
    if (e.isValid() && !m.isBoundary(e)) m.separateEdge(e);
  }
}

TEST(SurfaceMeshAllocations, SplitEdgeAndSplitFaceAlmostNeverAllocate) {
  SurfaceMesh m = copiedGrid(30, 3 * kEdits);
  const std::size_t ne = m.edgesSize(), nf = m.facesSize();
  warmUp(m);
  const std::uint64_t a0 = gAllocations;
  std::size_t splits = 0;
  for (std::size_t i = 0; i < kEdits; ++i) {
    const Edge e(spread(i, ne));
    if (m.isDeleted(e)) continue;  // the warm-up's slit replaced a few edges
    ASSERT_TRUE(m.splitEdge(e, 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1)))).isValid());
    ++splits;
  }
  ASSERT_GT(splits, kEdits - 10);
  const std::uint64_t a1 = gAllocations;
  for (std::size_t i = 0; i < kEdits; ++i) {
    const Face f(spread(i + 1, nf));
    ASSERT_TRUE(m.splitFace(f, m.centroid(f)).isValid());
  }
  const std::uint64_t a2 = gAllocations;
  EXPECT_LE(static_cast<double>(a1 - a0), kBound * static_cast<double>(splits)) << "splitEdge";
  EXPECT_LE(static_cast<double>(a2 - a1), kBound * kEdits) << "splitFace";
  EXPECT_TRUE(m.validate().ok());
}

TEST(SurfaceMeshAllocations, SplitVertexAlmostNeverAllocates) {
  SurfaceMesh m = copiedGrid(30, 3 * kEdits);
  warmUp(m);
  std::size_t splits = 0;
  std::uint64_t splitAllocs = 0;
  std::vector<Face> fan;
  fan.reserve(16);
  for (std::size_t i = 0; i < kEdits; ++i) {
    const Vertex v(spread(i, m.verticesSize()));
    if (m.isBoundary(v) || m.valence(v) < 4) continue;
    fan.clear();
    fan.push_back(m.face(m.edges(v)[0], 0));  // one face: a connected run
    const std::uint64_t a = gAllocations;
    if (m.splitVertex(v, fan).isValid()) ++splits;
    splitAllocs += gAllocations - a;
  }
  ASSERT_GT(splits, kEdits / 2);
  EXPECT_LE(static_cast<double>(splitAllocs), kBound * static_cast<double>(splits));
  EXPECT_TRUE(m.validate().ok());
}

TEST(SurfaceMeshAllocations, SeparateEdgeAlmostNeverAllocates) {
  SurfaceMesh m = copiedGrid(30, 3 * kEdits);
  warmUp(m);
  std::size_t separations = 0;
  std::uint64_t separateAllocs = 0;
  // A slit from the boundary inwards along row 15: each edit splits one vertex.
  for (int i = 0; i < 25; ++i) {
    const Edge e = m.findEdge(Vertex(15 * 31 + i), Vertex(15 * 31 + i + 1));
    if (!e.isValid() || m.isBoundary(e)) continue;
    const std::uint64_t a = gAllocations;
    if (m.separateEdge(e).isValid()) ++separations;
    separateAllocs += gAllocations - a;
  }
  ASSERT_GT(separations, 20u);
  EXPECT_LE(static_cast<double>(separateAllocs), kBound * static_cast<double>(separations));
  EXPECT_TRUE(m.validate().ok());
}

TEST(SurfaceMeshAllocations, DeleteAndAddFaceDoNotAllocate) {
  SurfaceMesh m = copiedGrid(30, 3 * kEdits);
  const std::size_t nf = m.facesSize();
  warmUp(m);
  const std::uint64_t a0 = gAllocations;
  for (std::size_t i = 0; i < kEdits; ++i) {
    const Face f(spread(i, nf));
    if (m.isDeleted(f)) continue;
    const auto vs = m.vertices(f);
    m.deleteFace(f);
    ASSERT_TRUE(m.addFace(vs[0], vs[1], vs[2]).isValid());
  }
  EXPECT_LE(gAllocations - a0, 6u);  // journal growth only
  EXPECT_TRUE(m.validate().ok());
}

}  // namespace
}  // namespace ld::mesh
