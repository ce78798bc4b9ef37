// The spring cache follows topology edits through the mesh's edit journal: after
// many local updates it gives the same forces and energy as a cache built from
// scratch, and one and two threads still agree bit for bit.
#include <random>

#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"
#include "tests/sim/physics/physics_test_util.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;

using testutil::randomEdits;

TEST(CacheUpdate, LocalUpdatesMatchARebuild) {
  Params p;
  State s = makeState(makeGrid(20, 20, 3.0), p.tissue);
  s.mesh.position(nearestVertex(s.mesh, Vec3(30, 30, 0))).z() -= 3.0;
  std::mt19937 rng(7);
  step(p, s, 1e-3);
  const auto rebuilds = s.cache.rebuilds;
  for (int round = 0; round < 20; ++round) {
    randomEdits(s.mesh, p.tissue, rng, 5);
    step(p, s, 1e-3);
    ASSERT_TRUE(isFinite(s));
  }
  EXPECT_EQ(s.cache.rebuilds, rebuilds);
  EXPECT_EQ(s.cache.localUpdates, 20u);
  EXPECT_EQ(s.cache.liveSprings, s.mesh.nEdges());
  // A copy has a new layout, so its cache is built from scratch.
  State fresh;
  fresh.mesh = s.mesh;
  const auto fa = forces(p, s), fb = forces(p, fresh);
  ASSERT_EQ(fa.size(), fb.size());
  double scale = 0.0;
  for (const Vec3& f : fb) scale = std::max(scale, f.norm());
  EXPECT_LT(testutil::maxDiff(fa, fb), 1e-12 * scale + 1e-15);
  EXPECT_NEAR(energy(p, s).total(), energy(p, fresh).total(), 1e-12 * energy(p, fresh).total());
  EXPECT_GT(fresh.cache.rebuilds, 0u);
  // Deleted vertices (isolated by face deletion keep their mass) never get NaN, and
  // stepping both gives the same motion up to rounding.
  for (int i = 0; i < 20; ++i) {
    step(p, s, 1e-3);
    step(p, fresh, 1e-3);
  }
  EXPECT_LT(testutil::maxDiff(s.mesh.positions(), fresh.mesh.positions()), 1e-9);
}

TEST(CacheUpdate, ManyEditsFallBackToARebuild) {
  Params p;
  State s = makeState(makeGrid(12, 12, 3.0), p.tissue);
  std::mt19937 rng(3);
  step(p, s, 1e-3);
  const auto rebuilds = s.cache.rebuilds;
  randomEdits(s.mesh, p.tissue, rng, 400);  // far more added springs than an eighth of the mesh
  step(p, s, 1e-3);
  EXPECT_EQ(s.cache.rebuilds, rebuilds + 1);
  EXPECT_EQ(s.cache.springs.size(), s.mesh.nEdges());
  EXPECT_EQ(s.cache.nCsr, s.cache.springs.size());
}

TEST(CacheUpdate, TwoThreadsAgreeAfterEdits) {
  Params one;
  State a = makeState(makeGrid(50, 50, 4.0), one.tissue);
  a.mesh.position(nearestVertex(a.mesh, Vec3(100, 100, 0))).z() -= 5.0;
  Params two = one;
  two.threads = 2;
  State b = a;
  std::mt19937 ra(11), rb(11);
  for (int round = 0; round < 5; ++round) {
    randomEdits(a.mesh, one.tissue, ra, 30);
    randomEdits(b.mesh, one.tissue, rb, 30);
    for (int i = 0; i < 4; ++i) {
      step(one, a, 1e-3);
      step(two, b, 1e-3);
    }
  }
  EXPECT_GT(b.cache.localUpdates, 0u);
  EXPECT_EQ(a.mesh.positions(), b.mesh.positions());
}

}  // namespace
}  // namespace ld::physics
