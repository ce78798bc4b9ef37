// Validity checks of the assessment with scripted trainees: an expert who follows the
// path closely and steadily, and novices with more lateral wander, pauses and lifts
// (fixed seeds). Every metric must move the right way as the noise grows, the score
// must rank them, and resampling the same motion must not change the metrics.
#include <filesystem>
#include <functional>
#include <map>

#include "curriculum/scripted_trainee.h"
#include "curriculum/task_runner.h"
#include "sim/io/mesh_io.h"
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

RunResult attempt(const std::string& id, int level, double hz, unsigned seed = 3) {
  const Loaded& l = load(id);
  return runTask(l.task, l.mesh, scriptedAttempt(l.task, l.mesh, traineeProfile(level, seed), hz));
}

TEST(Validity, MetricsWorsenAsNoiseGrowsAndTheScoreRanks) {
  for (const char* id : {"slab-s-curve", "organ-fold"}) {
    std::vector<RunResult> r;
    for (int level = 0; level <= 3; ++level) r.push_back(attempt(id, level, 250));
    EXPECT_TRUE(r[0].assessment.passed) << id << ": "
                                        << (r[0].assessment.failures.empty() ? "" : r[0].assessment.failures[0]);
    EXPECT_EQ(r[0].metrics.contactBreaks, 0) << id;
    EXPECT_EQ(r[0].metrics.pathBreaks, 0) << id;
    for (int k = 1; k <= 3; ++k) {
      const Metrics& a = r[k - 1].metrics;
      const Metrics& b = r[k].metrics;
      SCOPED_TRACE(std::string(id) + " level " + std::to_string(k));
      EXPECT_GT(b.deviation.total(), a.deviation.total());
      EXPECT_GT(b.cutDistanceMeanMm, a.cutDistanceMeanMm);
      EXPECT_GT(b.cutDistanceMaxMm, a.cutDistanceMaxMm);
      EXPECT_LE(b.bandFraction, a.bandFraction + 1e-12);
      EXPECT_EQ(b.contactBreaks, k);  // one lift per level
      EXPECT_GT(b.pathBreaks, 0);     // the wander crosses the line
      EXPECT_GT(b.totalTimeS, a.totalTimeS);
      EXPECT_GT(b.contact.meanS, a.contact.meanS);
      EXPECT_GT(b.contact.maxS, r[0].metrics.contact.maxS);  // pauses make long dwells
      EXPECT_GT(b.stretchMaxN, a.stretchMaxN);
      EXPECT_GT(b.pathLengthRightMm, a.pathLengthRightMm);
      EXPECT_GT(b.pathLengthLeftMm, a.pathLengthLeftMm);
      EXPECT_LT(r[k].assessment.score, r[k - 1].assessment.score);
      EXPECT_FALSE(r[k].assessment.passed);
    }
    EXPECT_LT(r[3].metrics.bandFraction, r[0].metrics.bandFraction);
  }
}

TEST(Validity, ResamplingChangesNoMetricByMoreThanOnePercent) {
  for (int level : {0, 2}) {
    const RunResult base = attempt("slab-s-curve", level, 1000);
    for (double hz : {100.0, 250.0}) {
      const RunResult r = attempt("slab-s-curve", level, hz);
      SCOPED_TRACE("level " + std::to_string(level) + " at " + std::to_string(int(hz)) + " Hz");
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
  // The drawn path was broken where the cut crossed it.
  EXPECT_EQ(pieces(r.drawn).size(), static_cast<std::size_t>(1 + r.metrics.pathBreaks));
}

}  // namespace
}  // namespace ld::curriculum
