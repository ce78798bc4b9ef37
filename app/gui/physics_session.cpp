#include "app/gui/physics_session.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "sim/physics/mass_spring.h"
#include "sim/physics/simulation_loop.h"

namespace ld::gui {

PhysicsSession::PhysicsSession(mesh::SurfaceMesh mesh) {
  physics::Params params;
  // The default slab has ~1.5 mm edges; at the loop's 1 ms step the thesis's masses
  // (5 mm thick water) would make the symplectic step unstable (omega * dt > 2), so
  // the GUI's tissue is five times denser: omega * dt stays about 1.
  params.tissue.density = 2.5e-5;
  physics::SimulationLoop::Options options;
  options.settle.tolerance = 1e-2;  // [mN]: visually at rest
  options.settle.maxTime = 5.0;
  options.rateHz = 1000.0;
  options.publishHz = 60.0;
  options.settleFirst = true;
  physics::State state = physics::makeState(std::move(mesh), params.tissue);
  loop_ = std::make_unique<physics::SimulationLoop>(params, std::move(state), options);
  loop_->start();
}

PhysicsSession::~PhysicsSession() { loop_->stop(); }

bool PhysicsSession::update(RenderMesh& out, bool& topologyChanged) {
  bool changed = false;
  topologyChanged = false;
  loop_->withSnapshot([&](const physics::Snapshot& s) {
    if (!first_ && s.serial == lastSerial_) return;
    changed = true;
    topologyChanged = first_ || s.topologyVersion != lastTopology_ || out.positions.size() != s.positions.size();
    first_ = false;
    lastSerial_ = s.serial;
    lastTopology_ = s.topologyVersion;
    out.positions.resize(s.positions.size());
    for (std::size_t i = 0; i < s.positions.size(); ++i)
      out.positions[i] = {static_cast<float>(s.positions[i].x()), static_cast<float>(s.positions[i].y()),
                          static_cast<float>(s.positions[i].z())};
    if (topologyChanged) out.triangles.assign(s.triangles.begin(), s.triangles.end());
  });
  return changed;
}

void PhysicsSession::pushToward(std::uint32_t vertex, const Eigen::Vector3d& target) {
  Eigen::Vector3d at = target;
  loop_->withSnapshot([&](const physics::Snapshot& s) {
    if (vertex < s.positions.size()) at = s.positions[vertex];
  });
  Eigen::Vector3d f = kPushStiffness * (target - at);
  if (f.norm() > kMaxPushForce) f *= kMaxPushForce / f.norm();
  pushed_ = vertex;
  applyPatchForce(vertex, f);
}

void PhysicsSession::applyPatchForce(std::uint32_t vertex, const Eigen::Vector3d& f) {
  // The pull acts on a small disc around the picked vertex, like an instrument's
  // tip, not on one vertex: weights (1 - d/r)^2 within r, normalised to the total.
  std::vector<std::pair<std::uint32_t, double>> patch;
  loop_->withSnapshot([&](const physics::Snapshot& s) {
    if (vertex >= s.positions.size()) return;
    const Eigen::Vector3d at = s.positions[vertex];
    if (patchTopology_ != s.topologyVersion || patchCentre_ != vertex) {
      patchTopology_ = s.topologyVersion;
      patchCentre_ = vertex;
      std::vector<bool> used(s.positions.size(), false);
      for (const auto& t : s.triangles)
        for (auto v : t) used[v] = true;
      patchVertices_.clear();
      for (std::uint32_t v = 0; v < s.positions.size(); ++v)
        if (used[v] && (s.positions[v] - at).norm() < kPushRadius) patchVertices_.push_back(v);
    }
    double total = 0;
    for (auto v : patchVertices_) {
      const double w = std::pow(1.0 - std::min((s.positions[v] - at).norm() / kPushRadius, 1.0), 2);
      patch.emplace_back(v, w);
      total += w;
    }
    for (auto& [v, w] : patch) w /= total;
  });
  pushForce_ = f.norm();
  if (patch.empty()) patch.emplace_back(vertex, 1.0);
  for (const auto& [v, w] : patch) loop_->setForce(mesh::Vertex(v), w * f);
}

void PhysicsSession::release() {
  pushed_.reset();
  pushForce_ = 0.0;
  loop_->clearForces();
}

void PhysicsSession::forceAt(const Eigen::Vector3d& point, const Eigen::Vector3d& force) {
  std::optional<std::uint32_t> nearest;
  loop_->withSnapshot([&](const physics::Snapshot& s) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : s.triangles)
      for (auto v : t)
        if (const double d = (s.positions[v] - point).squaredNorm(); d < best) {
          best = d;
          nearest = v;
        }
  });
  if (nearest) applyPatchForce(*nearest, force);
}

bool PhysicsSession::settled() const { return loop_->isSettled(); }
double PhysicsSession::settleProgress() const { return loop_->settleProgress(); }

double PhysicsSession::simTime() const {
  double t = 0.0;
  loop_->withSnapshot([&](const physics::Snapshot& s) { t = s.simTime; });
  return t;
}

QString PhysicsSession::status() const {
  if (!loop_->isSettled())
    return QStringLiteral("Physics: settling %1%").arg(static_cast<int>(100.0 * loop_->settleProgress()));
  std::uint64_t warnings = 0;
  double t = 0.0;
  loop_->withSnapshot([&](const physics::Snapshot& s) {
    warnings = s.stabilityWarnings;
    t = s.simTime;
  });
  const auto st = loop_->stats();
  QString line = QStringLiteral("Physics: t = %1 s, step %2 µs (p95 %3), late %4")
                     .arg(t, 0, 'f', 1)
                     .arg(st.meanUs, 0, 'f', 0)
                     .arg(st.p95Us, 0, 'f', 0)
                     .arg(st.missedDeadlines);
  if (warnings) line += QStringLiteral(", %1 stability warnings").arg(warnings);
  if (pushForce_ > 0) line += QStringLiteral(", push %1 mN").arg(pushForce_, 0, 'f', 0);
  return line;
}

}  // namespace ld::gui
