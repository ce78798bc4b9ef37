#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"
#include "tests/sim/physics/physics_test_util.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;

TEST(ActiveRegion, LocalPushCostsLittleAndStaysCloseToTheFullSolve) {
  Params p;
  State eq = makeState(makeGrid(30, 30, 4.0), p.tissue);
  settle(p, eq);
  Params local = p;
  local.active.enabled = true;
  State full = eq, act = eq;
  const auto v = nearestVertex(eq.mesh, Vec3(60, 60, 0));
  auto push = [&](State& s, bool on) {
    s.mesh.getVertexProperty<Vec3>(kForceProp)[v] = on ? Vec3(0, 0, -5.0) : Vec3::Zero();
  };
  std::size_t worked = 0, total = 0;
  double maxDiff = 0;
  for (int i = 0; i < 600; ++i) {
    const bool on = i < 300;
    push(full, on);
    push(act, on);
    step(p, full, 1e-3);
    worked += step(local, act, 1e-3).activeVertices;
    total += act.mesh.nVertices();
    maxDiff = std::max(maxDiff, testutil::maxDiff(full.mesh.positions(), act.mesh.positions()));
  }
  // The push moved the tissue by millimetres …
  EXPECT_GT(testutil::maxDiff(eq.mesh.positions(), testutil::positionsOf(full)), 0.0);
  // … the active region integrated well under half the vertex-steps …
  EXPECT_LT(static_cast<double>(worked), 0.5 * static_cast<double>(total));
  // … and stayed within a hundredth or two of a millimetre of the full solve.
  EXPECT_LT(maxDiff, 0.02);
  EXPECT_TRUE(isFinite(act));
}

TEST(ActiveRegion, UntouchedSettledTissueFallsAsleep) {
  Params p;
  p.active.enabled = true;
  State s = makeState(makeGrid(10, 10, 4.0), p.tissue);
  Params fullP = p;
  fullP.active.enabled = false;
  settle(fullP, s);
  std::size_t last = 0;
  for (int i = 0; i < 100; ++i) last = step(p, s, 1e-3).activeVertices;
  EXPECT_EQ(last, 0u);
  // Contact wakes it up again.
  s.mesh.getVertexProperty<Vec3>(kForceProp)[mesh::Vertex(std::size_t{50})] = Vec3(0, 0, -1);
  EXPECT_GT(step(p, s, 1e-3).activeVertices, 0u);
  for (int i = 0; i < 50; ++i) step(p, s, 1e-3);
  EXPECT_GT(step(p, s, 1e-3).activeVertices, 7u);  // spread to the neighbours
}

// Without the O(vertices) force scan, contacts named with wake() give the same motion
// bit for bit, and a force on a sleeper nobody named is not seen.
TEST(ActiveRegion, NamedContactsMatchTheForceScan) {
  Params scan;
  scan.active.enabled = true;
  Params named = scan;
  named.active.scanExternalForces = false;
  State eq = makeState(makeGrid(20, 20, 4.0), scan.tissue);
  Params fullP = scan;
  fullP.active.enabled = false;
  settle(fullP, eq);
  State a = eq, b = eq;
  for (int i = 0; i < 60; ++i) {  // everything falls asleep
    step(scan, a, 1e-3);
    step(named, b, 1e-3);
  }
  ASSERT_EQ(step(named, b, 1e-3).activeVertices, 0u);
  step(scan, a, 1e-3);
  const mesh::Vertex v = nearestVertex(eq.mesh, Vec3(40, 40, 0));
  std::size_t workedA = 0, workedB = 0;
  double pushedBy = 0.0;
  for (int i = 0; i < 400; ++i) {
    const Vec3 f = i < 200 ? Vec3(0, 0, -5.0) : Vec3::Zero();
    a.mesh.getVertexProperty<Vec3>(kForceProp)[v] = f;
    b.mesh.getVertexProperty<Vec3>(kForceProp)[v] = f;
    if (i == 0) wake(b, std::span<const mesh::Vertex>(&v, 1));
    workedA += step(scan, a, 1e-3).activeVertices;
    workedB += step(named, b, 1e-3).activeVertices;
    ASSERT_EQ(testutil::maxDiff(a.mesh.positions(), b.mesh.positions()), 0.0) << "step " << i;
    if (i == 199) pushedBy = testutil::maxDiff(eq.mesh.positions(), testutil::positionsOf(a));
  }
  EXPECT_EQ(workedA, workedB);
  EXPECT_GT(workedA, 400u);  // the push woke a region, not just the vertex
  EXPECT_GT(pushedBy, 0.2);  // mm

  // Let it fall asleep again, then push without naming the vertex: nothing moves.
  for (int i = 0; i < 2000 && step(named, b, 1e-3).activeVertices > 0; ++i) {
  }
  ASSERT_EQ(step(named, b, 1e-3).activeVertices, 0u);
  const auto before = testutil::positionsOf(b);
  b.mesh.getVertexProperty<Vec3>(kForceProp)[v] = Vec3(0, 0, -5.0);
  EXPECT_EQ(step(named, b, 1e-3).activeVertices, 0u);
  EXPECT_EQ(testutil::maxDiff(before, testutil::positionsOf(b)), 0.0);
  wake(b, std::span<const mesh::Vertex>(&v, 1));
  EXPECT_EQ(step(named, b, 1e-3).activeVertices, 1u);
  EXPECT_GT(testutil::maxDiff(before, testutil::positionsOf(b)), 0.0);
}

