// The headless task runner drives the real cutting engine: the cut path comes from
// the engine's cut points, the drawn path is broken where the cut crosses it and
// re-embedded (from the mesh's edit journal) without moving where its triangles are
// subdivided; an attempt that cuts nothing is not scored as perfect.
#include "curriculum/task_runner.h"

#include <algorithm>
#include <utility>

#include "curriculum/tissue_path.h"
#include "sim/physics/mass_spring.h"
#include "tests/curriculum/grid_mesh.h"
#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

using V = Eigen::Vector3d;
using instruments::Hand;
using instruments::Tool;

using testmesh::grid;

// A straight drawn path along x at y = 3 (on grid edges and through grid vertices).
Task lineTask() {
  Task t;
  t.id = "test-line";
  t.leftTool = "none";
  t.rightTool = "scalpel";
  std::vector<V> pts;
  for (int k = 0; k <= 10; ++k) pts.emplace_back(0.5 + 0.5 * k, 3.0, 0.0);
  t.path = makePolyline(pts);
  t.scoring.timeLimitS = 60;
  t.scoring.weights.uncutFraction = 30;
  t.proficiency.minBandFraction = 0.5;
  return t;
}

// A scalpel stroke across the sheet at x = xCut from y0 to y1 (blade through the
// sheet, sharp side toward +y), then lifted clear.
devices::Trajectory stroke(double xCut, double y0, double y1, double z, double hz) {
  devices::Trajectory tr;
  const double dur = 1.0;
  const int n = static_cast<int>(dur * hz);
  for (int i = 0; i <= n + 2; ++i) {
    devices::PoseSample s;
    s.t = static_cast<double>(i) / hz;
    s.hand = Hand::Right;
    s.tool = Tool::Scalpel;
    const double u = std::min(1.0, s.t / dur);
    s.pose.tip = V(xCut, y0 + u * (y1 - y0), i > n ? z + 30.0 : z);
    s.pose.dir = V(0, 0, -1);  // the edge runs from the tip up through the sheet
    s.pose.up = V(0, 1, 0);
    tr.samples.push_back(s);
  }
  return tr;
}

// The path and cut machinery on a still sheet (physics would let the cut, pre-stretched
// sheet retract, moving the path by design).
RunOptions still() {
  RunOptions o;
  o.physics = false;
  return o;
}

TEST(TaskRunner, CutsThroughTheEngineBreaksAndKeepsTheDrawnPath) {
  const Task task = lineTask();
  const mesh::SurfaceMesh m = grid(6);
  const RunResult r = runTask(task, m, stroke(2.75, 1.0, 5.0, -1.0, 100), still());
  // The engine cut the tissue.
  EXPECT_GT(r.cutStats.trianglesCut, 0);
  EXPECT_EQ(r.cutStats.fillFailures, 0);
  // The cut path: straight pieces along x = 2.75, ending with a stop.
  ASSERT_GE(r.cut.size(), 2u);
  for (const auto& q : r.cut) EXPECT_TRUE(test::near(q.p.x(), 2.75, 1e-6)) << q.p.transpose();
  EXPECT_TRUE(r.cut.back().stop);
  EXPECT_LT(r.cut.front().p.y(), 1.1);
  EXPECT_GT(r.cut.back().p.y(), 4.9);
  // One crossing: the drawn path is broken after its point at x = 2.5.
  EXPECT_EQ(r.metrics.pathBreaks, 1);
  ASSERT_EQ(r.drawn.size(), task.path.size());
  EXPECT_EQ(pieces(r.drawn).size(), 2u);
  EXPECT_TRUE(r.drawn[4].stop);
  EXPECT_EQ(pieces(r.drawnAsDrawn).size(), 1u);
  // Points whose triangles were subdivided were embedded again, none moved, and no
  // search of the whole mesh was needed.
  EXPECT_GT(r.pathReembedded, 0u);
  EXPECT_EQ(r.pathGlobalSearches, 0u);
  for (std::size_t i = 0; i < r.drawn.size(); ++i) EXPECT_TRUE(test::nearVec(r.drawn[i].p, task.path[i].p, 1e-9)) << i;
  // One contact interval; a cut that crosses the line has little deviation in xy
  // (two triangles of legs 2.25 x 2 and 2.75 x 2 ... bounded by the crossing lobes).
  EXPECT_EQ(r.metrics.contactBreaks, 0);
  EXPECT_FALSE(r.metrics.noCut);
}

