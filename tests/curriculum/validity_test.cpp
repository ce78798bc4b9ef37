// Validity checks of the assessment with scripted trainees: an expert who follows the
// path closely and steadily, and novices with more lateral wander, pauses and lifts
// (fixed seeds). Every metric must move the right way as the noise grows, the score
// must rank them, and resampling the same motion must not change the metrics.
#include <algorithm>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>

#include "curriculum/scripted_trainee.h"
#include "curriculum/task_runner.h"
#include "sim/io/mesh_io.h"
#include "sim/physics/spring_kernel.h"
#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

struct Loaded {
  Task task;
  mesh::SurfaceMesh mesh;
};

const Loaded& load(const std::string& id) {
  static std::map<std::string, Loaded> cache;
  auto it = cache.find(id);
  if (it == cache.end()) {
    const auto file = test::resourcesDir() / "tasks" / (id + ".json");
    Loaded l{loadTask(file), {}};
    l.mesh = io::readMesh(resolveModel(l.task, file));
    it = cache.emplace(id, std::move(l)).first;
  }
  return it->second;
}

// The metrics' validity against the trainees' noise is checked on a still tissue
// (physics off): under physics the cut's walls retract and the cutter's tracks lose
// the moving groove now and then (walk failures), which is the cutting engine's
// matter, not the metrics'. PhysicsGraspForce below checks the physics run.
RunResult attempt(const std::string& id, int level, double hz, unsigned seed = 3, bool physics = false,
                  bool still = false) {
  const Loaded& l = load(id);
  RunOptions o;
  o.physics = physics;
  o.holdUnderBlade = still;
  return runTask(l.task, l.mesh, scriptedAttempt(l.task, l.mesh, traineeProfile(level, seed), hz), o);
}

const char* const kBundled[] = {"slab-straight-line", "slab-gentle-curve", "slab-s-curve",
                                "slab-circle-cutout", "organ-curve",       "organ-fold"};

TEST(Validity, EveryMetricWorsensAsNoiseGrowsOnEveryBundledTask) {
  // Levels 0 (expert) to 3, two fixed seeds (1: the closing note's table), every task.
  for (unsigned seed : {1u, 3u})
    for (const char* id : kBundled) {
      std::vector<RunResult> r;
      for (int level = 0; level <= 3; ++level) r.push_back(attempt(id, level, 250, seed));
      SCOPED_TRACE(std::string(id) + " seed " + std::to_string(seed));
      EXPECT_TRUE(r[0].assessment.passed) << (r[0].assessment.failures.empty() ? "" : r[0].assessment.failures[0]);
      EXPECT_EQ(r[0].metrics.contactBreaks, 0);
      EXPECT_EQ(r[0].metrics.pathBreaks, 0);
      for (int k = 1; k <= 3; ++k) {
        const Metrics& a = r[k - 1].metrics;
        const Metrics& b = r[k].metrics;
        SCOPED_TRACE("level " + std::to_string(k));
        EXPECT_GT(b.deviation.total(), a.deviation.total());
        EXPECT_GT(b.cutDistanceMeanMm, a.cutDistanceMeanMm);
        EXPECT_GT(b.cutDistanceMaxMm, a.cutDistanceMaxMm);
        // Band: both levels often cut nearly all of the path within the band; a lift
        // falling elsewhere moves that by under 1 % of the path (not meaningful).
        EXPECT_LE(b.bandFraction, a.bandFraction + 0.01);
        EXPECT_EQ(b.contactBreaks, k);          // one lift per level
        EXPECT_GT(b.pathBreaks, a.pathBreaks);  // larger, faster wander and fast corrections cross more often
        EXPECT_GT(b.totalTimeS, a.totalTimeS);
        EXPECT_GT(b.contact.meanS, a.contact.meanS);  // slower, and pauses
        EXPECT_GT(b.contact.maxS, a.contact.maxS);
        EXPECT_GT(b.stretchMeanN, a.stretchMeanN);
        EXPECT_GT(b.stretchMaxN, a.stretchMaxN);
        EXPECT_GT(b.pathLengthRightMm, a.pathLengthRightMm);
        EXPECT_GT(b.pathLengthLeftMm, a.pathLengthLeftMm);
        EXPECT_LT(r[k].assessment.score, r[k - 1].assessment.score);  // the score ranks them
        EXPECT_FALSE(r[k].assessment.passed);                         // every novice fails
      }
      // The band fraction saturates at 1 while the wander stays inside the band (level 1
      // on organ-curve): it may stay there, and must fall by level 3.
      EXPECT_LT(r[3].metrics.bandFraction, r[1].metrics.bandFraction);
      EXPECT_LE(r[1].metrics.bandFraction, r[0].metrics.bandFraction);
      EXPECT_LT(r[3].metrics.bandFraction, r[0].metrics.bandFraction);
    }
}

