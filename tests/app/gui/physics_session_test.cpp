// The GUI's physics session: settles the tissue, publishes snapshots the view can
// take, moves the picked vertex toward the cursor's point (virtual spring), and opens
// a cut in the pre-stretched tissue by several millimetres while the rest stays put.
#include "app/gui/physics_session.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <thread>

#include "sim/io/mesh_io.h"
#include "sim/physics/scenes.h"
#include "tests/app/gui/wound_measure.h"
#include "tests/support/test_support.h"

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

std::vector<RenderMesh> meshesOf(ld::gui::SceneFrame f) {
  std::vector<RenderMesh> out;
  for (auto& o : f.objects) out.push_back(std::move(o.mesh));
  return out;
}

// The straight cut-through the window's scripted strokes make (MainWindow::cutStroke):
// samples every half millimetre across the top, the blade `depth` mm deep.
void cutAlong(PhysicsSession& s, double x0, double x1, double y, double top, double depth) {
  const int n = static_cast<int>(std::ceil(std::abs(x1 - x0) / 0.5));
  const Eigen::Vector3d motion(x1 - x0, 0, 0);
  for (int k = 0; k <= n; ++k)
    s.cutSample(Eigen::Vector3d(x0 + (x1 - x0) * k / n, y, top), Eigen::Vector3d::UnitZ(), motion, depth);
  s.endCut();
}

// The default slab's session once it has settled, and its first frame after that.
std::unique_ptr<PhysicsSession> settledSlab(ld::gui::SceneFrame& first) {
  auto session =
      std::make_unique<PhysicsSession>(ld::io::readMesh(ld::test::resourcesDir() / "models" / "tissue_slab.obj"));
  EXPECT_TRUE(waitFor([&] { return session->settled(); }));
  session->sync();
  bool topo = false;
  EXPECT_TRUE(session->update(first, topo));
  return session;
}

TEST(PhysicsSession, ACutThroughOpensBySeveralMillimetresAndTheUncutTissueStaysPut) {
  if (!PhysicsSession::cuttingAvailable()) GTEST_SKIP() << "no cutting module in this build";
  ld::gui::SceneFrame before;
  const auto owned = settledSlab(before);
  PhysicsSession& session = *owned;
  ASSERT_FALSE(before.objects.empty());
  bool topo = false;
  const RenderMesh tissue = before.objects.at(0).mesh;

  // 60 mm through the 5 mm slab along y = 0, inside the rim: one object, a slit that
  // the pre-stretched springs pull open against the home springs.
  cutAlong(session, -30, 30, 0, tissue.bounds().max[2], 8);
  session.advance(1.0);  // 1000 steps at 1 kHz
  session.sync();
  ld::gui::SceneFrame after;
  ASSERT_TRUE(session.update(after, topo));
  ASSERT_EQ(after.objects.size(), 1u) << "a slit inside the rim frees nothing";
  const auto meshes = meshesOf(after);
  // The lips stand apart by several millimetres along the middle of the cut (about
  // 3.4 mm; the window's earlier 3 mN/mm home springs held them 1.7 mm apart).
  for (float x : {-10.0F, 0.0F, 10.0F}) EXPECT_GT(ld::gui::test::lipGap(meshes, x, 0.0F), 2.5) << "at x = " << x;
  // ... not at the ends, where the cut closes.
  EXPECT_LT(ld::gui::test::lipGap(meshes, -29.5F, 0.0F), 2.0);

  // Far from the cut the tissue has not moved (the home springs hold it), and nothing
  // is non-finite, nor did the stability monitor have to step in.
  const RenderMesh& m = meshes[0];
  double far = 0.0;
  for (const auto& t : tissue.triangles)
    for (auto v : t)
      if (std::abs(tissue.positions[v][1]) > 20.0F)
        for (int a = 0; a < 3; ++a)
          far = std::max(far, static_cast<double>(std::abs(m.positions[v][a] - tissue.positions[v][a])));
  EXPECT_LT(far, 0.3) << "the uncut tissue drifted";
  const auto st = session.stats();
  EXPECT_EQ(st.nanFrames, 0u);
  EXPECT_EQ(st.warnings, 0u);
  for (const auto& p : m.positions) ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
  // At rest again: a second later the lips are where they were (no ringing, no creep).
  const double gap0 = ld::gui::test::lipGap(meshes, 0.0F, 0.0F);
  session.advance(1.0);
  session.sync();
  ld::gui::SceneFrame later;
  ASSERT_TRUE(session.update(later, topo));
  EXPECT_NEAR(ld::gui::test::lipGap(meshesOf(later), 0.0F, 0.0F), gap0, 0.1);
}