TEST(TaskRunner, EmbeddedPathFollowsEditsOnlyWhereFacesChanged) {
  // Directly on the engine: after cutting across, every path point is where it was
  // and the path has a stop where the cut crossed.
  mesh::SurfaceMesh m = grid(6);
  cutting::CutEngine engine;
  const int obj = engine.addObject(std::move(m));
  const Task task = lineTask();
  TissuePath tp = TissuePath::embed(engine.object(obj).mesh, task.path);
  const auto before = tp.worldPoints(engine.object(obj).mesh);
  std::optional<V> last;
  std::size_t moved = 0;
  for (const auto& s : stroke(2.25, 5.5, 0.5, -1.0, 200).samples) {
    instruments::Pose p = s.pose;
    p.up = V(0, -1, 0);  // cutting toward -y
    const auto res = engine.step(s.hand, s.tool, p);
    moved += tp.followEdits(engine.object(obj).mesh);
    if (!res.cutPoints.empty()) {
      const V q = res.cutPoints.front().point;
      if (last) tp.cutAcross(engine.object(obj).mesh, *last, q, V(0, 0, 1));
      last = q;
    } else {
      last.reset();
    }
  }
  engine.finish();
  moved += tp.followEdits(engine.object(obj).mesh);
  const mesh::SurfaceMesh& cut = engine.object(obj).mesh;
  ASSERT_TRUE(cut.validate().ok()) << cut.validate().message();
  EXPECT_GT(moved, 0u);
  EXPECT_LT(moved, 4 * task.path.size());  // only the points near the cut, a few times
  EXPECT_EQ(tp.globalSearches(), 0u);
  const auto after = tp.worldPoints(cut);
  for (std::size_t i = 0; i < after.size(); ++i) {
    EXPECT_TRUE(test::nearVec(after[i], before[i], 1e-9)) << i;
    EXPECT_GE(tp.points()[i].loc.bary.minCoeff(), -1e-9);
  }
  const Polyline now = tp.positions(cut);
  EXPECT_EQ(pieces(now).size(), 2u);
  EXPECT_TRUE(now[3].stop);  // x = 2.0 | cut at 2.25 | x = 2.5
  // And the path still moves with the tissue.
  for (mesh::Vertex v : engine.object(obj).mesh.vertices()) engine.object(obj).mesh.position(v).z() += 1.0;
  for (const auto& q : tp.positions(engine.object(obj).mesh)) EXPECT_TRUE(test::near(q.p.z(), 1.0, 1e-12));
}

