#include "sim/physics/simulation_loop.h"

#include <atomic>
#include <chrono>
#include <numeric>
#include <thread>

#include <gtest/gtest.h>

#include "sim/physics/scenes.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;
using namespace std::chrono_literals;

template <class Pred>
bool waitFor(Pred pred, std::chrono::milliseconds limit = 20000ms) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

TEST(SimulationLoop, SettlesPublishesAndTakesForces) {
  Params p;
  State s = makeState(makeGrid(8, 8, 4.0), p.tissue);
  const std::size_t faces = s.mesh.nFaces();
  SimulationLoop::Options opt;
  opt.rateHz = 1000;
  std::atomic<int> progressCalls{0};
  opt.settle.progress = [&](double, double) { ++progressCalls; };
  SimulationLoop loop(p, std::move(s), opt);
  EXPECT_EQ(loop.snapshot().triangles.size(), faces);  // a snapshot exists before start
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.isSettled(); }));
  EXPECT_DOUBLE_EQ(loop.settleProgress(), 1.0);
  EXPECT_GT(progressCalls.load(), 0);
  const Snapshot settled = loop.snapshot();
  const Vec3 centre(16, 16, 0);
  std::size_t idx = 0;
  for (std::size_t i = 1; i < settled.positions.size(); ++i)
    if ((settled.positions[i] - centre).norm() < (settled.positions[idx] - centre).norm()) idx = i;
  loop.setForceAt(settled.positions[idx], Vec3(0, 0, -3.0));
  ASSERT_TRUE(waitFor([&] { return loop.snapshot().positions[idx].z() < settled.positions[idx].z() - 0.05; }));
  std::atomic<bool> ran{false};
  loop.post([&](Params&, State& st) { ran = st.mesh.nFaces() == faces; });
  ASSERT_TRUE(waitFor([&] { return ran.load(); }));
  loop.clearForces();
  ASSERT_TRUE(
      waitFor([&] { return std::abs(loop.snapshot().positions[idx].z() - settled.positions[idx].z()) < 0.01; }));
  const Snapshot later = loop.snapshot();
  EXPECT_GT(later.serial, settled.serial);
  EXPECT_GT(later.step, settled.step);
  EXPECT_EQ(later.triangles.size(), faces);
  EXPECT_EQ(later.normals.size(), later.positions.size());
  loop.stop();
  const LoopStats st = loop.stats();
  EXPECT_GT(st.steps, 0u);
  EXPECT_EQ(std::accumulate(st.histogram.begin(), st.histogram.end(), std::uint64_t{0}), st.steps);
  EXPECT_LE(st.p50Us, st.maxUs);
  EXPECT_TRUE(isFinite(loop.state()));
}

TEST(SimulationLoop, StopsWhileSettling) {
  Params p;
  p.tissue.damping = 0.0;  // never settles
  SimulationLoop::Options opt;
  opt.settle.maxTime = 1e6;
  SimulationLoop loop(p, makeState(makeGrid(4, 4, 4.0), p.tissue), opt);
  loop.start();
  std::this_thread::sleep_for(20ms);
  loop.stop();
  EXPECT_FALSE(loop.isRunning());
  EXPECT_TRUE(isFinite(loop.state()));
}

}  // namespace
}  // namespace ld::physics