TEST(Validity, ResamplingChangesNoMetricByMoreThanOnePercent) {
  // Level 3 is left out: its erratic strokes make the cutter lose and restart tracks
  // (walk failures) at different places at different rates, so the cut itself, not the
  // metrics, depends on the sampling there (band fraction 0.68 at 100 Hz against 0.70
  // at 1 kHz on this seed; sim/cutting/README.md, limits).
  for (const auto& [id, level] :
       std::vector<std::pair<const char*, int>>{{"slab-s-curve", 0}, {"slab-s-curve", 1}, {"slab-s-curve", 2}}) {
    const RunResult base = attempt(id, level, 1000);
    for (double hz : {100.0, 250.0}) {
      const RunResult r = attempt(id, level, hz);
      SCOPED_TRACE(std::string(id) + " level " + std::to_string(level) + " at " + std::to_string(int(hz)) + " Hz");
      const Metrics& a = base.metrics;
      const Metrics& b = r.metrics;
      auto close = [](double x, double y, double floor) { return test::near(x, y, floor, 0.01); };
      EXPECT_TRUE(close(b.deviation.total(), a.deviation.total(), 0.05));
      EXPECT_TRUE(close(b.cutDistanceMeanMm, a.cutDistanceMeanMm, 0.002));
      EXPECT_TRUE(close(b.cutDistanceMaxMm, a.cutDistanceMaxMm, 0.002));
      EXPECT_TRUE(close(b.bandFraction, a.bandFraction, 0.0));
      EXPECT_TRUE(close(b.contact.meanS, a.contact.meanS, 0.0));
      EXPECT_TRUE(close(b.contact.maxS, a.contact.maxS, 0.0));
      EXPECT_TRUE(close(b.contact.totalS, a.contact.totalS, 0.0));
      EXPECT_TRUE(close(b.totalTimeS, a.totalTimeS, 0.0));
      EXPECT_TRUE(close(b.stretchMeanN, a.stretchMeanN, 0.0));
      EXPECT_TRUE(close(b.stretchMaxN, a.stretchMaxN, 0.0));
      EXPECT_TRUE(close(b.pathLengthLeftMm, a.pathLengthLeftMm, 0.0));
      EXPECT_TRUE(close(b.pathLengthRightMm, a.pathLengthRightMm, 0.0));
      EXPECT_TRUE(close(r.assessment.score, base.assessment.score, 0.0));
      EXPECT_EQ(b.contactBreaks, a.contactBreaks);
      EXPECT_EQ(b.pathBreaks, a.pathBreaks);
    }
  }
}

TEST(Validity, LiveSeriesEndsAtTheBatchValues) {
  const RunResult r = attempt("slab-straight-line", 1, 250);
  ASSERT_GT(r.series.size(), 50u);
  const Metrics& last = r.series.back().m;
  EXPECT_TRUE(test::near(last.deviation.total(), r.metrics.deviation.total(), 1e-9));
  // The cut recorded on the tissue gives the same deviation computed from scratch.
  EXPECT_TRUE(
      test::near(deviation(load("slab-straight-line").task.path, r.cut).total(), r.metrics.deviation.total(), 1e-9));
  // The live deviation grows over the attempt (more path compared as the cut proceeds).
  EXPECT_LT(r.series[r.series.size() / 4].m.deviation.total(), last.deviation.total());
  // The drawn path was broken where the cut crossed it (two crossings of one drawn
  // segment break it once).
  EXPECT_LE(pieces(r.drawn).size(), static_cast<std::size_t>(1 + r.metrics.pathBreaks));
  EXPECT_GT(pieces(r.drawn).size(), 1u);
}