TEST(TaskRunner, SeparationMarksPointsOnTheFreedPieceWithoutAGlobalSearch) {
  // A cut right across the sheet at x = 3.25 frees its smaller right part. The
  // points left of the cut stay on the kept mesh (found again on their original
  // triangles, no search of the whole mesh); those right of it are marked freed.
  mesh::SurfaceMesh m = grid(6);
  tagOriginalFaces(m);
  cutting::CutEngine engine;
  const int obj = engine.addObject(std::move(m));
  const Task task = lineTask();
  TissuePath tp = TissuePath::embed(engine.object(obj).mesh, task.path);
  std::size_t followed = 0;
  for (const auto& s : stroke(3.25, -1.0, 7.0, -1.0, 200).samples) {
    engine.step(s.hand, s.tool, s.pose);
    followed += tp.followEdits(engine.object(obj).mesh);
  }
  engine.finish();
  followed += tp.followEdits(engine.object(obj).mesh);
  ASSERT_EQ(engine.objects().size(), 2u);
  const mesh::SurfaceMesh& kept = engine.object(obj).mesh;
  ASSERT_TRUE(kept.validate().ok()) << kept.validate().message();
  double maxX = -1e9;
  for (mesh::Vertex v : kept.vertices()) maxX = std::max(maxX, kept.position(v).x());
  ASSERT_LT(maxX, 3.3);  // the larger left part was kept
  EXPECT_EQ(tp.globalSearches(), 0u);
  EXPECT_EQ(tp.freedPoints(), 5u);  // x = 3.5 .. 5.5
  EXPECT_GT(followed, 0u);
  const Polyline now = tp.positions(kept);
  for (std::size_t i = 0; i < task.path.size(); ++i) {
    EXPECT_EQ(tp.points()[i].freed, task.path[i].p.x() > 3.25) << i;
    EXPECT_TRUE(test::nearVec(now[i].p, task.path[i].p, 1e-9)) << i;
  }
  // Kept points are embedded in the kept mesh where they were.
  for (std::size_t i = 0; i < task.path.size(); ++i) {
    if (!tp.points()[i].freed) {
      EXPECT_TRUE(kept.isValid(tp.points()[i].loc.face)) << i;
    }
  }
  // The same through the task runner.
  const RunResult r = runTask(task, grid(6), stroke(3.25, -1.0, 7.0, -1.0, 200), still());
  EXPECT_EQ(r.objects, 2u);
  EXPECT_EQ(r.cutStats.separations, 1);
  EXPECT_EQ(r.pathFreed, 5u);
  EXPECT_EQ(r.pathGlobalSearches, 0u);
}

TEST(TaskRunner, NothingCutIsNotPerfect) {
  const Task task = lineTask();
  const mesh::SurfaceMesh m = grid(6);
  const RunResult none = runTask(task, m, stroke(2.75, 1.0, 5.0, 10.0, 100), still());  // far above the tissue
  EXPECT_TRUE(none.cut.empty());
  EXPECT_TRUE(none.metrics.noCut);
  // The straight 5 mm path: its chord adds nothing; the band strip (2 x 2 mm wide)
  // counts in xy and xz, nothing in yz (the path projects to a point there).
  EXPECT_TRUE(test::near(none.metrics.deviation.xy, 20.0, 1e-9));
  EXPECT_TRUE(test::near(none.metrics.deviation.xz, 20.0, 1e-9));
  EXPECT_TRUE(test::near(none.metrics.deviation.yz, 0.0, 1e-9));
  EXPECT_EQ(none.metrics.bandFraction, 0.0);
  EXPECT_FALSE(none.assessment.passed);
  // A cut along the line (within the band) deviates less and scores better.
  devices::Trajectory along;
  for (int i = 0; i <= 102; ++i) {
    devices::PoseSample s;
    s.t = i / 100.0;
    s.tool = Tool::Scalpel;
    const double u = std::min(1.0, s.t);
    s.pose.tip = V(0.5 + 5.0 * u, 3.2, i > 100 ? 30.0 : -1.0);
    s.pose.dir = V(0, 0, -1);
    s.pose.up = V(1, 0, 0);
    along.samples.push_back(s);
  }
  const RunResult good = runTask(task, m, along, still());
  EXPECT_FALSE(good.metrics.noCut);
  EXPECT_GT(good.metrics.bandFraction, 0.9);
  EXPECT_LT(good.metrics.deviation.total(), none.metrics.deviation.total());
  EXPECT_GT(good.assessment.score, none.assessment.score);
  EXPECT_TRUE(good.assessment.passed);
}

// ---- the grasper's force under physics ---------------------------------------------

// The left hand's grasper: open 1 mm above `at`, descends and closes on it by t = 0.2 s,
// pulls by `pull` (smoothly over 1 s) and holds until tEnd. `close` false: the jaws
// stay open.
devices::Trajectory graspAndPull(const V& at, const V& pull, double tEnd, bool close = true, double hz = 250) {
  devices::Trajectory tr;
  const int n = static_cast<int>(tEnd * hz);
  for (int i = 0; i <= n; ++i) {
    devices::PoseSample s;
    s.t = static_cast<double>(i) / hz;
    s.hand = Hand::Left;
    s.tool = Tool::Grasper;
    const double u = std::clamp((s.t - 0.3) / 1.0, 0.0, 1.0);
    const double ramp = u * u * (3 - 2 * u);
    s.pose.tip = at + V(0, 0, std::max(0.0, 1.0 - s.t / 0.2)) + ramp * pull;
    s.pose.dir = V(0, 0, -1);
    s.pose.up = V(1, 0, 0);
    s.pose.jaw = close && s.t >= 0.2 ? 0.0 : 1.0;  // closes on arrival
    tr.samples.push_back(s);
  }
  return tr;
}

