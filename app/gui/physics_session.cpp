#include "app/gui/physics_session.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "sim/physics/mass_spring.h"
#include "sim/physics/simulation_loop.h"
#ifdef LD_GUI_HAVE_CUTTING
#include "app/gui/model_loader.h"
#include "sim/cutting/cutter.h"
#include "sim/instruments/instrument.h"
#else
namespace ld::cutting {
class CutEngine {};  // never created: the cutting module is not built
}  // namespace ld::cutting
#endif

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
#ifdef LD_GUI_HAVE_CUTTING
  // The engine adds its face and vertex properties to its copy; the simulation takes
  // that copy so the mesh can move between the two on the simulation thread.
  cutting::CutParams cp;
  cp.tissue = params.tissue;
  engine_ = std::make_unique<cutting::CutEngine>(cp);
  objectId_ = engine_->addObject(state.mesh);
  state.mesh = engine_->object(objectId_).mesh;
  state.invalidate();
  storeFaceKinds(state.mesh);
#endif
  loop_ = std::make_unique<physics::SimulationLoop>(params, std::move(state), options);
  loop_->start();
}

PhysicsSession::~PhysicsSession() { loop_->stop(); }  // before the engine goes

bool PhysicsSession::update(RenderMesh& out, bool& topologyChanged) {
  bool changed = false;
  topologyChanged = false;
  loop_->withSnapshot([&](const physics::Snapshot& s) {
    if (!first_ && s.serial == lastSerial_) return;
    std::lock_guard lock(kindsMutex_);
    changed = true;
    topologyChanged = first_ || s.topologyVersion != lastTopology_ || piecesShown_ != piecesVersion_ ||
                      out.positions.size() != s.positions.size() + pieces_.positions.size();
    first_ = false;
    lastSerial_ = s.serial;
    lastTopology_ = s.topologyVersion;
    piecesShown_ = piecesVersion_;
    // The simulated tissue first, then the pieces a cut has set free (not simulated).
    out.positions.resize(s.positions.size() + pieces_.positions.size());
    for (std::size_t i = 0; i < s.positions.size(); ++i)
      out.positions[i] = {static_cast<float>(s.positions[i].x()), static_cast<float>(s.positions[i].y()),
                          static_cast<float>(s.positions[i].z())};
    std::copy(pieces_.positions.begin(), pieces_.positions.end(),
              out.positions.begin() + static_cast<std::ptrdiff_t>(s.positions.size()));
    if (topologyChanged) {
      out.triangles.assign(s.triangles.begin(), s.triangles.end());
      if (kindsTopology_ == s.topologyVersion && kinds_.size() == out.triangles.size())
        out.faceKind = kinds_;
      else
        out.faceKind.assign(out.triangles.size(), 0);
      const auto offset = static_cast<std::uint32_t>(s.positions.size());
      for (const auto& t : pieces_.triangles) out.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
      out.faceKind.insert(out.faceKind.end(), pieces_.faceKind.begin(), pieces_.faceKind.end());
    }
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

bool PhysicsSession::cuttingAvailable() {
#ifdef LD_GUI_HAVE_CUTTING
  return true;
#else
  return false;
#endif
}

void PhysicsSession::storeFaceKinds(const mesh::SurfaceMesh& m) {
#ifdef LD_GUI_HAVE_CUTTING
  std::vector<std::uint8_t> kinds;
  kinds.reserve(m.nFaces());
  const auto prop = m.getFaceProperty<int>(cutting::kFaceKindProp);
  for (auto f : m.faces()) kinds.push_back(prop && prop[f] != cutting::kSurface ? 1 : 0);
  std::lock_guard lock(kindsMutex_);
  kinds_ = std::move(kinds);
  kindsTopology_ = m.topologyVersion();
#else
  (void)m;
#endif
}

#ifdef LD_GUI_HAVE_CUTTING
void PhysicsSession::afterCut(physics::State& st, const cutting::StepResult& r) {
  trianglesCut_ += r.trianglesCut;
  bool stale = false;
  {
    std::lock_guard lock(kindsMutex_);
    stale = kindsTopology_ != st.mesh.topologyVersion();
  }
  // A refused sample (exception) can leave edits without a result saying so.
  if (!r.topologyChanged && !stale) return;
  st.invalidate();  // masses and springs changed around the cut
  storeFaceKinds(st.mesh);
  if (r.separated.empty()) return;
  // Freed pieces stay where they were cut free, drawn but not simulated.
  RenderMesh add;
  for (int id : r.separated) {
    const auto& piece = engine_->object(id).mesh;
    RenderMesh pm = renderMeshFrom(piece);
    const auto kind = piece.getFaceProperty<int>(cutting::kFaceKindProp);
    const auto offset = static_cast<std::uint32_t>(add.positions.size());
    add.positions.insert(add.positions.end(), pm.positions.begin(), pm.positions.end());
    for (auto f : piece.faces()) add.faceKind.push_back(kind && kind[f] != cutting::kSurface ? 1 : 0);
    for (const auto& t : pm.triangles) add.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  std::lock_guard lock(kindsMutex_);
  const auto offset = static_cast<std::uint32_t>(pieces_.positions.size());
  pieces_.positions.insert(pieces_.positions.end(), add.positions.begin(), add.positions.end());
  for (const auto& t : add.triangles) pieces_.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  pieces_.faceKind.insert(pieces_.faceKind.end(), add.faceKind.begin(), add.faceKind.end());
  ++piecesVersion_;
}
#endif

void PhysicsSession::cutSample(const Eigen::Vector3d& surface, const Eigen::Vector3d& normal,
                               const Eigen::Vector3d& motion, double depth) {
#ifdef LD_GUI_HAVE_CUTTING
  // Scalpel geometry (DESIGN.md): the edge runs from the tip back along -dir; the
  // sharp side faces `up`, which must point along the motion for the blade to cut.
  instruments::Pose pose;
  pose.dir = -normal.normalized();
  Eigen::Vector3d up = motion - motion.dot(pose.dir) * pose.dir;
  if (up.norm() < 1e-9) return;
  pose.up = up.normalized();
  pose.tip = surface + depth * pose.dir;
  loop_->post([this, pose](physics::Params&, physics::State& st) {
    engine_->object(objectId_).mesh = std::move(st.mesh);
    cutting::StepResult r;
    try {
      r = engine_->step(instruments::Hand::Right, instruments::Tool::Scalpel, pose);
    } catch (const std::exception& e) {
      // The engine refused this sample; the stroke goes on with the next one.
      std::lock_guard lock(kindsMutex_);
      lastCutError_ = e.what();
    }
    // Look the object up again: a separation may have grown the engine's list.
    st.mesh = std::move(engine_->object(objectId_).mesh);
    afterCut(st, r);
  });
#else
  (void)surface, (void)normal, (void)motion, (void)depth;
#endif
}

void PhysicsSession::endCut() {
#ifdef LD_GUI_HAVE_CUTTING
  loop_->post([this](physics::Params&, physics::State& st) {
    engine_->object(objectId_).mesh = std::move(st.mesh);
    const cutting::StepResult r = engine_->endStroke(instruments::Hand::Right);
    st.mesh = std::move(engine_->object(objectId_).mesh);
    afterCut(st, r);
  });
#endif
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
  if (trianglesCut_ > 0) line += QStringLiteral(", %1 triangles cut").arg(trianglesCut_.load());
  {
    std::lock_guard lock(kindsMutex_);
    if (!lastCutError_.empty()) line += QStringLiteral(", cut refused: %1").arg(QString::fromStdString(lastCutError_));
  }
  return line;
}

}  // namespace ld::gui