TEST(Validity, PhysicsGraspForceRanksAndLeavesTheCutNearlyUnchanged) {
  // The scripted trainees grasp the slab's edge with the left hand and retract it
  // (expert 4 mm, steady; novice 8 mm with jerks): under physics the grasper's force
  // is larger and less steady for the novice. The expert's cut path and metrics with
  // physics stay close to those on a still tissue: deviation, band and contacts alike.
  // Cut points: the lips move by up to ~0.8 mm, and the cutter restarts tracks it loses
  // on the moving groove (sim/cutting/README.md, "Tissue that moves under the blade"),
  // which puts a few points up to ~3 mm from the still cut — a cut elsewhere would be
  // farther than 5 mm.
  const RunResult on = attempt("slab-straight-line", 0, 250, 3, true);
  const RunResult off = attempt("slab-straight-line", 0, 250, 3, false);
  const RunResult novice = attempt("slab-straight-line", 2, 250, 3, true);
  ASSERT_TRUE(on.physics.on);
  EXPECT_EQ(on.physics.grasps, 1);
  EXPECT_EQ(on.physics.implicitFallbacks, 0u);
  EXPECT_LT(on.physics.startResidualMn, 1e-9);
  EXPECT_GT(on.metrics.stretchMeanN, 0.0);
  EXPECT_LT(on.metrics.stretchMeanN, novice.metrics.stretchMeanN);
  EXPECT_LT(on.metrics.stretchMaxN, novice.metrics.stretchMaxN);
  // Physics forces are far above the home-spring estimate (the mesh springs resist).
  EXPECT_GT(on.metrics.stretchMaxN, 5 * off.metrics.stretchMaxN);
  double far = 0.0;
  for (const auto& q : on.cut) far = std::max(far, distanceToPath(q.p, off.cut));
  std::cout << "expert on/off: deviation " << on.metrics.deviation.total() << " / " << off.metrics.deviation.total()
            << " mm2, cut distance mean " << on.metrics.cutDistanceMeanMm << " / " << off.metrics.cutDistanceMeanMm
            << " mm, band " << on.metrics.bandFraction << " / " << off.metrics.bandFraction
            << ", farthest cut point from the still cut " << far << " mm, path breaks " << on.metrics.pathBreaks
            << " / " << off.metrics.pathBreaks << ", drawn path moved " << on.pathMovedMm << " mm\n";
  EXPECT_LT(far, 5.0);
  // The drawn path moves with the tissue (the pre-stretched wall springs pull the cut's
  // lips toward the groove), so the open-loop scripted hook deviates more and crosses
  // it a few times: deviation within 60 % (of the larger), path breaks not bounded
  // here. The deviation is sensitive to the physics' last bits through the cutter's
  // track restarts: with the physics kernel paths, which agree to ~1e-13, it was
  // 14.2 mm² (AVX2 or AVX-512 with sqrt and div), 14.4 (AVX2, rsqrt), 18.5 (the scalar
  // reference, and AVX-512 with rsqrt; walk failures 68 against 19) against 9.4 still.
  EXPECT_TRUE(test::near(on.metrics.deviation.total(), off.metrics.deviation.total(), 0.0, 0.6))
      << on.metrics.deviation.total() << " vs " << off.metrics.deviation.total();
  EXPECT_TRUE(test::near(on.metrics.cutDistanceMeanMm, off.metrics.cutDistanceMeanMm, 0.3));
  EXPECT_TRUE(test::near(on.metrics.bandFraction, off.metrics.bandFraction, 0.01));
  // A lip retracting from the hook can lose contact for a sample (one break more); the
  // contact time stays within 2 %.
  EXPECT_LE(on.metrics.contactBreaks, off.metrics.contactBreaks + 1);
  EXPECT_TRUE(test::near(on.metrics.contact.totalS, off.metrics.contact.totalS, 0.0, 0.02));
}