Task graspTask(double stiffness) {
  Task t = lineTask();
  t.leftTool = "grasper";
  t.rightTool = "none";
  t.tissue.stiffness = stiffness;
  t.tissue.damping = 40.0;  // settles within the hold
  return t;
}

double lastForce(const RunResult& r) { return r.grasp.empty() ? -1.0 : r.grasp.back().force; }

TEST(TaskRunnerPhysics, HomeSpringPatchPulledByDGivesHomeKTimesD) {
  // No mesh springs (K = 0): each held vertex hangs on its home spring only, in series
  // with the penalty spring, so at rest F = n · homeK · d · kp / (kp + homeK) ≈ n · homeK · d.
  const Task task = graspTask(0.0);
  const mesh::SurfaceMesh m = grid(8);
  const double d = 2.0, homeK = task.tissue.homeStiffness;
  for (const auto& [radius, held] : {std::pair{0.5, 1}, std::pair{1.0, 5}}) {
    RunOptions o;
    o.graspRadius = radius;
    const RunResult r = runTask(task, m, graspAndPull(V(4, 4, 0), V(d, 0, 0), 3.0), o);
    ASSERT_TRUE(r.physics.on);
    EXPECT_EQ(r.physics.grasps, 1);
    EXPECT_EQ(r.physics.heldVertices, static_cast<std::size_t>(held));
    const double kp = o.graspStiffness;
    const double expected = held * homeK * d * kp / (kp + homeK) * 1e-3;  // N
    EXPECT_TRUE(test::near(lastForce(r), expected, 1e-9, 1e-3)) << lastForce(r) << " vs " << expected;
    EXPECT_TRUE(test::near(lastForce(r), held * homeK * d * 1e-3, 1e-9, 0.011));
    EXPECT_TRUE(test::near(r.metrics.stretchMaxN, expected, 1e-9, 0.02));  // no big overshoot
    EXPECT_GT(r.metrics.stretchMeanN, 0.3 * expected);
    EXPECT_LT(r.metrics.stretchMeanN, expected);
    EXPECT_EQ(r.physics.implicitFallbacks, 0u);
  }
}

TEST(TaskRunnerPhysics, NoGraspNoForce) {
  const Task task = graspTask(60.0);
  const mesh::SurfaceMesh m = grid(8);
  // Jaws open all along; jaws closed 5 mm above the sheet (nothing to hold).
  for (const auto& tr : {graspAndPull(V(4, 4, 0), V(2, 0, 0), 2.0, false), graspAndPull(V(4, 4, 5), V(2, 0, 0), 2.0)}) {
    const RunResult r = runTask(task, m, tr);
    EXPECT_EQ(r.physics.grasps, 0);
    EXPECT_EQ(r.metrics.stretchMaxN, 0.0);
    EXPECT_EQ(r.metrics.stretchMeanN, 0.0);
    EXPECT_GT(r.physics.steps, 1000);  // the tissue was stepped all the same
  }
}

TEST(TaskRunnerPhysics, ForceRisesWithPullDistance) {
  // The pre-stretched sheet (K = 60) pulled in its plane and out of it.
  const Task task = graspTask(60.0);
  const mesh::SurfaceMesh m = grid(8);
  for (const V& dir : {V(1, 0, 0), V(0, 0, 1)}) {
    double prev = 0.0;
    for (double d : {0.5, 1.0, 2.0, 3.0}) {
      const RunResult r = runTask(task, m, graspAndPull(V(4, 4, 0), d * dir, 3.0));
      EXPECT_GT(lastForce(r), prev * 1.2) << d;
      // Stiffer than the home springs alone (the mesh springs resist too).
      EXPECT_GT(lastForce(r), r.physics.heldVertices * task.tissue.homeStiffness * d * 1e-3 * 0.98) << d;
      EXPECT_EQ(r.physics.implicitFallbacks, 0u);
      prev = lastForce(r);
    }
  }
}