// A cut's edits wake the vertices they touched, not the whole tissue: the first step
// after them integrates a handful of vertices, the region grows only as far as the
// change pulls, and the motion stays close to the full solve.
TEST(ActiveRegion, ATopologyEditWakesOnlyItsNeighbourhood) {
  Params p;
  p.tissue.massFloorDt = 1e-3;  // as the cutter's users set it: no vertex too light for dt
  p.active.enabled = true;
  p.active.scanExternalForces = false;
  Params fullP = p;
  fullP.active.enabled = false;
  State s = makeState(makeGrid(40, 40, 4.0), p.tissue);
  settle(fullP, s);
  for (int i = 0; i < 3000 && step(p, s, 1e-3).activeVertices > 0; ++i) {
  }
  ASSERT_EQ(step(p, s, 1e-3).activeVertices, 0u);
  const auto restarts = s.active.restarts;

  // Local edits near the centre: two edge splits and a face split (new stretched
  // springs, new vertices, new masses).
  auto& m = s.mesh;
  const mesh::Vertex c = nearestVertex(m, Vec3(80, 80, 0));
  std::vector<mesh::Edge> around;
  for (mesh::Edge e : m.edges(c)) around.push_back(e);
  ASSERT_GE(around.size(), 3u);
  for (int k = 0; k < 2; ++k) {
    const auto a = m.vertex(around[k], 0), b = m.vertex(around[k], 1);
    const auto v = m.splitEdge(around[k], 0.5 * (m.position(a) + m.position(b)));
    initVertexOnEdge(m, v, a, b, 0.5, p.tissue);
    for (mesh::Edge e2 : m.edges(v)) initEdge(m, e2, p.tissue);
  }
  mesh::Face f;
  for (mesh::Face g : m.faces(c)) f = g;
  const auto vs = m.vertices(f);
  const auto v = m.splitFace(f, m.centroid(f));
  initVertexInFace(m, v, vs[0], vs[1], vs[2], Vec3::Constant(1.0 / 3.0), p.tissue);
  for (mesh::Edge e : m.edges(v)) initEdge(m, e, p.tissue);
  ASSERT_TRUE(m.validate().ok()) << m.validate().message();

  State full = s;
  const auto before = testutil::positionsOf(s);
  const std::size_t first = step(p, s, 1e-3).activeVertices;
  step(fullP, full, 1e-3);
  EXPECT_EQ(s.active.restarts, restarts) << "the edit woke every vertex";
  EXPECT_GT(first, 3u);                          // the new vertices and their neighbours
  EXPECT_LT(first, m.nVertices() / 20);          // not the tissue
  std::size_t worked = first, total = m.nVertices();
  double maxDiff = 0;
  for (int i = 0; i < 400; ++i) {
    worked += step(p, s, 1e-3).activeVertices;
    step(fullP, full, 1e-3);
    total += m.nVertices();
    maxDiff = std::max(maxDiff, testutil::maxDiff(full.mesh.positions(), s.mesh.positions()));
  }
  // The edit moved the tissue (the new springs are pre-stretched) …
  EXPECT_GT(testutil::maxDiff(before, testutil::positionsOf(full)), 0.01);
  // … the active region followed it with a small share of the work …
  EXPECT_LT(static_cast<double>(worked), 0.5 * static_cast<double>(total));
  // … and stayed close to the full solve.
  EXPECT_LT(maxDiff, 0.02);
  EXPECT_TRUE(isFinite(s));

  // A new layout (a copy renumbers nothing, but its cache and set start afresh).
  State copy;
  copy.mesh = s.mesh;
  EXPECT_EQ(step(p, copy, 1e-3).activeVertices, copy.mesh.nVertices());
}

}  // namespace
}  // namespace ld::physics
