#pragma once
// The fixed-step physics on its own thread.
//
// - The loop steps at a set rate (1 kHz default) with sleep-until deadlines; a step
//   that ends after its deadline counts as missed; when it falls more than
//   maxCatchUp periods behind it drops the backlog instead of spiralling.
// - Readers (the GUI thread) get the latest snapshot (positions, triangles, normals,
//   version counters), double-buffered: the loop fills the back buffer and swaps it
//   in when no reader holds the front one, so the loop never waits for a reader.
// - Writers (devices, the GUI's mouse) send forces and commands through a
//   thread-safe queue; the loop applies them between steps.
// - Before the fixed-rate phase the tissue settles (progress() goes 0 → 1) while
//   snapshots keep coming, so a window can show the settling.
#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "sim/physics/mass_spring.h"

namespace ld::physics {

struct Snapshot {
  std::vector<Eigen::Vector3d> positions;               // by vertex index (deleted slots included)
  std::vector<Eigen::Vector3d> normals;                 // by vertex index
  std::vector<std::array<std::uint32_t, 3>> triangles;  // live faces
  std::uint64_t topologyVersion = 0;                    // changes when triangles change
  std::uint64_t step = 0;                               // simulation steps taken
  std::uint64_t serial = 0;                             // increments with every published snapshot
  double simTime = 0.0;
  bool settling = false;
  std::uint64_t stabilityWarnings = 0;
};

struct LoopStats {
  std::uint64_t steps = 0;
  std::uint64_t missedDeadlines = 0;                              // steps that finished after their deadline
  std::uint64_t droppedPeriods = 0;                               // periods skipped after falling behind
  double meanUs = 0, p50Us = 0, p95Us = 0, p99Us = 0, maxUs = 0;  // step compute time
  std::vector<std::uint64_t> histogram;                           // step time counts, bins of histogramBinUs
  double histogramBinUs = 50.0;
};

class SimulationLoop {
 public:
  struct Options {
    double rateHz = 1000.0;
    double publishHz = 120.0;  // snapshots per second (at most one per step)
    bool settleFirst = true;
    SettleOptions settle;
    int maxCatchUp = 10;  // periods behind before the backlog is dropped
  };

  SimulationLoop(Params params, State state, Options options);
  SimulationLoop(Params params, State state) : SimulationLoop(std::move(params), std::move(state), Options{}) {}
  ~SimulationLoop();  // stops the thread
  SimulationLoop(const SimulationLoop&) = delete;
  SimulationLoop& operator=(const SimulationLoop&) = delete;

  void start();
  void stop();  // joins; the state can then be read with state()
  [[nodiscard]] bool isRunning() const { return running_.load(); }

  // ---- any thread ----------------------------------------------------------
  // Sets the external force on a vertex (replacing the previous one) until cleared.
  void setForce(mesh::Vertex v, const Eigen::Vector3d& f);
  // The force at the vertex nearest `point` (the GUI's picked point).
  void setForceAt(const Eigen::Vector3d& point, const Eigen::Vector3d& f);
  void clearForces();
  // Runs between two steps on the simulation thread (topology edits, parameter changes).
  void post(std::function<void(Params&, State&)> command);
  void setParams(const Params& p);

  // Calls fn with the latest snapshot while holding it (keep fn short).
  void withSnapshot(const std::function<void(const Snapshot&)>& fn) const;
  [[nodiscard]] Snapshot snapshot() const;  // a copy
  [[nodiscard]] double settleProgress() const { return settleProgress_.load(); }
  [[nodiscard]] bool isSettled() const { return settled_.load(); }
  [[nodiscard]] LoopStats stats() const;

  // Only while stopped.
  [[nodiscard]] const State& state() const { return state_; }
  [[nodiscard]] const Params& params() const { return params_; }

 private:
  void run();
  void drainQueue();
  void publish(bool settling);
  void recordStepTime(double us);

  Params params_;
  State state_;
  Options options_;
  std::thread thread_;
  std::atomic<bool> running_{false}, stopRequested_{false}, settled_{false};
  std::atomic<double> settleProgress_{0.0};

  mutable std::mutex queueMutex_;
  std::vector<std::function<void(Params&, State&)>> queue_;
  std::vector<std::pair<mesh::Vertex, Eigen::Vector3d>> forcedVertices_;  // sim thread only

  mutable std::mutex frontMutex_;
  Snapshot front_, back_;
  std::uint64_t serial_ = 0;

  mutable std::mutex statsMutex_;
  std::vector<double> recent_;  // ring of recent step times [µs]
  std::size_t recentNext_ = 0;
  LoopStats stats_;
  double sumUs_ = 0;
};

}  // namespace ld::physics
