#include "app/gui/physics_session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "sim/physics/tissue_properties.h"
#ifdef LD_GUI_HAVE_CUTTING
#include "sim/cutting/cutter.h"
#include "sim/instruments/instrument.h"
#else
namespace ld::cutting {
class CutEngine {};  // never created: the cutting module is not built
struct StepResult {};
}  // namespace ld::cutting
#endif

namespace ld::gui {
namespace {

using Clock = std::chrono::steady_clock;

Vec3f toF(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

}  // namespace

physics::Params PhysicsSession::defaultParams() {
  physics::Params params;
  // The default slab has ~1.5 mm edges; at the 1 ms step the thesis's masses (5 mm
  // thick water) would make the symplectic step unstable (omega * dt > 2), so the
  // GUI's tissue is five times denser: omega * dt stays about 1.
  params.tissue.density = 2.5e-5;
  // The pre-stretched mesh springs (rest = 0.7 x length) pull a cut open; the home
  // springs hold the tissue in place. How far the lips part grows with the ratio of
  // mesh to home stiffness (K / homeK): a 60 mm cut-through of the default slab opens
  // by 1.7 mm at 3 mN/mm, 3.4 at 1, 4.9 at 0.5, while tissue 15 mm from the cut moves
  // 0.01, 0.09 and 0.3 mm (measured). Weaker than 1 the settled slab's rim rounds off
  // so far that the cutter leaves rim-to-rim strokes attached (2-5 of 10 test strokes
  // at 0.5-0.7 mN/mm, none at 1), so 1 it is: the wound gapes by several millimetres
  // and pieces still come free. The mass floor below keeps the 1 ms step stable.
  params.tissue.homeK = 1.0;
  // Short edges made by cutting are stiff and light (k = K / rest): a mass floor keeps
  // the 1 ms step stable there instead of the monitor's substeps.
  params.tissue.massFloorDt = 1e-3;
  return params;
}

PhysicsSession::PhysicsSession(mesh::SurfaceMesh mesh, Options options) : params_(defaultParams()), options_(options) {
  if (!physics::hasTissueProperties(mesh)) physics::attachTissueProperties(mesh, params_.tissue);
#ifdef LD_GUI_HAVE_CUTTING
  cutting::CutParams cp;
  cp.tissue = params_.tissue;
  // No collision margin (unlike `cut --physics on`, one step per sample): here a mouse
  // sample follows ~16 steps, and the lazy full refit before it is cheaper than a margin
  // refit after each step. Tried (2026-12-05, slab, hold off, 16 steps between 51 samples
  // of a cut beside an opening wound): margin 0.25 with summed travel 15.3 ms of collision
  // work (818 margin refits), margin 0 2.2 ms (52 full refits).
  engine_ = std::make_unique<cutting::CutEngine>(cp);
  const int id = engine_->addObject(std::move(mesh));
  bodies_.push_back(Body{id, {}, 0});
#else
  plain_ = std::make_unique<mesh::SurfaceMesh>(std::move(mesh));
  bodies_.push_back(Body{0, {}, 0});
#endif
  publish();
  thread_ = std::thread([this] { run(); });
}

PhysicsSession::~PhysicsSession() {
  {
    std::lock_guard lock(queueMutex_);  // a resting loop checks stop_ under it
    stop_ = true;
  }
  queuePosted_.notify_all();
  if (thread_.joinable()) thread_.join();
}

mesh::SurfaceMesh& PhysicsSession::meshOf(int id) {
#ifdef LD_GUI_HAVE_CUTTING
  // Positions change only in stepAll/settle, which tell the engine what moved.
  return engine_->meshToMove(id);
#else
  (void)id;
  return *plain_;
#endif
}

// The engine's collision tree refits around what the body's last step moved.
void PhysicsSession::movedBy(const Body& b) {
#ifdef LD_GUI_HAVE_CUTTING
  if (const auto moved = physics::movedVertices(b.dynamics))
    engine_->verticesMoved(b.id, *moved);
  else
    engine_->verticesMoved(b.id);
#else
  (void)b;
#endif
}

void PhysicsSession::post(Command c) {
  std::lock_guard lock(queueMutex_);
  queue_.push_back(std::move(c));
  ++posted_;
  queuePosted_.notify_one();
}

bool PhysicsSession::drain() {
  std::vector<Command> todo;
  {
    std::lock_guard lock(queueMutex_);
    todo.swap(queue_);
  }
  for (auto& c : todo) c();
  if (!todo.empty()) {
    std::lock_guard lock(queueMutex_);
    done_ += todo.size();
  }
  queueDone_.notify_all();
  return !todo.empty();
}

bool PhysicsSession::stillStep() const {
  if (strokeOpen_ && holdWhileCutting_) return true;  // held: stepAll did nothing
  return std::all_of(bodies_.begin(), bodies_.end(),
                     [](const Body& b) { return b.dynamics.maxMove <= kRestMove; });  // +inf when unknown
}

void PhysicsSession::sync() {
  post([this] { publish(); });  // the next update() then shows every command's effect
  std::unique_lock lock(queueMutex_);
  const std::uint64_t target = posted_;
  queueDone_.wait(lock, [&] { return done_ >= target || stop_.load(); });
}

void PhysicsSession::run() {
  physics::FlushDenormals ftz;
  const double dt = 1.0 / options_.rateHz;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(dt));
  const auto publishPeriod =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.publishHz));
  auto lastPublish = Clock::now();

  // Settle the tissue as loaded (the thesis's start positions), showing progress.
  physics::SettleOptions so;
  so.dt = dt;
  so.tolerance = options_.settleTolerance;
  so.maxTime = options_.settleMaxTime;
  so.progress = [&](double p, double) {
    settleProgress_ = p;
    if (Clock::now() - lastPublish >= publishPeriod) {
      publish();
      lastPublish = Clock::now();
    }
  };
  so.cancel = [this] { return stop_.load(); };
  physics::settle(params_, bodies_[0].dynamics, meshOf(bodies_[0].id), so);
