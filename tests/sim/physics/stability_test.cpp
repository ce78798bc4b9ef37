// The stability monitor: divergence becomes a warning and a recovery, and no
// non-finite value ever reaches the state that renderers and metrics read.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"
#include "tests/sim/physics/physics_test_util.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;

using testutil::pushedPatch;

TEST(Stability, ExplicitMethodsPastTheirLimitNeverPublishNaN) {
  for (Method m : {Method::ExplicitEuler, Method::SymplecticEuler, Method::Verlet, Method::Rk4}) {
    Params p;
    p.method = m;
    p.tissue.damping = 0.0;
    // 20 ms is several times every explicit method's limit on this patch.
    const double dt = 0.02;
    State raw = pushedPatch(p);
    bool rawDiverged = false;
    for (int i = 0; i < 200 && !rawDiverged; ++i) {
      rawStep(p, raw, m, dt);
      rawDiverged = !isFinite(raw) || energy(p, raw).total() > 1e6;
    }
    ASSERT_TRUE(rawDiverged) << methodName(m) << " should diverge without the monitor";

    State s = pushedPatch(p);
    const double e0 = energy(p, s).total();
    for (int i = 0; i < 200; ++i) {
      step(p, s, dt);
      ASSERT_TRUE(isFinite(s)) << methodName(m) << " step " << i;
      ASSERT_LE(energy(p, s).total(), 2.0 * e0 + 1e-9) << methodName(m) << " step " << i;
    }
    EXPECT_GT(s.stability.warnings, 0u) << methodName(m);
    EXPECT_GT(s.stability.substepRetries + s.stability.implicitFallbacks, 0u) << methodName(m);
    EXPECT_FALSE(s.stability.lastReason.empty());
  }
}

TEST(Stability, WithinTheLimitNoWarnings) {
  Params p;
  State s = pushedPatch(p);
  for (int i = 0; i < 500; ++i) step(p, s, 1e-3);
  EXPECT_EQ(s.stability.warnings, 0u);
}

TEST(Stability, NonFiniteExternalForceIsContained) {
  Params p;
  State s = pushedPatch(p);
  const auto before = s.mesh.positions();
  auto ext = s.mesh.getVertexProperty<Vec3>(kForceProp);
  ext.vector()[5] = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  step(p, s, 1e-3);
  EXPECT_TRUE(isFinite(s));
  EXPECT_EQ(s.mesh.positions(), before);  // last good positions kept
  EXPECT_EQ(s.stability.velocityResets, 1u);
  EXPECT_EQ(s.stability.lastReason, "non-finite");
}

TEST(Stability, SubstepsStickAfterARecovery) {
  Params p;
  p.method = Method::SymplecticEuler;
  State s = pushedPatch(p);
  const auto info = step(p, s, 0.006);
  EXPECT_FALSE(info.accepted);
  EXPECT_GT(info.substeps, 1);
  const auto warnings = s.stability.warnings;
  const auto next = step(p, s, 0.006);
  EXPECT_TRUE(next.accepted);  // the sticky substep count is used straight away
  EXPECT_EQ(s.stability.warnings, warnings);
}

}  // namespace
}  // namespace ld::physics
