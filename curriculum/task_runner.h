#pragma once
// Runs a task headless from a trajectory (the scripted device) through the cutting
// engine (ld::cutting::CutEngine): every sample of the cutting hand cuts the tissue;
// the engine's contacts give the contact time and breaks, its cut points the cut path
// (one straight piece per original triangle, a stop at each loss of contact). The
// drawn path is embedded in the tissue and follows the cuts (re-embedded from the
// mesh's edit journal where its triangles are subdivided; broken where the cut
// crosses it). Metrics are computed live, then the score. The tissue does not move
// (no physics yet): the grasper's stretch force is an estimate (see README). The
// instant contact starts or ends between two samples is found by bisection on the
// interpolated pose, so contact times do not depend on the sampling rate.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "curriculum/metrics/live.h"
#include "curriculum/metrics/score.h"
#include "curriculum/task.h"
#include "devices/trajectory.h"
#include "sim/cutting/cutter.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::curriculum {

struct RunOptions {
  int bisections = 24;           // contact transition search between two samples
  double grabDistance = 1.5;     // mm: closed jaws this near the surface hold it
  double grabJaw = 0.2;          // jaw opening at or below which the grasper is closed
  double seriesInterval = 0.05;  // s between points of the metric time series
  cutting::CutParams cut;
};

struct RunResult {
  Metrics metrics;
  Assessment assessment;
  Polyline drawn;         // the drawn path after the run, broken where it was cut
  Polyline drawnAsDrawn;  // the same points with the pieces as authored
  Polyline cut;           // the recorded cut path
  cutting::CutStats cutStats;
  std::size_t objects = 1;             // tissue objects at the end (separated pieces)
  std::size_t pathReembedded = 0;      // drawn-path points embedded again after edits
  std::size_t pathGlobalSearches = 0;  // of those, found by a search of the whole mesh
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