// While a stroke is open the tissue is held still (time does not advance), and it moves
// again when the blade lifts; with the hold off it keeps moving under the blade.
TEST(PhysicsSession, HoldsTheTissueStillWhileTheBladeIsInIt) {
  if (!PhysicsSession::cuttingAvailable()) GTEST_SKIP() << "no cutting module in this build";
  PhysicsSession session(ld::physics::makeSlab(40.0, 30.0, 5.0, 2.5));
  ASSERT_TRUE(waitFor([&] { return session.settled(); }));
  const Eigen::Vector3d top(0, 0, 2.5), up = Eigen::Vector3d::UnitZ(), along = Eigen::Vector3d::UnitX();
  session.cutSample(top, up, along, 2.0);
  session.sync();
  const double held = session.simTime();
  session.advance(0.2);
  session.sync();
  EXPECT_EQ(session.simTime(), held) << "the tissue moved while the blade was in it";
  session.endCut();
  session.advance(0.2);
  session.sync();
  EXPECT_GE(session.simTime(), held + 0.2 - 1e-9) << "the tissue did not move again after the stroke";

  session.setHoldWhileCutting(false);
  session.cutSample(top + Eigen::Vector3d(1, 0, 0), up, along, 2.0);
  session.sync();
  const double live = session.simTime();
  session.advance(0.2);
  session.sync();
  EXPECT_GE(session.simTime(), live + 0.2 - 1e-9) << "with the hold off the tissue keeps moving";
  session.endCut();
}

// With the hold off the tissue moves under the blade, and what each sample adds settles
// at once where its springs balance (as `task run --physics on` does); held, nothing is
// settled (the wound opens with the tissue's own motion once the blade lifts). Both
// cuts open, and nothing goes non-finite.
TEST(PhysicsSession, WithTheHoldOffWhatACutAddsSettlesAtOnce) {
  if (!PhysicsSession::cuttingAvailable()) GTEST_SKIP() << "no cutting module in this build";
  ld::gui::SceneFrame before;
  const auto owned = settledSlab(before);
  PhysicsSession& session = *owned;
  ASSERT_FALSE(before.objects.empty());
  bool topo = false;
  const float top = before.objects.at(0).mesh.bounds().max[2];

  // Off the grid's lines (y = 0.4), so that the path splits edges: new vertices.
  cutAlong(session, -30, -5, 0.4, top, 8);  // held (the default)
  session.sync();
  EXPECT_EQ(session.stats().settledAdded, 0u) << "held still, the cut's additions were moved";
  const long heldCut = session.trianglesCut();
  ASSERT_GT(heldCut, 0);
  ld::gui::SceneFrame held;
  ASSERT_TRUE(session.update(held, topo));

  session.setHoldWhileCutting(false);
  cutAlong(session, 5, 30, 0.4, top, 8);
  session.sync();
  ASSERT_GT(session.trianglesCut(), heldCut);
  // The path's edge crossings on both layers (two a cell), not only its two ends; and
  // only what this stroke added (the held stroke's vertices were marked, not left over).
  ld::gui::SceneFrame live;
  ASSERT_TRUE(session.update(live, topo));
  const auto added = live.objects.at(0).mesh.positions.size() - held.objects.at(0).mesh.positions.size();
  EXPECT_GT(session.stats().settledAdded, 20u) << "the cut's additions on the moving tissue did not settle";
  EXPECT_LE(session.stats().settledAdded, added) << "more settled than the live stroke added";

  session.advance(1.0);
  session.sync();
  ld::gui::SceneFrame after;
  ASSERT_TRUE(session.update(after, topo));
  const auto meshes = meshesOf(after);
  EXPECT_GT(ld::gui::test::lipGap(meshes, -17.5F, 0.4F), 1.0) << "the held cut did not open";
  EXPECT_GT(ld::gui::test::lipGap(meshes, 17.5F, 0.4F), 1.0) << "the live cut did not open";
  const auto st = session.stats();
  EXPECT_EQ(st.nanFrames, 0u);
  for (const auto& m : meshes)
    for (const auto& p : m.positions) ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
}