#ifdef LD_GUI_HAVE_CUTTING
  engine_->verticesMoved(bodies_[0].id);
  engine_->settleAdded();  // marks the settled tissue's vertices: later calls settle what cuts add
#endif
  settleProgress_ = 1.0;
  publish();
  settled_ = true;

  auto deadline = Clock::now() + period;
  const auto window = static_cast<std::uint64_t>(std::max(1.0, options_.rateHz));  // one second of steps
  std::uint64_t stillSteps = 0;
  while (!stop_.load()) {
    if (drain()) stillSteps = 0;
    if (stillSteps >= window) {
      // At rest: no step would move anything, so none runs (an idle workstation keeps
      // no core busy) until a command comes; the clock runs on in whole steps.
      if (!resting_.load()) {
        restSince_ = bodies_[0].dynamics.time;  // first: a status() that sees resting_ reads it
        resting_ = true;
      }
      {
        std::unique_lock lock(queueMutex_);
        queuePosted_.wait_for(lock, std::chrono::milliseconds(20), [&] { return !queue_.empty() || stop_.load(); });
      }
      for (const auto now = Clock::now(); deadline <= now; deadline += period)
        for (auto& b : bodies_) b.dynamics.time += dt;
      if (Clock::now() - lastPublish >= publishPeriod) {
        publish(Publish::IfMoved);
        lastPublish = Clock::now();
      }
      continue;
    }
    resting_ = false;
    const auto t0 = Clock::now();
    stepAll(dt);
    stillSteps = stillStep() ? stillSteps + 1 : 0;
    noteStep(std::chrono::duration<double, std::micro>(Clock::now() - t0).count(), window);
    if (Clock::now() - lastPublish >= publishPeriod) {
      publish(Publish::IfMoved);
      lastPublish = Clock::now();
    }
    const auto now = Clock::now();
    if (now > deadline) {
      ++late_;
      if (now - deadline > 10 * period) deadline = now;  // drop the backlog, do not spiral
    } else {
      std::this_thread::sleep_until(deadline);
    }
    deadline += period;
  }
  drain();  // let sync() return
}

void PhysicsSession::stepAll(double dt) {
  if (strokeOpen_ && holdWhileCutting_) return;  // the blade is in the tissue: hold it still
  std::uint64_t warnings = 0, implicit = 0, resets = 0;
  for (auto& b : bodies_) {
    physics::step(params_, b.dynamics, meshOf(b.id), dt);
    movedBy(b);
    warnings += b.dynamics.stability.warnings;
    implicit += b.dynamics.stability.implicitFallbacks;
    resets += b.dynamics.stability.velocityResets;
  }
  warnings_ = warnings;
  implicit_ = implicit;
  resets_ = resets;
}

