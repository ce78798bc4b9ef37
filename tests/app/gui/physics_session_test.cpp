// The GUI's physics session: settles the tissue, publishes snapshots the view can
// take, and moves the picked vertex toward the cursor's point (virtual spring).
#include "app/gui/physics_session.h"

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <thread>

#include "sim/physics/scenes.h"

namespace {

using ld::gui::PhysicsSession;
using ld::gui::RenderMesh;

// Waits (wall clock, generous bound) for a condition polled by the GUI-side update.
bool waitFor(const std::function<bool()>& cond) {
  for (int i = 0; i < 3000; ++i) {
    if (cond()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

TEST(PhysicsSession, SettlesThenFollowsThePushAndLetsGo) {
  PhysicsSession session(ld::physics::makeSlab(40.0, 30.0, 5.0, 2.5));
  RenderMesh m;
  bool topo = false;
  ASSERT_TRUE(waitFor([&] { return session.settled(); }));
  ASSERT_TRUE(waitFor([&] { return session.update(m, topo); }));
  ASSERT_FALSE(m.triangles.empty());
  EXPECT_TRUE(session.status().startsWith("Physics: t ="));

  // The top vertex nearest the centre.
  std::uint32_t top = 0;
  for (std::uint32_t v = 0; v < m.positions.size(); ++v) {
    const auto& p = m.positions[v];
    const auto& q = m.positions[top];
    if (p[2] > q[2] + 1e-3F ||
        (std::abs(p[2] - q[2]) <= 1e-3F && p[0] * p[0] + p[1] * p[1] < q[0] * q[0] + q[1] * q[1]))
      top = v;
  }
  const float z0 = m.positions[top][2];
  const Eigen::Vector3d target(m.positions[top][0], m.positions[top][1], z0 - 6.0);
  ASSERT_TRUE(waitFor([&] {
    session.pushToward(top, target);  // the GUI refreshes the pull every frame
    session.update(m, topo);
    return m.positions[top][2] < z0 - 1.0F;
  })) << "the pushed vertex did not move down";
  EXPECT_TRUE(session.status().contains("push"));
  EXPECT_FALSE(topo) << "pushing does not change the triangles";

  session.release();
  ASSERT_TRUE(waitFor([&] {
    session.update(m, topo);
    return std::abs(m.positions[top][2] - z0) < 0.05F;
  })) << "the tissue did not return after release";
}

}  // namespace
