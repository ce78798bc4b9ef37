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

}  // namespace
}  // namespace ld::physics