void PhysicsSession::noteStep(double us, std::uint64_t window) {
  meanUs_ = steps_.load() == 0 ? us : 0.99 * meanUs_ + 0.01 * us;
  meanStepUs_ = meanUs_;
  windowMaxUs_ = std::max(windowMaxUs_, us);
  // The largest step of the last full second of steps, or of this one when larger.
  maxStepUs_ = std::max(lastWindowMaxUs_, windowMaxUs_);
  if (++steps_ % window == 0) {
    lastWindowMaxUs_ = windowMaxUs_;
    windowMaxUs_ = 0.0;
  }
}

void PhysicsSession::advance(double seconds) {
  post([this, seconds] {
    const double dt = 1.0 / options_.rateHz;
    const auto n = static_cast<long>(std::lround(seconds / dt));
    const auto window = static_cast<std::uint64_t>(std::max(1.0, options_.rateHz));
    for (long i = 0; i < n && !stop_.load(); ++i) {
      const auto t0 = Clock::now();
      stepAll(dt);
      noteStep(std::chrono::duration<double, std::micro>(Clock::now() - t0).count(), window);
    }
  });
}

PhysicsSession::Stats PhysicsSession::stats() const {
  Stats s;
  s.steps = steps_.load();
  s.late = late_.load();
  s.meanStepUs = meanStepUs_.load();
  s.maxStepUs = maxStepUs_.load();
  s.warnings = warnings_.load();
  s.implicit = implicit_.load();
  s.resets = resets_.load();
  s.nanFrames = nanFrames_.load();
  s.resting = resting_.load();
  s.settledAdded = static_cast<std::uint64_t>(settledAdded_.load());
  return s;
}

namespace {

// A frame whose every vertex lies within this distance [mm] of the last one shown draws
// the same pixels (a pixel is ~0.1 mm on the default slab): it is not published, so a
// tissue at rest costs the GUI no repaint at all.
constexpr float kStillDistance = 1e-4F;

// Same objects, same triangles, every vertex still (squared distance within the bound).
bool looksTheSame(const SceneFrame& shown, const SceneFrame& next) {
  if (shown.objects.size() != next.objects.size() || shown.preview != next.preview) return false;
  constexpr float still2 = kStillDistance * kStillDistance;
  for (std::size_t i = 0; i < next.objects.size(); ++i) {
    const SceneObject& a = shown.objects[i];
    const SceneObject& b = next.objects[i];
    if (a.id != b.id || a.topology != b.topology || a.mesh.positions.size() != b.mesh.positions.size()) return false;
    for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
      const Vec3f& p = a.mesh.positions[v];
      const Vec3f& q = b.mesh.positions[v];
      const float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
      if (!(dx * dx + dy * dy + dz * dz <= still2)) return false;  // NaN counts as moved
    }
  }
  return true;
}

}  // namespace

void PhysicsSession::publish(Publish when) {
  SceneFrame next;
  bool finite = true;
  {
    std::lock_guard lock(frameMutex_);
    next.objects.reserve(bodies_.size());
    for (const auto& b : bodies_) {
      const mesh::SurfaceMesh& m = meshOf(b.id);
      SceneObject o;
      o.id = b.id;
#ifdef LD_GUI_HAVE_CUTTING
      for (const auto& eo : engine_->objects())  // const: object() would mean "all moved"
        if (eo.id == b.id) o.parent = eo.parent;
#endif
      o.topology = m.topologyVersion();
      o.mesh.positions.resize(m.verticesSize());
      for (auto v : m.vertices()) {
        const Eigen::Vector3d& p = m.position(v);
        finite = finite && p.allFinite();
        o.mesh.positions[v.idx()] = toF(p);
      }
      // Triangles again only when they changed since the last frame.
      const auto old = std::find_if(frame_.objects.begin(), frame_.objects.end(),
                                    [&](const SceneObject& x) { return x.id == b.id; });
      if (old != frame_.objects.end() && old->topology == o.topology) {
        o.mesh.triangles = old->mesh.triangles;
        o.mesh.faceKind = old->mesh.faceKind;
      } else {
        o.mesh.triangles.reserve(m.nFaces());
        o.mesh.faceKind.reserve(m.nFaces());
#ifdef LD_GUI_HAVE_CUTTING
        const auto kind = m.getFaceProperty<int>(cutting::kFaceKindProp);
#endif
        for (auto f : m.faces()) {
          const auto& vs = m.vertices(f);
          o.mesh.triangles.push_back({static_cast<std::uint32_t>(vs[0].idx()), static_cast<std::uint32_t>(vs[1].idx()),
                                      static_cast<std::uint32_t>(vs[2].idx())});
#ifdef LD_GUI_HAVE_CUTTING
          o.mesh.faceKind.push_back(kind && kind[f] != cutting::kSurface ? 1 : 0);
#else
          o.mesh.faceKind.push_back(0);
#endif
        }
      }
      next.objects.push_back(std::move(o));
    }
  }
  if (!finite) ++nanFrames_;
  next.preview = preview_;
  next.simTime = bodies_[0].dynamics.time;
  std::lock_guard lock(frameMutex_);
  if (when == Publish::IfMoved && looksTheSame(frame_, next)) {
    frame_.simTime = next.simTime;  // the clock still runs; the picture stays
    return;
  }
  next.serial = ++serial_;
  frame_ = std::move(next);
}

