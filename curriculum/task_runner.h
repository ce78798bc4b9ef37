#pragma once
// Runs a task headless from a trajectory (the scripted device): finds where the
// cutting instrument meets the tissue sample by sample, records the cut path on the
// tissue, breaks the drawn path where the cut crosses it, and computes the metrics
// live, then the score. The tissue is the task's model at rest (no physics); the
// instant contact starts or ends between two samples is found by bisection on the
// interpolated pose, so the result does not depend on the sampling rate.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "curriculum/metrics/live.h"
#include "curriculum/metrics/score.h"
#include "curriculum/task.h"
#include "devices/trajectory.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::curriculum {

struct RunOptions {
  int bisections = 40;           // contact transition search between two samples
  double grabDistance = 1.5;     // mm: closed jaws this near the surface hold it
  double grabJaw = 0.2;          // jaw opening at or below which the grasper is closed
  double seriesInterval = 0.05;  // s between points of the metric time series
};

struct RunResult {
  Metrics metrics;
  Assessment assessment;
  Polyline drawn;  // the drawn path after the run, broken where it was cut
  Polyline cut;    // the recorded cut path
  std::vector<SeriesPoint> series;
  std::size_t samples = 0;
  std::size_t contactSamples = 0;
};

// `m` is the task's model (already loaded). Throws PathError when the task's path
// does not lie on the model.
RunResult runTask(const Task& task, const mesh::SurfaceMesh& m, const devices::Trajectory& tr,
                  const RunOptions& options = {});

// The metrics object of DESIGN.md (`task run`), with extra keys.
nlohmann::json metricsJson(const Metrics& m, const Assessment& a);
nlohmann::json runJson(const Task& task, const RunResult& r);

}  // namespace ld::curriculum