TEST(PhysicsSession, AdvanceRunsStepsAtOnceAndStatsCountThem) {
  PhysicsSession session(ld::physics::makeSlab(40.0, 30.0, 5.0, 2.5));
  ASSERT_TRUE(waitFor([&] { return session.settled(); }));
  const double t0 = session.simTime();
  session.advance(0.25);
  session.sync();
  EXPECT_GE(session.simTime(), t0 + 0.25 - 1e-9) << "advance ran its 250 steps";
  const auto st = session.stats();
  EXPECT_GT(st.meanStepUs, 0.0);
  EXPECT_GE(st.maxStepUs, 0.0);
  EXPECT_EQ(st.nanFrames, 0u);
  EXPECT_TRUE(session.status().contains("NaN 0")) << session.status().toStdString();
}

// A tissue at rest publishes no frames (the idle window then draws nothing), while its
// clock runs on; what it last showed is where the tissue is, to a fraction of a pixel;
// a push brings the frames back.
TEST(PhysicsSession, ATissueAtRestPublishesNoFramesUntilItMoves) {
  PhysicsSession session(ld::physics::makeSlab(40.0, 30.0, 5.0, 2.5));
  RenderMesh shown;
  bool topo = false;
  ASSERT_TRUE(waitFor([&] { return session.settled(); }));
  int quiet = 0;  // polls in a row with no new frame, 10 ms apart (the publisher runs at 60 Hz)
  ASSERT_TRUE(waitFor([&] {
    quiet = session.update(shown, topo) ? 0 : quiet + 1;
    return quiet >= 30;
  })) << "the settled slab kept publishing frames";
  const double t0 = session.simTime();
  ASSERT_TRUE(waitFor([&] { return session.simTime() > t0 + 0.05; })) << "the clock stopped with the frames";
  EXPECT_FALSE(session.update(shown, topo));

  session.sync();  // publishes whatever the state, moved or not
  RenderMesh now;
  ASSERT_TRUE(session.update(now, topo));
  ASSERT_EQ(now.positions.size(), shown.positions.size());
  float far = 0.0F;
  for (std::size_t v = 0; v < now.positions.size(); ++v)
    for (int a = 0; a < 3; ++a) far = std::max(far, std::abs(now.positions[v][a] - shown.positions[v][a]));
  EXPECT_LE(far, 1e-4F) << "the last frame shown is not where the tissue is";

  std::uint32_t top = 0;
  for (std::uint32_t v = 0; v < now.positions.size(); ++v)
    if (now.positions[v][2] > now.positions[top][2]) top = v;
  const Eigen::Vector3d target(now.positions[top][0], now.positions[top][1], now.positions[top][2] - 3.0);
  ASSERT_TRUE(waitFor([&] {
    session.pushToward(top, target);
    return session.update(now, topo);
  })) << "a push did not bring the frames back";
  session.release();
}

// At rest the loop stops stepping (an idle workstation keeps no core busy) while the
// clock runs on; a command wakes it and the tissue follows the push as before.
TEST(PhysicsSession, ATissueAtRestSleepsUntilACommandWithItsClockRunning) {
  PhysicsSession session(ld::physics::makeSlab(40.0, 30.0, 5.0, 2.5));
  ASSERT_TRUE(waitFor([&] { return session.settled(); }));
  ASSERT_TRUE(waitFor([&] { return session.stats().resting; })) << "the settled slab never came to rest";
  const QString line = session.status();
  EXPECT_TRUE(line.startsWith("Physics: at rest since t =")) << line.toStdString();
  const std::uint64_t steps0 = session.stats().steps;
  const double t0 = session.simTime();
  ASSERT_TRUE(waitFor([&] { return session.simTime() > t0 + 0.1; })) << "the clock stopped at rest";
  EXPECT_EQ(session.stats().steps, steps0) << "steps ran while at rest";
  EXPECT_TRUE(session.stats().resting);
  EXPECT_EQ(session.status(), line) << "the idle status line changed (a repaint)";

  RenderMesh now;
  bool topo = false;
  session.sync();
  ASSERT_TRUE(session.update(now, topo));
  std::uint32_t top = 0;
  for (std::uint32_t v = 0; v < now.positions.size(); ++v)
    if (now.positions[v][2] > now.positions[top][2]) top = v;
  const float z0 = now.positions[top][2];
  const Eigen::Vector3d target(now.positions[top][0], now.positions[top][1], z0 - 3.0);
  ASSERT_TRUE(waitFor([&] {
    session.pushToward(top, target);
    session.update(now, topo);
    return now.positions[top][2] < z0 - 0.5F;
  })) << "a push did not wake the tissue";
  EXPECT_GT(session.stats().steps, steps0);
  EXPECT_FALSE(session.stats().resting);
  session.release();
}

}  // namespace