TEST(Validity, ExpertPassesTheStraightLineOnTissueMovingUnderTheBlade) {
  // With the tissue moving under the blade (--physics on) the cut is recorded on the
  // tissue at rest, where the line was drawn: the expert's straight cut is graded as
  // on the still tissue (score within 5 points, at most 4 path breaks: 2 and 0 measured
  // on a Zen 5, room for another kernel path's last bits; it was 16.5 with 44 breaks
  // when the blade's world points were compared with the moving line).
  for (unsigned seed : {1u, 3u}) {
    SCOPED_TRACE(seed);
    const RunResult on = attempt("slab-straight-line", 0, 250, seed, true);
    const RunResult off = attempt("slab-straight-line", 0, 250, seed, false);
    ASSERT_TRUE(on.physics.on);
    ASSERT_FALSE(on.physics.heldStill);
    EXPECT_LE(on.metrics.pathBreaks, 4);
    EXPECT_NEAR(on.assessment.score, off.assessment.score, 5.0);
    EXPECT_TRUE(on.assessment.passed) << (on.assessment.failures.empty() ? "" : on.assessment.failures[0]);
    EXPECT_EQ(on.metrics.contactBreaks, off.metrics.contactBreaks);
    EXPECT_GT(on.metrics.bandFraction, 0.98);
  }
}

TEST(Validity, HeldStillPhysicsGivesTheGraspForceAndTheStillCut) {
  // task run's default: the grasper's force from the simulated tissue, the cut and the
  // drawn path on the tissue held still. Every other metric is the still run's exactly
  // (the tissue under the blade is the same), while the force is the physics one: far
  // above the estimate, and larger for the novice. The expert passes, the novice fails.
  for (const char* id : {"slab-straight-line"}) {
    SCOPED_TRACE(id);
    const RunResult still = attempt(id, 0, 250, 1, true, true);
    const RunResult off = attempt(id, 0, 250, 1, false);
    const RunResult on = attempt(id, 0, 250, 1, true, false);
    const RunResult novice = attempt(id, 2, 250, 1, true, true);
    ASSERT_TRUE(still.physics.on);
    ASSERT_TRUE(still.physics.heldStill);
    EXPECT_EQ(still.physics.grasps, 1);
    EXPECT_EQ(still.physics.implicitFallbacks, 0u);
    EXPECT_GT(still.physics.steps, 1000);
    EXPECT_GT(still.physics.maxDisplacementMm, 2.0);  // the simulated tissue was pulled (4 mm)
    EXPECT_DOUBLE_EQ(still.metrics.deviation.total(), off.metrics.deviation.total());
    EXPECT_EQ(still.metrics.pathBreaks, off.metrics.pathBreaks);
    EXPECT_EQ(still.metrics.contactBreaks, off.metrics.contactBreaks);
    EXPECT_DOUBLE_EQ(still.metrics.bandFraction, off.metrics.bandFraction);
    EXPECT_DOUBLE_EQ(still.metrics.contact.meanS, off.metrics.contact.meanS);
    EXPECT_EQ(still.cut.size(), off.cut.size());
    EXPECT_EQ(still.cutStats.walkFailures, 0u);
    EXPECT_DOUBLE_EQ(still.pathMovedMm, off.pathMovedMm);
    EXPECT_GT(still.metrics.stretchMaxN, 5 * off.metrics.stretchMaxN);
    // Close to the force with the tissue moving under the blade too (same grasp and pull).
    EXPECT_TRUE(test::near(still.metrics.stretchMeanN, on.metrics.stretchMeanN, 0.0, 0.25));
    EXPECT_LT(still.metrics.stretchMeanN, novice.metrics.stretchMeanN);
    EXPECT_LT(still.metrics.stretchMaxN, novice.metrics.stretchMaxN);
    EXPECT_TRUE(still.assessment.passed) << (still.assessment.failures.empty() ? "" : still.assessment.failures[0]);
    EXPECT_FALSE(novice.assessment.passed);
  }
}

// The expert's trajectory with the cutting hand's tip moved by `shift(t)`.
devices::Trajectory shifted(devices::Trajectory tr, const std::function<Eigen::Vector3d(double)>& shift) {
  for (auto& s : tr.samples)
    if (s.tool != instruments::Tool::Grasper) s.pose.tip += shift(s.t);
  return tr;
}

