// Stepping a mesh owned elsewhere (Dynamics + mesh) gives exactly what a State gives,
// and picks up topology edits made between steps.
#include <cfloat>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"
#include "sim/physics/spring_kernel.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;

State pushedGrid(const Params& p) {
  State s = makeState(makeGrid(12, 12, 3.0), p.tissue);
  s.mesh.position(nearestVertex(s.mesh, Vec3(18, 18, 0))).z() -= 4.0;
  return s;
}

std::vector<Vec3> velocitiesOf(const mesh::SurfaceMesh& m) { return m.getVertexProperty<Vec3>(kVelocityProp).vector(); }

TEST(Dynamics, InPlaceStepEqualsStateStepBitForBit) {
  for (Method method : allMethods()) {
    Params p;
    p.method = method;
    State s = pushedGrid(p);
    mesh::SurfaceMesh owned = s.mesh;  // e.g. a cutter's object
    Dynamics d;
    for (int i = 0; i < 15; ++i) {
      const StepInfo a = step(p, s, 1e-3);
      const StepInfo b = step(p, d, owned, 1e-3);
      ASSERT_EQ(a.accepted, b.accepted);
    }
    EXPECT_EQ(owned.positions(), s.mesh.positions()) << methodName(method);
    EXPECT_EQ(velocitiesOf(owned), velocitiesOf(s.mesh)) << methodName(method);
    EXPECT_EQ(d.steps, s.steps);
    EXPECT_DOUBLE_EQ(d.time, s.time);
    EXPECT_EQ(energy(p, d, owned).total(), energy(p, s).total());
    EXPECT_EQ(forces(p, d, owned), forces(p, s));
    EXPECT_EQ(maxResidualForce(p, d, owned), maxResidualForce(p, s));
  }
}

TEST(Dynamics, TopologyEditBetweenStepsIsPickedUp) {
  Params p;
  State s = pushedGrid(p);
  mesh::SurfaceMesh owned = s.mesh;
  Dynamics d;
  step(p, d, owned, 1e-3);
  step(p, s, 1e-3);
  const auto updates = d.cache.rebuilds + d.cache.localUpdates;
  // Split an edge in both copies the same way, as the cutter would.
  auto split = [&](mesh::SurfaceMesh& m) {
    const mesh::Edge e(7);
    const auto a = m.vertex(e, 0), b = m.vertex(e, 1);
    const auto v = m.splitEdge(e, 0.5 * (m.position(a) + m.position(b)));
    initVertexOnEdge(m, v, a, b, 0.5, p.tissue);
    ASSERT_TRUE(m.validate().ok());
  };
  split(owned);
  split(s.mesh);
  step(p, d, owned, 1e-3);
  step(p, s, 1e-3);
  EXPECT_GT(d.cache.rebuilds + d.cache.localUpdates, updates);
  EXPECT_EQ(d.cache.liveSprings, owned.nEdges());
  // The new vertex moves with the tissue and the new springs act on it: the energy
  // agrees with a fresh state built from the same mesh.
  for (int i = 0; i < 10; ++i) {
    step(p, d, owned, 1e-3);
    step(p, s, 1e-3);
  }
  EXPECT_EQ(owned.positions(), s.mesh.positions());
  State fresh;
  fresh.mesh = owned;
  EXPECT_NEAR(energy(p, fresh).total(), energy(p, d, owned).total(), 1e-12);
  EXPECT_TRUE(isFinite(owned));
}

TEST(Dynamics, SettleInPlace) {
  Params p;
  State s = pushedGrid(p);
  mesh::SurfaceMesh owned = s.mesh;
  Dynamics d;
  SettleOptions o;
  o.tolerance = 1e-2;
  const SettleResult a = settle(p, s, o);
  const SettleResult b = settle(p, d, owned, o);
  EXPECT_TRUE(b.converged);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(owned.positions(), s.mesh.positions());
}

