#pragma once
// Speed-against-accuracy and stability experiments behind `lapdissect-cli sim bench`
// and `sim chart` (no Qt here: the command line draws the charts).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sim/physics/mass_spring.h"

namespace ld::physics {

// A scene: the tissue at its start state (settled, then pushed) and how its error is
// measured. `analytic` scenes (the oscillator) compare with the exact solution of
// x'' + c·x' + ω²·x = 0 on vertex 0's x coordinate; the others with a reference run.
struct Scene {
  std::string name;
  Params params;
  State initial;
  bool analytic = false;
  double omega = 0.0, damping = 0.0, x0 = 0.0;  // analytic scenes only
  mesh::Vertex pushed;                          // the vertex pushed 5 mm down (mesh scenes)
};

// Built-in scenes: "oscillator", "patch-release" (the default 80×60×5 mm slab, top
// centre pushed 5 mm down and released), "sliver" (the same slab with a line of
// 0.05 mm sliver triangles). `scale` coarsens (>1) or refines (<1) the slab spacing.
// Throws UnknownNameError for another name.
[[nodiscard]] Scene builtinScene(const std::string& name, double scale = 1.0);
[[nodiscard]] bool isBuiltinScene(const std::string& name);
// Any mesh (e.g. read from a model file): settled, then pushed at its top centre.
[[nodiscard]] Scene sceneFromMesh(mesh::SurfaceMesh m, const std::string& name);

struct BenchResult {
  std::string scene;
  Method method = Method::SymplecticEuler;
  double dt = 0, duration = 0;
  std::uint64_t steps = 0;
  double usPerStep = 0;               // CPU time of the process per step
  double errorRms = 0, errorMax = 0;  // [mm] over all vertices and checkpoints
  bool stable = true;                 // finite, no energy blow-up
  std::uint64_t warnings = 0;         // stability monitor warnings (when it was on)
  std::size_t vertices = 0, triangles = 0;
  [[nodiscard]] double msPerSimulatedSecond() const { return usPerStep * 1e-3 * (1.0 / dt); }
};

// Positions of every vertex at `checkpoints` equally spaced times in (0, duration].
using Trajectory = std::vector<std::vector<Eigen::Vector3d>>;

// Runs `method` for `duration` with step dt (monitor off unless `monitor`), recording
// the trajectory at the checkpoints (each must fall on a step: duration/checkpoints a
// multiple of dt, within rounding).
Trajectory runScene(const Scene& s, Method method, double dt, double duration, int checkpoints, bool monitor,
                    BenchResult* result);

// The converged reference: analytic for the oscillator, RK4 with step dtRef otherwise.
Trajectory referenceTrajectory(const Scene& s, double dtRef, double duration, int checkpoints);

// Fills the error fields of r by comparing run with ref.
void compareTrajectories(const Trajectory& run, const Trajectory& ref, BenchResult& r);

// `sim bench`: one run against a reference of the same scene (RK4 at dt/64).
BenchResult benchScene(const Scene& s, Method method, double dt, double duration, bool monitor = false);

// Active-region mode against the full solve on the same interaction: from the settled
// scene, a 5 mN push on the top-centre vertex for the first half of `duration`, then
// release. Reports the fraction of vertex-steps integrated, the largest position
// difference from the full solve at any step, and both step costs (CPU time).
struct ActiveComparison {
  double workFraction = 1.0;
  double maxDifference = 0.0;  // [mm]
  double usPerStepFull = 0.0, usPerStepActive = 0.0;
  std::uint64_t steps = 0;
};
ActiveComparison compareActiveRegion(const Scene& s, double dt, double duration);

// Largest dt (searched on a log scale in [lo, hi]) for which `steps` raw steps of
// method keep the scene finite and its energy within 1.5× the start energy.
// Returns hi when even hi is stable (check with `capped`).
double largestStableDt(const Scene& s, Method method, double lo, double hi, int steps, int iterations,
                       bool* capped = nullptr);

// ---- the chart data --------------------------------------------------------------
struct SpeedAccuracyRow {
  BenchResult r;
};
struct StabilityRow {
  std::string sweep;  // "stiffness" (x = K in mN) or "min_edge" (x = smallest edge in mm)
  double x = 0;
  Method method = Method::SymplecticEuler;
  double largestStableDt = 0;
  bool capped = false;  // stable up to the largest dt tried
};
// Progress callback: a short line of text per finished item.
using Progress = std::function<void(const std::string&)>;
std::vector<BenchResult> speedAccuracySweep(const Progress& progress = {});
std::vector<StabilityRow> stabilitySweep(const Progress& progress = {});

}  // namespace ld::physics
