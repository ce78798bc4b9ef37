#include "sim/physics/simulation_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "sim/physics/physics_error.h"
#include "sim/physics/scenes.h"

namespace ld::physics {

using Clock = std::chrono::steady_clock;
using Vec3 = Eigen::Vector3d;

namespace {
constexpr std::size_t kRecent = 4096;
constexpr std::size_t kBins = 64;
}  // namespace

SimulationLoop::SimulationLoop(Params params, State state, Options options)
    : params_(std::move(params)), state_(std::move(state)), options_(std::move(options)) {
  if (!(options_.rateHz > 0.0)) throw PhysicsError("SimulationLoop: rate must be positive");
  if (!hasTissueProperties(state_.mesh)) throw MissingPropertyError(kHomeProp);
  stats_.histogram.assign(kBins, 0);
  recent_.reserve(kRecent);
  publish(false);  // nobody reads yet, so this lands in the front buffer
}

SimulationLoop::~SimulationLoop() { stop(); }

void SimulationLoop::start() {
  if (running_.load()) return;
  stopRequested_ = false;
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void SimulationLoop::stop() {
  stopRequested_ = true;
  if (thread_.joinable()) thread_.join();
  running_ = false;
  drainQueue();  // commands posted after the last step still apply
}

void SimulationLoop::setForce(mesh::Vertex v, const Vec3& f) {
  post([this, v, f](Params&, State& s) {
    if (!s.mesh.isValid(v)) return;
    s.mesh.getVertexProperty<Vec3>(kForceProp)[v] = f;
    forcedVertices_.emplace_back(v, f);
  });
}

void SimulationLoop::setForceAt(const Vec3& point, const Vec3& f) {
  post([this, point, f](Params&, State& s) {
    const auto v = nearestVertex(s.mesh, point);
    if (!v.isValid()) return;
    s.mesh.getVertexProperty<Vec3>(kForceProp)[v] = f;
    forcedVertices_.emplace_back(v, f);
  });
}

void SimulationLoop::clearForces() {
  post([this](Params&, State& s) {
    auto ext = s.mesh.getVertexProperty<Vec3>(kForceProp);
    for (auto& [v, f] : forcedVertices_)
      if (s.mesh.isValid(v)) ext[v].setZero();
    forcedVertices_.clear();
  });
}

void SimulationLoop::post(std::function<void(Params&, State&)> command) {
  std::lock_guard lock(queueMutex_);
  queue_.push_back(std::move(command));
}

void SimulationLoop::setParams(const Params& p) {
  post([p](Params& mine, State&) { mine = p; });
}

void SimulationLoop::drainQueue() {
  std::vector<std::function<void(Params&, State&)>> todo;
  {
    std::lock_guard lock(queueMutex_);
    todo.swap(queue_);
  }
  for (auto& c : todo) c(params_, state_);
}

void SimulationLoop::publish(bool settling) {
  // Fill the back buffer without any lock (only this thread touches it).
  const auto& m = state_.mesh;
  back_.positions = m.positions();
  back_.normals = m.vertexNormals();
  if (back_.topologyVersion != m.topologyVersion() || back_.triangles.size() != m.nFaces() || back_.serial == 0) {
    back_.triangles.clear();
    back_.triangles.reserve(m.nFaces());
    for (auto f : m.faces()) {
      const auto& vs = m.vertices(f);
      back_.triangles.push_back({vs[0].idx(), vs[1].idx(), vs[2].idx()});
    }
  }
  back_.topologyVersion = m.topologyVersion();
  back_.step = state_.steps;
  back_.simTime = state_.time;
  back_.settling = settling;
  back_.stabilityWarnings = state_.stability.warnings;
  back_.serial = ++serial_;
  // Swap only when no reader holds the front buffer; otherwise publish next time.
  std::unique_lock lock(frontMutex_, std::try_to_lock);
  if (lock.owns_lock()) std::swap(front_, back_);
}

void SimulationLoop::withSnapshot(const std::function<void(const Snapshot&)>& fn) const {
  std::lock_guard lock(frontMutex_);
  fn(front_);
}

Snapshot SimulationLoop::snapshot() const {
  std::lock_guard lock(frontMutex_);
  return front_;
}

void SimulationLoop::recordStepTime(double us) {
  std::lock_guard lock(statsMutex_);
  ++stats_.steps;
  sumUs_ += us;
  stats_.maxUs = std::max(stats_.maxUs, us);
  const auto bin = std::min<std::size_t>(kBins - 1, static_cast<std::size_t>(us / stats_.histogramBinUs));
  ++stats_.histogram[bin];
  if (recent_.size() < kRecent) {
    recent_.push_back(us);
  } else {
    recent_[recentNext_] = us;
    recentNext_ = (recentNext_ + 1) % kRecent;
  }
}

LoopStats SimulationLoop::stats() const {
  std::lock_guard lock(statsMutex_);
  LoopStats s = stats_;
  if (s.steps > 0) s.meanUs = sumUs_ / static_cast<double>(s.steps);
  if (!recent_.empty()) {
    std::vector<double> sorted = recent_;
    std::sort(sorted.begin(), sorted.end());
    auto q = [&](double p) { return sorted[static_cast<std::size_t>(p * static_cast<double>(sorted.size() - 1))]; };
    s.p50Us = q(0.50);
    s.p95Us = q(0.95);
    s.p99Us = q(0.99);
  }
  return s;
}

void SimulationLoop::run() {
  FlushDenormals ftz;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.rateHz));
  const auto publishPeriod =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.publishHz));
  const double dt = 1.0 / options_.rateHz;
  auto lastPublish = Clock::now();

  if (options_.settleFirst && !settled_.load()) {
    SettleOptions so = options_.settle;
    so.dt = dt;
    so.progress = [&](double prog, double residual) {
      settleProgress_ = prog;
      if (options_.settle.progress) options_.settle.progress(prog, residual);
      if (Clock::now() - lastPublish >= publishPeriod) {
        publish(true);
        lastPublish = Clock::now();
      }
      drainQueue();
    };
    so.cancel = [this] { return stopRequested_.load(); };
    settle(params_, state_, so);
  }
  settleProgress_ = 1.0;
  settled_ = true;
  publish(false);
  lastPublish = Clock::now();

  auto deadline = Clock::now() + period;
  while (!stopRequested_.load()) {
    drainQueue();
    const auto t0 = Clock::now();
    step(params_, state_, dt);
    const auto t1 = Clock::now();
    recordStepTime(std::chrono::duration<double, std::micro>(t1 - t0).count());
    if (t1 - lastPublish >= publishPeriod) {
      publish(false);
      lastPublish = Clock::now();
    }
    const auto done = Clock::now();
    if (done > deadline) {
      std::lock_guard lock(statsMutex_);
      ++stats_.missedDeadlines;
      if (done - deadline > options_.maxCatchUp * period) {
        const auto behind = (done - deadline) / period;
        stats_.droppedPeriods += static_cast<std::uint64_t>(behind);
        deadline += behind * period;
      }
    } else {
      std::this_thread::sleep_until(deadline);
    }
    deadline += period;
  }
  publish(false);
}

}  // namespace ld::physics