TEST(TaskRunnerPhysics, EstimateWhenPhysicsIsOff) {
  const Task task = graspTask(60.0);
  const mesh::SurfaceMesh m = grid(8);
  const RunResult r = runTask(task, m, graspAndPull(V(4, 4, 0), V(2, 0, 0), 2.0), still());
  EXPECT_FALSE(r.physics.on);
  EXPECT_EQ(r.physics.steps, 0);
  EXPECT_TRUE(test::near(lastForce(r), task.tissue.homeStiffness * 2.0 * 1e-3, 1e-12));
  EXPECT_EQ(runJson(task, r)["stretch_force"]["model"],
            "estimate: home stiffness x grasper displacement (--physics off)");
  const RunResult p = runTask(task, m, graspAndPull(V(4, 4, 0), V(2, 0, 0), 2.0));
  EXPECT_EQ(runJson(task, p)["stretch_force"]["model"], "physics");
}

TEST(TaskRunnerPhysics, CutOnMovingTissueIsRecordedOnTheTissueAtRest) {
  // The grasper lifts the sheet 3 mm beside the line, then the scalpel cuts across it
  // there: the blade meets the sheet above its rest plane, but the cut is where the
  // blade went through the tissue, so the recorded cut lies on the sheet as loaded
  // (z = 0, the plane the path was drawn on) and crosses the drawn line once.
  Task task = graspTask(60.0);
  task.rightTool = "scalpel";
  const mesh::SurfaceMesh m = grid(8);
  devices::Trajectory tr = graspAndPull(V(3, 4.5, 0), V(0, 0, 3), 3.0);
  devices::Trajectory cut = stroke(3.0, 1.5, 4.0, -2.0, 250);
  for (auto& s : cut.samples) s.t += 1.6;
  tr.samples.insert(tr.samples.end(), cut.samples.begin(), cut.samples.end());
  std::stable_sort(tr.samples.begin(), tr.samples.end(), [](const auto& a, const auto& b) { return a.t < b.t; });
  const RunResult r = runTask(task, m, tr);
  ASSERT_TRUE(r.physics.on);
  ASSERT_FALSE(r.physics.heldStill);
  EXPECT_EQ(r.physics.grasps, 1);
  ASSERT_GE(r.cut.size(), 2u);
  double lifted = 0.0;
  for (const auto& q : r.drawn) lifted = std::max(lifted, q.p.z());
  EXPECT_GT(lifted, 0.5);  // the tissue did move (the line went up with it)
  for (const auto& q : r.cut) {
    EXPECT_NEAR(q.p.z(), 0.0, 1e-9);
    EXPECT_NEAR(q.p.x(), 3.0, 0.3);
  }
  EXPECT_EQ(r.metrics.pathBreaks, 1);
}

TEST(TaskRunnerPhysics, BalancedHomesKeepTheModelAtRest) {
  // The pre-stretched springs pull the sheet's rim inward; with the homes balanced the
  // model as loaded is at rest, and stays there while nothing touches it.
  mesh::SurfaceMesh m = grid(6);
  const physics::TissueParams p = tissueParams(TissueSettings{});
  physics::attachTissueProperties(m, p);
  physics::Params pp;
  pp.tissue = p;
  physics::Dynamics d0;
  EXPECT_GT(physics::maxResidualForce(pp, d0, m), 1.0);  // mN, before
  EXPECT_LT(balanceHomes(m, p), 1e-9);
  const mesh::SurfaceMesh before = m;
  physics::Dynamics d;
  for (int i = 0; i < 500; ++i) physics::step(pp, d, m, 1e-3);
  for (mesh::Vertex v : m.vertices()) EXPECT_TRUE(test::nearVec(m.position(v), before.position(v), 1e-9));
}

}  // namespace
}  // namespace ld::curriculum