bool PhysicsSession::update(SceneFrame& out, bool& topologyChanged) {
  std::lock_guard lock(frameMutex_);
  topologyChanged = false;
  if (frame_.serial == taken_) return false;
  taken_ = frame_.serial;
  std::vector<std::pair<int, std::uint64_t>> topo;
  topo.reserve(frame_.objects.size());
  for (const auto& o : frame_.objects) topo.emplace_back(o.id, o.topology);
  topologyChanged = topo != takenTopology_;  // ids and versions: pieces added change it too
  takenTopology_ = std::move(topo);
  out = frame_;
  return true;
}

bool PhysicsSession::update(RenderMesh& out, bool& topologyChanged) {
  SceneFrame f;
  if (!update(f, topologyChanged) || f.objects.empty()) return false;
  out = std::move(f.objects.front().mesh);
  return true;
}

void PhysicsSession::setForce(int object, std::uint32_t v, const Eigen::Vector3d& f) {
  mesh::SurfaceMesh& m = meshOf(object);
  if (v >= m.verticesSize() || m.isDeleted(mesh::Vertex(v))) return;
  auto force = m.vertexProperty<Eigen::Vector3d>(physics::kForceProp, Eigen::Vector3d::Zero());
  force[mesh::Vertex(v)] = f;
  forced_.emplace_back(object, v);
}

void PhysicsSession::clearForces() {
  for (const auto& [object, v] : forced_) {
    mesh::SurfaceMesh& m = meshOf(object);
    if (v >= m.verticesSize()) continue;
    auto force = m.vertexProperty<Eigen::Vector3d>(physics::kForceProp, Eigen::Vector3d::Zero());
    force[mesh::Vertex(v)] = Eigen::Vector3d::Zero();
  }
  forced_.clear();
}

void PhysicsSession::applyPatchForce(int object, std::uint32_t vertex, const Eigen::Vector3d& f) {
  // The pull acts on a small disc around the picked vertex, like an instrument's tip,
  // not on one vertex: weights (1 - d/r)^2 within r, normalised to the total.
  const mesh::SurfaceMesh& m = meshOf(object);
  if (vertex >= m.verticesSize() || m.isDeleted(mesh::Vertex(vertex))) return;
  const Eigen::Vector3d at = m.position(mesh::Vertex(vertex));
  if (patchKey_ != std::pair{object, vertex} || patchTopology_ != m.topologyVersion()) {
    patchKey_ = std::pair{object, vertex};
    patchTopology_ = m.topologyVersion();
    patch_.clear();
    for (auto v : m.vertices())
      if ((m.position(v) - at).norm() < kPushRadius) patch_.push_back(static_cast<std::uint32_t>(v.idx()));
  }
  std::vector<std::pair<std::uint32_t, double>> weights;
  double total = 0;
  for (auto v : patch_) {
    const double w = std::pow(1.0 - std::min((m.position(mesh::Vertex(v)) - at).norm() / kPushRadius, 1.0), 2);
    weights.emplace_back(v, w);
    total += w;
  }
  clearForces();
  if (!(total > 0)) {
    weights.assign(1, {vertex, 1.0});
    total = 1.0;
  }
  for (const auto& [v, w] : weights) setForce(object, v, (w / total) * f);
  for (auto& b : bodies_)
    if (b.id == object) b.dynamics.energyBudget = std::numeric_limits<double>::quiet_NaN();
}

