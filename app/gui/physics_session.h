#pragma once
// The tissue simulation behind the window. A thread of its own steps every tissue
// object of a cutting::CutEngine in place (physics::step on the engine's meshes, one
// physics::Dynamics per object) at a fixed rate, after settling the tissue first.
// The GUI thread talks to it through a command queue (cuts, pushes, grasps run
// between two steps) and reads published frames only, never the meshes.
//
// Object 0 is the tissue as loaded; a cut-through that frees a part adds an object
// that is simulated like the rest and can be grasped and moved: dragging translates
// the piece's home positions, so the springs pull it along and it stays where it is
// dropped.
#include <QString>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "app/gui/render_mesh.h"
#include "sim/mesh/surface_mesh.h"
#include "sim/physics/mass_spring.h"

namespace ld::cutting {
class CutEngine;
struct StepResult;
}  // namespace ld::cutting

namespace ld::gui {

// One tissue object as drawn: positions by vertex slot (deleted slots are kept, not
// referenced), so vertex indices are the mesh's own.
struct SceneObject {
  int id = 0;
  int parent = -1;  // the object it was cut from, or -1
  RenderMesh mesh;
  std::uint64_t topology = 0;  // changes when the triangles change
};

// Where the cut follows the blade inside a triangle (CutEngine's preview), in mm.
struct PreviewLine {
  Vec3f from{}, to{}, depth{};
  bool operator==(const PreviewLine&) const = default;
};

struct SceneFrame {
  std::vector<SceneObject> objects;
  std::vector<PreviewLine> preview;
  std::uint64_t serial = 0;
  double simTime = 0.0;
};

class PhysicsSession {
 public:
  // Stiffness of the mouse's virtual spring [mN/mm] and the largest force it exerts [mN].
  static constexpr double kPushStiffness = 20.0;
  static constexpr double kMaxPushForce = 400.0;
  static constexpr double kPushRadius = 4.0;  // [mm] the pulled patch around the picked vertex

  struct Options {
    double rateHz = 1000.0;
    double publishHz = 60.0;
    double settleTolerance = 1e-2;  // [mN]: visually at rest
    double settleMaxTime = 5.0;     // [s] simulated
  };

  explicit PhysicsSession(mesh::SurfaceMesh mesh) : PhysicsSession(std::move(mesh), Options{}) {}
  PhysicsSession(mesh::SurfaceMesh mesh, Options options);
  ~PhysicsSession();
  PhysicsSession(const PhysicsSession&) = delete;
  PhysicsSession& operator=(const PhysicsSession&) = delete;

  // The tissue parameters the window simulates with (much weaker home springs than
  // the defaults so that a wound opens by several millimetres under the pre-stretch).
  [[nodiscard]] static physics::Params defaultParams();

  // Copies the latest frame into `out` when it is newer than the one it holds.
  // Returns true then; `topologyChanged` tells whether any object's triangles (or the
  // list of objects) changed too.
  bool update(SceneFrame& out, bool& topologyChanged);
  // Object 0 only (the tissue as loaded).
  bool update(RenderMesh& out, bool& topologyChanged);

  // Pulls vertex v of an object toward `target` with the virtual spring (call again
  // as the cursor or the tissue moves); release() lets go.
  void pushToward(int object, std::uint32_t vertex, const Eigen::Vector3d& target);
  void pushToward(std::uint32_t vertex, const Eigen::Vector3d& target) { pushToward(0, vertex, target); }
  void release();
  // A force spread over the patch around the vertex of object 0 nearest `point` (--push).
  void forceAt(const Eigen::Vector3d& point, const Eigen::Vector3d& force);

  // Moves a freed piece: its home positions (and so the piece) by `delta` [mm].
  // Object 0 (the tissue held in place) is not moved.
  void movePiece(int object, const Eigen::Vector3d& delta);
  // Every piece freed so far (on the simulation thread's order of commands).
  void moveAllPieces(const Eigen::Vector3d& delta);
  // The pieces freed by the last stroke that freed any.
  void moveLastFreedPieces(const Eigen::Vector3d& delta);

  // Scalpel cutting (when the cutting module is built): one stroke sample with the
  // blade's tip `depth` mm under the surface point `surface` whose outward normal is
  // `normal`, moving along `motion`. Runs on the simulation thread between steps.
  [[nodiscard]] static bool cuttingAvailable();
  void cutSample(const Eigen::Vector3d& surface, const Eigen::Vector3d& normal, const Eigen::Vector3d& motion,
                 double depth);
  void endCut();
  // While a stroke is open (first sample to endCut) the tissue is held still by default:
  // the cutter closes cut loops (and frees pieces) reliably only on tissue that does not
  // move under the blade (corner strokes through a moving, opening tissue often leave
  // the piece attached: a cutter limit, measured). The wound opens when the blade
  // lifts. Off, the tissue keeps moving under the blade, and what each sample adds
  // settles at once where its springs balance (CutEngine::settleAdded, as `task run
  // --physics on` does; Stats::settledAdded counts the vertices).
  void setHoldWhileCutting(bool on);
  [[nodiscard]] long trianglesCut() const { return trianglesCut_.load(); }
  [[nodiscard]] int objectCount() const { return objectCount_.load(); }

