// XPBD: selectable by name, stable far past the explicit methods' step limit, and it
// brings a pushed patch back to the rest shape the other methods reach.
#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/physics_error.h"
#include "sim/physics/scenes.h"
#include "tests/sim/physics/physics_test_util.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;

using testutil::pushedPatch;

TEST(Xpbd, SelectableByNameButNotInTheCharts) {
  EXPECT_EQ(methodFromName("xpbd"), Method::Xpbd);
  EXPECT_EQ(methodName(Method::Xpbd), "xpbd");
  for (Method m : allMethods()) EXPECT_NE(m, Method::Xpbd);
  try {
    (void)methodFromName("nope");
    FAIL();
  } catch (const UnknownNameError& e) {
    EXPECT_NE(std::string(e.what()).find("xpbd"), std::string::npos);
  }
}

TEST(Xpbd, StableWithoutTheMonitorWhereExplicitMethodsDiverge) {
  Params p;
  p.method = Method::Xpbd;
  p.tissue.damping = 0.0;
  State s = pushedPatch(p);
  const double e0 = energy(p, s).total();
  for (int i = 0; i < 200; ++i) {
    ASSERT_TRUE(rawStep(p, s, Method::Xpbd, 0.02)) << i;  // 20 ms: explicit methods diverge (stability_test)
    ASSERT_LE(energy(p, s).total(), e0 * (1.0 + 1e-9)) << i;
  }
}

TEST(Xpbd, ReturnsToTheRestShape) {
  Params pi;
  pi.method = Method::ImplicitEuler;
  State ref = pushedPatch(pi);
  for (int i = 0; i < 1500; ++i) step(pi, ref, 2e-3);
  Params px;
  px.method = Method::Xpbd;
  px.xpbdIterations = 20;
  State s = pushedPatch(px);
  const double moved = testutil::maxDiff(s.mesh.positions(), ref.mesh.positions());
  for (int i = 0; i < 1500; ++i) step(px, s, 2e-3);
  EXPECT_EQ(s.stability.warnings, 0u);
  EXPECT_LT(testutil::maxDiff(s.mesh.positions(), ref.mesh.positions()), 0.05 * moved);
  EXPECT_LT(energy(px, s).kinetic, 1e-6);
}

}  // namespace
}  // namespace ld::physics
