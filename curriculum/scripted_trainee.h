#pragma once
// Scripted trainees for validity checks and demos: a smooth, continuous-time motion
// that follows a task's drawn path with an L-hook (pedal down while cutting) and holds
// the tissue with a grasper, with a chosen amount of lateral wander, pauses and lifts.
// The motion is a function of time with fixed seeds, so sampling it at any rate gives
// the same movement.
#include <string>

#include "curriculum/task.h"
#include "devices/trajectory.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::curriculum {

struct TraineeProfile {
  std::string name = "expert";
  double speed = 8.0;          // mm/s along the path
  double speedWobble = 0.0;    // fraction of speed, slow surging
  double lateralBias = 0.15;   // mm, constant offset to one side
  double lateralNoise = 0.15;  // mm, amplitude of smooth lateral wander (zero mean)
  // Spatial frequencies of that wander, per mm of path: [1/40, 1/10] x wanderScale (a
  // novice corrects more often, so the line is crossed more often).
  double wanderScale = 1.0;
  // mm, amplitude of fast lateral corrections (wavelengths of 1.5 to 4 mm of path,
  // divided by fastScale: the unsteady hand), on top of the slow wander.
  double fastNoise = 0.0;
  double fastScale = 1.0;
  double depth = 0.8;  // mm, hook elbow below the surface while cutting
  int pauses = 0;      // stops of pauseS seconds along the path
  double pauseS = 1.2;
  int lifts = 0;  // contact losses of liftS seconds along the path
  double liftS = 0.6;
  double pull = 4.0;       // mm the grasper stretches the tissue
  double pullNoise = 0.0;  // mm, jerkiness of the grasper
  unsigned seed = 1;
};

// 0 = expert, 1..3 = novices with growing lateral wander (larger, and of higher
// spatial frequency), fast lateral corrections, pauses, lifts, slower and surging
// speed and a harder, jerkier pull of the grasper.
TraineeProfile traineeProfile(int level, unsigned seed = 1);

// Samples the scripted motion at `rateHz` (both hands at every sample time).
devices::Trajectory scriptedAttempt(const Task& task, const mesh::SurfaceMesh& m, const TraineeProfile& p,
                                    double rateHz);

}  // namespace ld::curriculum