// 0 before a, 1 after b, smooth between.
double ramp(double t, double a, double b) {
  const double u = std::clamp((t - a) / (b - a), 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

RunResult movingRun(const std::string& id, const devices::Trajectory& tr) {
  const Loaded& l = load(id);
  RunOptions o;
  o.physics = true;  // moving: the cut recorded on the tissue at rest
  o.followMovingPath = true;  // a trainee follows the line where the tissue took it
  return runTask(l.task, l.mesh, tr, o);
}

// The expert (the CLI's script, 1 kHz) on every bundled task with the tissue moving
// under the blade, on three seeds and with the physics' scalar and vector builds (they
// agree to rounding, and the moving tissue turns last bits into different cuts: one
// machine passing is no evidence). Before the cut's new vertices settled
// (physics::settleVertices) and the scripted hand followed the moving line, 21 of 54
// such runs (these and the AVX2 build's) had a spurious path or contact break and one
// failed; the test then asserted two tasks on seed 1 and failed on a machine whose
// vector build differs from the one it was written on. The cut distance bound is 1 mm
// over all these runs (it was 0.6 for the two): with settling (as first measured),
// slab-s-curve seed 1 reached 0.84 mm (0.41 before) and three other runs 0.61.
class ExpertOnMovingTissue : public ::testing::TestWithParam<const char*> {};

TEST_P(ExpertOnMovingTissue, IsNotChargedForTheSimulationsArtefacts) {
  const std::string id = GetParam();
  const Loaded& l = load(id);
  std::vector<physics::detail::Kernel> kernels{physics::detail::Kernel::Scalar};
  if (physics::detail::activeKernel() != physics::detail::Kernel::Scalar)
    kernels.push_back(physics::detail::activeKernel());
  struct Restore {
    ~Restore() { physics::detail::forceKernel(std::nullopt); }
  } restore;
  for (const auto kernel : kernels) {
    ASSERT_TRUE(physics::detail::forceKernel(kernel));
    for (unsigned seed : {1u, 2u, 3u}) {
      SCOPED_TRACE(std::string(physics::detail::kernelName(kernel)) + " seed " + std::to_string(seed));
      const RunResult r = movingRun(id, scriptedAttempt(l.task, l.mesh, traineeProfile(0, seed), 1000));
      ASSERT_TRUE(r.physics.on);
      ASSERT_FALSE(r.physics.heldStill);
      EXPECT_EQ(r.metrics.pathBreaks, 0);
      EXPECT_EQ(pieces(r.drawn).size(), 1u);
      EXPECT_EQ(r.metrics.contactBreaks, 0);
      EXPECT_GE(r.metrics.bandFraction, 0.98);
      EXPECT_LT(r.metrics.cutDistanceMaxMm, 1.0);
      EXPECT_TRUE(r.assessment.passed) << (r.assessment.failures.empty() ? "" : r.assessment.failures[0]);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Validity, ExpertOnMovingTissue,
                         ::testing::Values("slab-straight-line", "slab-gentle-curve", "slab-s-curve",
                                           "slab-circle-cutout", "organ-curve", "organ-fold"),
                         [](const auto& p) {
                           std::string n = p.param;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

TEST(Validity, RealBreaksStillCountOnMovingTissue) {
  const Loaded& l = load("slab-gentle-curve");
  const devices::Trajectory expert = scriptedAttempt(l.task, l.mesh, traineeProfile(0, 1), 1000);
  // The hook lifted 4 mm out of the tissue mid-path and put back.
  const RunResult lifted = movingRun("slab-gentle-curve", shifted(expert, [](double t) {
                                       return Eigen::Vector3d(0, 0, 4.0 * (ramp(t, 4.0, 4.1) - ramp(t, 4.5, 4.6)));
                                     }));
  EXPECT_GE(lifted.metrics.contactBreaks, 1);
  // The cut 1 mm to one side of the line, then 1 mm to the other: one crossing.
  const RunResult crossed =
      movingRun("slab-gentle-curve",
                shifted(expert, [](double t) { return Eigen::Vector3d(0, 1.0 - 2.0 * ramp(t, 5.0, 5.3), 0); }));
  EXPECT_EQ(crossed.metrics.pathBreaks, 1);
  EXPECT_EQ(pieces(crossed.drawn).size(), 2u);
}

}  // namespace
}  // namespace ld::curriculum
