#pragma once
// The tissue simulation behind the window: a physics::SimulationLoop on its own
// thread (it settles the tissue first, then runs at a fixed rate), read by the GUI
// thread through snapshots only. The mouse pushes the tissue through a virtual
// spring between the picked vertex and the cursor's point.
#include <QString>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "app/gui/render_mesh.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::physics {
class SimulationLoop;
}
namespace ld::cutting {
class CutEngine;
struct StepResult;
}  // namespace ld::cutting
namespace ld::physics {
struct State;
}

namespace ld::gui {

class PhysicsSession {
 public:
  // Stiffness of the mouse's virtual spring [mN/mm] and the largest force it exerts [mN].
  static constexpr double kPushStiffness = 20.0;
  static constexpr double kMaxPushForce = 400.0;
  static constexpr double kPushRadius = 4.0;  // [mm] the pulled patch around the picked vertex

  explicit PhysicsSession(mesh::SurfaceMesh mesh);
  ~PhysicsSession();
  PhysicsSession(const PhysicsSession&) = delete;
  PhysicsSession& operator=(const PhysicsSession&) = delete;

  // Copies the latest snapshot into `out` when it is newer than the last one taken.
  // Returns true then; `topologyChanged` tells whether the triangles changed too.
  bool update(RenderMesh& out, bool& topologyChanged);

  // Pulls vertex v toward `target` with the virtual spring (call again as the cursor
  // or the tissue moves); release() lets go.
  void pushToward(std::uint32_t vertex, const Eigen::Vector3d& target);
  void release();
  // A force spread over the patch around the vertex nearest `point` (--push).
  void forceAt(const Eigen::Vector3d& point, const Eigen::Vector3d& force);

  // Scalpel cutting (when the cutting module is built): one stroke sample with the
  // blade's tip `depth` mm under the surface point `surface` whose outward normal is
  // `normal`, moving along `motion`. Runs on the simulation thread between steps.
  [[nodiscard]] static bool cuttingAvailable();
  void cutSample(const Eigen::Vector3d& surface, const Eigen::Vector3d& normal, const Eigen::Vector3d& motion,
                 double depth);
  void endCut();
  [[nodiscard]] long trianglesCut() const { return trianglesCut_.load(); }

  [[nodiscard]] bool settled() const;
  [[nodiscard]] double settleProgress() const;
  [[nodiscard]] double simTime() const;
  [[nodiscard]] QString status() const;  // one line for the status bar

 private:
  void storeFaceKinds(const mesh::SurfaceMesh& m);
  void afterCut(physics::State& st, const cutting::StepResult& r);

  // Force f spread over the patch around vertex (total f).
  void applyPatchForce(std::uint32_t vertex, const Eigen::Vector3d& f);

  // Declared before the loop so it outlives the simulation thread that uses it.
  std::unique_ptr<cutting::CutEngine> engine_;
  int objectId_ = -1;
  std::atomic<long> trianglesCut_{0};
  mutable std::mutex kindsMutex_;
  std::vector<std::uint8_t> kinds_;  // per live face, as the snapshot lists them
  std::uint64_t kindsTopology_ = ~std::uint64_t{0};
  std::string lastCutError_;
  RenderMesh pieces_;  // parts a cut-through set free (shown, not simulated)
  std::uint64_t piecesVersion_ = 0, piecesShown_ = 0;

  std::unique_ptr<physics::SimulationLoop> loop_;
  std::uint64_t lastSerial_ = 0;
  std::uint64_t lastTopology_ = 0;
  bool first_ = true;
  std::optional<std::uint32_t> pushed_;
  std::uint64_t patchTopology_ = ~std::uint64_t{0};
  std::uint32_t patchCentre_ = ~std::uint32_t{0};
  std::vector<std::uint32_t> patchVertices_;
  double pushForce_ = 0.0;
};

}  // namespace ld::gui