void PhysicsSession::pushToward(int object, std::uint32_t vertex, const Eigen::Vector3d& target) {
  post([this, object, vertex, target] {
    const mesh::SurfaceMesh& m = meshOf(object);
    if (vertex >= m.verticesSize()) return;
    Eigen::Vector3d f = kPushStiffness * (target - m.position(mesh::Vertex(vertex)));
    if (f.norm() > kMaxPushForce) f *= kMaxPushForce / f.norm();
    pushForce_ = f.norm();
    applyPatchForce(object, vertex, f);
  });
}

void PhysicsSession::release() {
  post([this] {
    pushForce_ = 0.0;
    clearForces();
  });
}

void PhysicsSession::forceAt(const Eigen::Vector3d& point, const Eigen::Vector3d& force) {
  post([this, point, force] {
    const mesh::SurfaceMesh& m = meshOf(bodies_[0].id);
    std::optional<std::uint32_t> nearest;
    double best = std::numeric_limits<double>::infinity();
    for (auto f : m.faces())
      for (auto v : m.vertices(f))
        if (const double d = (m.position(v) - point).squaredNorm(); d < best) {
          best = d;
          nearest = static_cast<std::uint32_t>(v.idx());
        }
    if (nearest) applyPatchForce(bodies_[0].id, *nearest, force);
  });
}

void PhysicsSession::moveHomes(Body& b, const Eigen::Vector3d& delta) {
  mesh::SurfaceMesh& m = meshOf(b.id);
  auto home = m.vertexProperty<Eigen::Vector3d>(physics::kHomeProp, Eigen::Vector3d::Zero());
  for (auto v : m.vertices()) home[v] += delta;
  b.dynamics.invalidate();  // the home energy jumps: a new budget, not a divergence
}

void PhysicsSession::movePiece(int object, const Eigen::Vector3d& delta) {
  post([this, object, delta] {
    for (std::size_t i = 1; i < bodies_.size(); ++i)  // bodies_[0], the tissue, is held
      if (bodies_[i].id == object) moveHomes(bodies_[i], delta);
  });
}

void PhysicsSession::moveAllPieces(const Eigen::Vector3d& delta) {
  post([this, delta] {
    for (std::size_t i = 1; i < bodies_.size(); ++i) moveHomes(bodies_[i], delta);
  });
}

void PhysicsSession::moveLastFreedPieces(const Eigen::Vector3d& delta) {
  post([this, delta] {
    int last = -1;
    for (std::size_t i = 1; i < bodies_.size(); ++i) last = std::max(last, bodies_[i].stroke);
    for (std::size_t i = 1; i < bodies_.size(); ++i)
      if (bodies_[i].stroke == last) moveHomes(bodies_[i], delta);
  });
}

bool PhysicsSession::cuttingAvailable() {
#ifdef LD_GUI_HAVE_CUTTING
  return true;
#else
  return false;
#endif
}

void PhysicsSession::addBodies() {
#ifdef LD_GUI_HAVE_CUTTING
  for (const auto& o : engine_->objects()) {
    if (std::any_of(bodies_.begin(), bodies_.end(), [&](const Body& b) { return b.id == o.id; })) continue;
    mesh::SurfaceMesh& m = meshOf(o.id);
    if (!physics::hasTissueProperties(m)) physics::attachTissueProperties(m, params_.tissue);
    bodies_.push_back(Body{o.id, {}, strokes_});
  }
  objectCount_ = static_cast<int>(bodies_.size());
#endif
}

void PhysicsSession::afterCut(const cutting::StepResult& r) {
#ifdef LD_GUI_HAVE_CUTTING
  trianglesCut_ += r.trianglesCut;
  preview_.clear();
  for (const auto& p : r.preview) preview_.push_back({toF(p.from), toF(p.to), toF(p.depth)});
  // Masses and springs changed around the cut (the cache follows the topology
  // version; the energy budget starts again).
  if (r.topologyChanged)
    for (auto& b : bodies_) b.dynamics.energyBudget = std::numeric_limits<double>::quiet_NaN();
  addBodies();
#else
  (void)r;
#endif
}