// Dynamics::maxMove bounds every coordinate's move of the step (what a collision
// tree with fat boxes skips its pass on), also with two threads and on the first
// steps of a strongly pushed grid; unknown (+inf) where the step has no such sum.
TEST(Dynamics, MaxMoveBoundsTheStepsLargestMove) {
  for (int threads : {1, 2}) {
    Params p;
    p.threads = threads;
    State s = pushedGrid(p);
    double largest = 0.0;
    for (int i = 0; i < 200; ++i) {
      const std::vector<Vec3> before = s.mesh.positions();
      const StepInfo info = step(p, s, 1e-3);
      double moved = 0.0;
      for (std::size_t v = 0; v < before.size(); ++v)
        moved = std::max(moved, (s.mesh.positions()[v] - before[v]).cwiseAbs().maxCoeff());
      largest = std::max(largest, moved);
      if (info.accepted && info.substeps == 1) {
        ASSERT_TRUE(std::isfinite(s.maxMove)) << "step " << i;
        ASSERT_LE(moved, s.maxMove) << "step " << i;
        ASSERT_LE(s.maxMove, 1.001 * moved + 1e-12) << "a bound, but not a loose one";
      }
    }
    EXPECT_GT(largest, 1e-3) << "the scene should move";
  }
  for (Method method : {Method::Verlet, Method::ImplicitEuler}) {
    Params p;
    p.method = method;
    State s = pushedGrid(p);
    step(p, s, 1e-3);
    EXPECT_EQ(s.maxMove, std::numeric_limits<double>::infinity()) << methodName(method);
  }
  Params off;
  off.stability.enabled = false;
  State s = pushedGrid(off);
  step(off, s, 1e-3);
  EXPECT_EQ(s.maxMove, std::numeric_limits<double>::infinity()) << "the monitor's sums are off";
}

// body(p, s) on every step kernel this CPU has (forced), with one and two threads: s
// a 2601-vertex grid (a partial last group, past the two-thread size) pushed at one
// vertex, p = base with the threads and the group bounds (Params::groupMoves) set.
template <class Body>
void onPushedGroupGrid(const Params& base, Body&& body) {
  for (detail::Kernel kernel : {detail::Kernel::Scalar, detail::Kernel::Avx2, detail::Kernel::Avx512}) {
    if (!detail::kernelSupported(kernel)) continue;
    ASSERT_TRUE(detail::forceKernel(kernel));
    for (int threads : {1, 2}) {
      SCOPED_TRACE(std::string(detail::kernelName(kernel)) + " threads " + std::to_string(threads));
      Params p = base;
      p.threads = threads;
      p.groupMoves = true;
      State s = makeState(makeGrid(50, 50, 3.0), p.tissue);
      s.mesh.position(nearestVertex(s.mesh, Vec3(60, 60, 0))).z() -= 4.0;
      body(p, s);
      if (::testing::Test::HasFatalFailure()) break;
    }
    if (::testing::Test::HasFatalFailure()) break;
  }
  detail::forceKernel(std::nullopt);
}

// How far (per coordinate) the farthest vertex of group g (of kMoveGroup) is from `from`.
double groupMoved(const mesh::SurfaceMesh& m, const std::vector<Vec3>& from, std::size_t g) {
  constexpr std::size_t G = Dynamics::kMoveGroup;
  double moved = 0.0;
  for (std::size_t v = g * G; v < std::min(from.size(), (g + 1) * G); ++v)
    moved = std::max(moved, (m.positions()[v] - from[v]).cwiseAbs().maxCoeff());
  return moved;
}

// Dynamics::groupMoves2 bounds each group of kMoveGroup vertices' moves apart (what a
// collision tree looks at the fast vertices by): on every kernel, with one and two
// threads (a grid past the two-thread size), tight, with the largest group at
// maxMove; empty where maxMove is unknown or Params::groupMoves is off.
TEST(Dynamics, GroupMovesBoundEachGroupsMoves) {
  constexpr std::size_t G = Dynamics::kMoveGroup;
  onPushedGroupGrid(Params{}, [&](const Params& p, State& s) {
    std::size_t checked = 0, quiet = 0;
    for (int i = 0; i < 60; ++i) {
      const std::vector<Vec3> before = s.mesh.positions();
      const StepInfo info = step(p, s, 1e-3);
      const auto g2 = s.groupMoves2();
      if (!(info.accepted && info.substeps == 1)) {
        EXPECT_TRUE(g2.empty());
        continue;
      }
      const std::size_t n = before.size();
      ASSERT_EQ(g2.size(), (n + G - 1) / G);
      double largest = 0.0;
      for (std::size_t g = 0; g < g2.size(); ++g) {
        const double moved = groupMoved(s.mesh, before, g);
        const double bound = std::sqrt(g2[g]);
        // (Up to the rounding of x + dx, a few ulps of the coordinates, as maxMove.)
        ASSERT_LE(moved, bound + 4.0 * DBL_EPSILON * 150.0) << "step " << i << " group " << g;
        ASSERT_LE(bound, 1.001 * moved + 1e-12) << "a bound, but not a loose one";
        largest = std::max(largest, bound);
        quiet += bound < 0.1 * s.maxMove;
        ++checked;
      }
      EXPECT_NEAR(largest, s.maxMove, 1e-9 * s.maxMove) << "the largest group moved the most";
    }
    EXPECT_GT(checked, 1000u);
    EXPECT_GT(quiet, 0u) << "groups far from the push move less than the step's largest move";
  });
  Params unasked;
  State u = pushedGrid(unasked);
  step(unasked, u, 1e-3);
  ASSERT_TRUE(std::isfinite(u.maxMove));
  EXPECT_TRUE(u.groupMoves2().empty()) << "only taken when asked for";
  Params off;
  off.groupMoves = true;
  off.stability.enabled = false;
  State s = pushedGrid(off);
  step(off, s, 1e-3);
  EXPECT_TRUE(s.groupMoves2().empty()) << "the monitor's sums are off";
}

