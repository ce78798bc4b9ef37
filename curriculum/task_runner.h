#pragma once
// Runs a task headless from a trajectory (the scripted device) through the cutting
// engine (ld::cutting::CutEngine): every sample of the cutting hand cuts the tissue;
// the engine's contacts give the contact time and breaks, its cut points the cut path
// (one straight piece per original triangle, a stop at each loss of contact). The
// drawn path is embedded in the tissue and follows the cuts (re-embedded from the
// mesh's edit journal where its triangles are subdivided; broken where the cut
// crosses it). Metrics are computed live, then the score. The tissue moves under the
// mass-spring physics (symplectic steps of at most 1 ms with the mass floor); a
// closed grasper holds the vertices its jaws touch with stiff penalty springs, and
// the sum of those spring forces is the grasper's stretch force (README). The
// instant contact starts or ends between two samples is found by bisection on the
// interpolated pose, so contact times do not depend on the sampling rate.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "curriculum/metrics/live.h"
#include "curriculum/metrics/score.h"
#include "curriculum/task.h"
#include "devices/trajectory.h"
#include "sim/cutting/cutter.h"
#include "sim/mesh/surface_mesh.h"
#include "sim/physics/tissue_properties.h"

namespace ld::curriculum {

struct RunOptions {
  int bisections = 24;           // contact transition search between two samples
  double grabDistance = 1.5;     // mm: closed jaws this near the surface hold it
  double grabJaw = 0.2;          // jaw opening at or below which the grasper is closed
  double seriesInterval = 0.05;  // s between points of the metric time series
  cutting::CutParams cut;
  // Physics (task run --physics on; the CLI defaults to off): the tissue is stepped while the
  // trajectory plays and the grasper force is the sum of its penalty springs. Off:
  // no motion, and the force is the estimate home stiffness x grasper displacement.
  bool physics = true;
  // With physics: the tissue the blade and the drawn path see is held still (as the
  // window holds it while the blade is in it), and the physics runs on a displaced
  // copy of it (the same mesh, cuts and springs, positions = still + displacement)
  // that gives the grasper's force. The cut then does not move under the blade (the
  // cutter loses tracks on tissue moving under it, which would count against the
  // trainee), and the force still feels the cut. `task run` uses this by default.
  bool holdUnderBlade = false;
  // Physics on (moving): a crossing of the drawn path stands once the cut recorded at
  // rest is this far beyond the line (mm). The cut snaps to the mesh's vertices and
  // edges (CutParams::snapFraction of an edge: up to ~0.25 mm on the bundled models, the
  // still cut's own largest distance from the blade's path) and the tissue moving
  // under the blade adds to that (README).
  double crossingBandMm = 0.4;
  // Physics on (moving): the cutting hand follows the drawn path where the tissue has
  // carried it; each of its samples is shifted by the path's displacement at the point
  // nearest the working point as authored. For scripted attempts, which are authored
  // on the still tissue: a trainee watching the screen follows the line as it moves.
  // Off for recorded trajectories (they are what the hand did).
  bool followMovingPath = false;
  double physicsDt = 1e-3;         // s, the longest step (the workstation's 1 kHz loop)
  double graspStiffness = 1000.0;  // mN/mm, penalty spring per held vertex
  double graspRadius = 1.5;        // mm: vertices this near the grasp point are held
  double layerMm = 5.0;            // thickness turning the task's density into an areal one
};

// The physics parameters of a task's tissue (K, rest ratio, home stiffness, damping
// as given; areal density = density [g/cm³] x layerMm; mass floor for physicsDt).
physics::TissueParams tissueParams(const TissueSettings& t, const RunOptions& options = {});

// Sets every home so that the mesh as it is is at rest (spring forces balanced by
// the home springs): the pre-stretched springs would otherwise pull the model away
// from where the task's path and trajectories were authored. Needs homeK > 0 and the
// tissue properties. Returns the largest residual force afterwards [mN].
double balanceHomes(mesh::SurfaceMesh& m, const physics::TissueParams& p);

struct PhysicsStats {
  bool on = false;
  bool heldStill = false;        // holdUnderBlade: the cut on the still tissue
  double maxDisplacementMm = 0;  // held still: farthest the simulated tissue was from it
  long steps = 0;                // physics steps (all objects)
  double seconds = 0.0;          // wall time in physics steps
  double startResidualMn = 0;    // largest net force at the start (after balancing)
  std::uint64_t rejectedSteps = 0, implicitFallbacks = 0;
  int grasps = 0;                // times the grasper took hold
  std::size_t heldVertices = 0;  // vertices held, summed over grasps
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
  std::size_t pathFreed = 0;           // drawn-path points on pieces the cut freed
  double pathMovedMm = 0.0;            // farthest a drawn-path point ended from where it was drawn
  std::vector<SeriesPoint> series;
  std::vector<ForceSample> grasp;  // the grasper's force at each of its samples
  std::size_t samples = 0;
  std::size_t contactSamples = 0;
  PhysicsStats physics;
};

// `m` is the task's model (already loaded). Throws PathError when the task's path
// does not lie on the model.
RunResult runTask(const Task& task, const mesh::SurfaceMesh& m, const devices::Trajectory& tr,
                  const RunOptions& options = {});

// The metrics object of DESIGN.md (`task run`), with extra keys.
nlohmann::json metricsJson(const Metrics& m, const Assessment& a);
nlohmann::json runJson(const Task& task, const RunResult& r);

}  // namespace ld::curriculum