void PhysicsSession::cutSample(const Eigen::Vector3d& surface, const Eigen::Vector3d& normal,
                               const Eigen::Vector3d& motion, double depth) {
#ifdef LD_GUI_HAVE_CUTTING
  // Scalpel geometry (DESIGN.md): the edge runs from the tip back along -dir; the
  // sharp side faces `up`, which must point along the motion for the blade to cut.
  instruments::Pose pose;
  pose.dir = -normal.normalized();
  const Eigen::Vector3d up = motion - motion.dot(pose.dir) * pose.dir;
  if (up.norm() < 1e-9) return;
  pose.up = up.normalized();
  pose.tip = surface + depth * pose.dir;
  post([this, pose] {
    cutting::StepResult r;
    strokeOpen_ = true;
    try {
      r = engine_->step(instruments::Hand::Right, instruments::Tool::Scalpel, pose);
      // Moving under the blade: what the sample added settles where its springs balance,
      // except the tips on the blade, as `task run --physics on` and `cut --physics on` do.
      if (!holdWhileCutting_) settledAdded_ += static_cast<long>(engine_->settleAdded(r.preview));
    } catch (const std::exception& e) {
      // The engine refused this sample; the stroke goes on with the next one.
      std::lock_guard lock(errorMutex_);
      lastCutError_ = e.what();
    }
    afterCut(r);
  });
#else
  (void)surface, (void)normal, (void)motion, (void)depth;
#endif
}

void PhysicsSession::endCut() {
#ifdef LD_GUI_HAVE_CUTTING
  post([this] {
    cutting::StepResult r;
    try {
      r = engine_->endStroke(instruments::Hand::Right);
      if (!holdWhileCutting_) {
        settledAdded_ += static_cast<long>(engine_->settleAdded());  // the tips too, off the blade now
      } else {
        // Held still, the stroke's additions open with the tissue's own motion once it
        // moves again (as on the runner's still tissue): marked settled, not moved, so
        // that a later stroke with the hold off does not settle them all at once.
        physics::TissueParams mark = params_.tissue;
        mark.settleSweeps = 0;
        for (const auto& o : engine_->objects()) {  // freed pieces too (not bodies yet)
          mesh::SurfaceMesh& m = meshOf(o.id);
          if (physics::hasTissueProperties(m)) physics::settleVertices(m, physics::unsettledVertices(m), mark);
        }
      }
    } catch (const std::exception& e) {
      std::lock_guard lock(errorMutex_);
      lastCutError_ = e.what();
    }
    afterCut(r);
    preview_.clear();
    ++strokes_;
    strokeOpen_ = false;
  });
#endif
}

void PhysicsSession::setHoldWhileCutting(bool on) {
  post([this, on] { holdWhileCutting_ = on; });
}

double PhysicsSession::simTime() const {
  std::lock_guard lock(frameMutex_);
  return frame_.simTime;
}

QString PhysicsSession::status() const {
  if (!settled_.load())
    return QStringLiteral("Physics: settling %1%").arg(static_cast<int>(100.0 * settleProgress_.load()));
  const Stats st = stats();
  // At rest the line does not change (no repaint of an idle window): the time it came
  // to rest instead of the running clock.
  QString line = QStringLiteral("Physics: %1 s, step %2 µs (max %3), late %4 of %5, NaN %6")
                     .arg(st.resting ? QStringLiteral("at rest since t = %1").arg(restSince_.load(), 0, 'f', 1)
                                     : QStringLiteral("t = %1").arg(simTime(), 0, 'f', 1))
                     .arg(st.meanStepUs, 0, 'f', 0)
                     .arg(st.maxStepUs, 0, 'f', 0)
                     .arg(st.late)
                     .arg(st.steps)
                     .arg(st.nanFrames);
  if (st.warnings)
    line += QStringLiteral(", %1 stability warnings (%2 implicit fallbacks, %3 velocity resets)")
                .arg(st.warnings)
                .arg(st.implicit)
                .arg(st.resets);
  if (const int n = objectCount_.load(); n > 1) line += QStringLiteral(", %1 pieces freed").arg(n - 1);
  if (pushForce_.load() > 0) line += QStringLiteral(", push %1 mN").arg(pushForce_.load(), 0, 'f', 0);
  if (trianglesCut_ > 0) line += QStringLiteral(", %1 triangles cut").arg(trianglesCut_.load());
  std::lock_guard lock(errorMutex_);
  if (!lastCutError_.empty()) line += QStringLiteral(", cut refused: %1").arg(QString::fromStdString(lastCutError_));
  return line;
}

}  // namespace ld::gui