// The step's position and velocity buffers trade places with the mesh's every step;
// both keep room for the cutter's new vertices (a quarter more), so a vertex added
// after a step, or after the next, neither moves the arrays nor copies them.
TEST(Dynamics, StepLeavesRoomToAddVertices) {
  Params p;
  State s = pushedGrid(p);
  for (int i = 0; i < 2; ++i) {
    step(p, s, 1e-3);
    const std::size_t n = s.mesh.verticesSize();
    const auto& v = s.mesh.getVertexProperty<Vec3>(kVelocityProp).vector();
    EXPECT_GE(s.mesh.positions().capacity(), n + n / 4) << "step " << i;
    EXPECT_GE(v.capacity(), n + n / 4) << "step " << i;
    const Vec3* x0 = s.mesh.positions().data();
    const Vec3* v0 = v.data();
    s.mesh.addVertex(Vec3(0, 0, 50));
    EXPECT_EQ(s.mesh.positions().data(), x0) << "step " << i << ": the positions were moved";
    EXPECT_EQ(s.mesh.getVertexProperty<Vec3>(kVelocityProp).vector().data(), v0) << "step " << i;
  }
}

// Dynamics::groupTravel sums each group's move bounds (plus travelPad a step) from
// where the consumer last set the entry, and groupsPastLimit lists, in group order,
// every group whose entry is past travelLimit after a step: on every kernel, one and
// two threads. The test plays the collision tree: it takes the list, sets those
// entries to 0 and measures their moves from there. A renumbering (garbage
// collection) makes every entry +inf, so every group is listed.
TEST(Dynamics, GroupTravelSumsTheMovesFromEachReset) {
  constexpr std::size_t G = Dynamics::kMoveGroup;
  Params base;
  base.travelLimit = 0.5;
  base.travelPad = 1e-9;
  onPushedGroupGrid(base, [&](const Params& p, State& s) {
    const std::size_t n = s.mesh.verticesSize(), groups = (n + G - 1) / G;
    std::vector<Vec3> from = s.mesh.positions();  // each vertex where its entry was last set
    std::size_t listed = 0, steps = 0;
    for (int i = 0; i < 80; ++i) {
      step(p, s, 1e-3);
      const std::span<double> travel = s.groupTravel();
      ASSERT_EQ(travel.size(), groups);
      std::vector<std::uint32_t> want;
      for (std::size_t g = 0; g < groups; ++g)
        if (!(travel[g] <= p.travelLimit)) want.push_back(static_cast<std::uint32_t>(g));
      const auto past = s.groupsPastLimit();
      ASSERT_EQ(std::vector<std::uint32_t>(past.begin(), past.end()), want) << "step " << i;
      if (std::isfinite(s.maxMove)) {
        ++steps;
        for (std::size_t g = 0; g < groups; ++g)
          ASSERT_LE(groupMoved(s.mesh, from, g), travel[g]) << "step " << i << " group " << g;
      }
      listed += past.size();
      // As the tree does: the listed ones (all, after a step that was not summed) restart.
      for (std::size_t g = 0; g < groups; ++g) {
        if (std::isfinite(s.maxMove) && !std::binary_search(want.begin(), want.end(), static_cast<std::uint32_t>(g)))
          continue;
        travel[g] = 0.0;
        for (std::size_t v = g * G; v < std::min(n, (g + 1) * G); ++v) from[v] = s.mesh.positions()[v];
      }
      s.clearGroupsPastLimit();
    }
    EXPECT_GT(steps, 60u);
    EXPECT_GT(listed, 0u) << "groups pass the limit";
    EXPECT_LT(listed, steps * groups / 4) << "a group's entry sums several steps before it does";
    // Renumbered: every entry unknown, every group listed.
    s.mesh.garbageCollection();
    step(p, s, 1e-3);
    EXPECT_EQ(s.groupsPastLimit().size(), groups);
    EXPECT_TRUE(std::isinf(s.groupTravel()[0]));
  });
  Params unlimited;
  unlimited.groupMoves = true;
  State u = pushedGrid(unlimited);
  step(unlimited, u, 1e-3);
  EXPECT_TRUE(u.groupTravel().empty()) << "not summed without a limit";
  EXPECT_TRUE(u.groupsPastLimit().empty());
}

}  // namespace
}  // namespace ld::physics