  // Blocks until every command posted so far has run (scripted use and tests).
  void sync();
  // Runs `seconds` of simulated time at once on the simulation thread, as fast as it
  // can, in the order of the commands (scripted strokes pace their samples with it as a
  // hand would, so the tissue moves between samples; tests wait for a number of steps).
  void advance(double seconds);

  // What the loop measured about itself (the status bar and --screenshot's JSON).
  struct Stats {
    std::uint64_t steps = 0;      // fixed steps since the tissue settled
    std::uint64_t late = 0;       // steps that finished after their deadline
    double meanStepUs = 0.0;      // running mean of one step (all objects) [µs]
    double maxStepUs = 0.0;       // largest step in the last second of steps [µs]
    std::uint64_t warnings = 0;   // steps the stability monitor rejected at first
    std::uint64_t implicit = 0;   // ... of which finished with the implicit method
    std::uint64_t resets = 0;     // ... or by zeroing velocities (last resort)
    std::uint64_t nanFrames = 0;  // published frames with a non-finite position
    bool resting = false;         // at rest: the loop sleeps until a command comes
    std::uint64_t settledAdded = 0;  // vertices cuts added that settled at once (hold off)
  };
  [[nodiscard]] Stats stats() const;

  [[nodiscard]] bool settled() const { return settled_.load(); }
  [[nodiscard]] double settleProgress() const { return settleProgress_.load(); }
  [[nodiscard]] double simTime() const;
  [[nodiscard]] QString status() const;  // one line for the status bar

  // A step that moves no vertex more than this [mm] (physics::Dynamics::maxMove) counts
  // toward rest; after a second of such steps the loop stops stepping (the tissue would
  // not move a visible amount: 0.1 µm/s) and only keeps the clock, until a command.
  static constexpr double kRestMove = 1e-7;

 private:
  struct Body {
    int id = 0;
    physics::Dynamics dynamics;
    int stroke = 0;  // the stroke that freed it
  };
  void moveHomes(Body& b, const Eigen::Vector3d& delta);
  using Command = std::function<void()>;

  void post(Command c);
  void run();
  bool drain();                          // true when commands ran
  [[nodiscard]] bool stillStep() const;  // the last step moved nothing (sim thread)
  void stepAll(double dt);
  void noteStep(double us, std::uint64_t window);  // sim thread
  // Always: a new frame for the next update(). IfMoved: only when a vertex moved more
  // than a fraction of a pixel or the triangles or preview changed (the idle loop's).
  enum class Publish { Always, IfMoved };
  void publish(Publish when = Publish::Always);
  mesh::SurfaceMesh& meshOf(int id);
  void movedBy(const Body& b);
  void addBodies();
  void afterCut(const cutting::StepResult& r);
  void setForce(int object, std::uint32_t v, const Eigen::Vector3d& f);              // sim thread
  void clearForces();                                                                // sim thread
  void applyPatchForce(int object, std::uint32_t vertex, const Eigen::Vector3d& f);  // sim thread

  physics::Params params_;
  Options options_;
  std::unique_ptr<cutting::CutEngine> engine_;
  std::unique_ptr<mesh::SurfaceMesh> plain_;                         // the tissue when the cutting module is absent
  std::vector<Body> bodies_;                                         // sim thread
  int strokes_ = 0;                                                  // strokes ended (sim thread)
  bool holdWhileCutting_ = true, strokeOpen_ = false;                // sim thread
  double meanUs_ = 0.0, windowMaxUs_ = 0.0, lastWindowMaxUs_ = 0.0;  // sim thread
  std::vector<std::pair<int, std::uint32_t>> forced_;
  std::optional<std::pair<int, std::uint32_t>> patchKey_;
  std::uint64_t patchTopology_ = ~std::uint64_t{0};
  std::vector<std::uint32_t> patch_;

  std::mutex queueMutex_;
  std::condition_variable queueDone_, queuePosted_;
  std::vector<Command> queue_;
  std::uint64_t posted_ = 0, done_ = 0;

  mutable std::mutex frameMutex_;
  SceneFrame frame_;
  std::vector<PreviewLine> preview_;  // sim thread
  std::uint64_t serial_ = 0;
  std::uint64_t taken_ = 0;
  std::vector<std::pair<int, std::uint64_t>> takenTopology_;

  std::atomic<bool> stop_{false}, settled_{false}, resting_{false};
  std::atomic<double> settleProgress_{0.0}, restSince_{0.0};
  std::atomic<long> trianglesCut_{0}, settledAdded_{0};
  std::atomic<int> objectCount_{1};
  std::atomic<double> pushForce_{0.0};
  std::atomic<std::uint64_t> warnings_{0}, implicit_{0}, resets_{0}, late_{0}, steps_{0}, nanFrames_{0};
  std::atomic<double> meanStepUs_{0.0}, maxStepUs_{0.0};
  mutable std::mutex errorMutex_;
  std::string lastCutError_;
  std::thread thread_;
};

}  // namespace ld::gui
