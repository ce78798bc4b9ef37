#include "curriculum/task_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <unordered_set>
#include <utility>

#include "curriculum/curriculum_error.h"
#include "curriculum/tissue_path.h"
#include "sim/collision/segment_triangle.h"
#include "sim/instruments/instrument.h"
#include "sim/physics/mass_spring.h"

namespace ld::curriculum {
namespace {

using instruments::Hand;
using instruments::Pose;
using instruments::Tool;

Pose interpolate(const Pose& a, const Pose& b, double u) {
  Pose p;
  p.tip = a.tip + u * (b.tip - a.tip);
  p.dir = (a.dir + u * (b.dir - a.dir)).normalized();
  Eigen::Vector3d up = a.up + u * (b.up - a.up);
  up -= up.dot(p.dir) * p.dir;  // keep it perpendicular to dir
  p.up = up.norm() > 1e-12 ? Eigen::Vector3d(up.normalized()) : a.up;
  p.jaw = a.jaw + u * (b.jaw - a.jaw);
  p.pedal = a.pedal;
  return p;
}

// The working point of a cutting tool: the hook's elbow, the scalpel's tip (the start
// of its first cutting edge).
Eigen::Vector3d workingPoint(Tool tool, const Pose& pose, const instruments::Settings& settings) {
  for (const auto& s : instruments::segments(tool, pose, settings))
    if (s.role == instruments::SegmentRole::CuttingEdge) return s.a;
  return pose.tip;
}

// Of the cutting edges' contacts, the one nearest the working point, so that a hook
// lying flat on the tissue or dipping its tip does not make the contact point jump
// along the edge.
std::optional<Eigen::Vector3d> cuttingContact(const std::vector<cutting::Contact>& contacts,
                                              const Eigen::Vector3d& ref) {
  std::optional<Eigen::Vector3d> best;
  double bestD = 0.0;
  for (const auto& c : contacts) {
    if (c.role != instruments::SegmentRole::CuttingEdge) continue;
    const double d = (c.point - ref).squaredNorm();
    if (!best || d < bestD) {
      best = c.point;
      bestD = d;
    }
  }
  return best;
}

// Where the cutting edges touch any tissue object at `pose` (nearest the working
// point; no change to the meshes): used only to time the start and end of a
// contact between two samples.
std::optional<Eigen::Vector3d> touchAt(const cutting::CutEngine& engine, Tool tool, const Pose& pose) {
  const Eigen::Vector3d ref = workingPoint(tool, pose, engine.params().tool);
  std::optional<Eigen::Vector3d> best;
  for (const auto& s : instruments::segments(tool, pose, engine.params().tool)) {
    if (s.role != instruments::SegmentRole::CuttingEdge) continue;
    for (const auto& o : engine.objects())
      for (const auto& h : collision::intersectSegment(o.mesh, s.a, s.b))
        if (!best || (h.point - ref).squaredNorm() < (*best - ref).squaredNorm()) best = h.point;
  }
  return best;
}

// The tissue at rest (the model as loaded, balanced: where the path was drawn and
// the trajectories were authored), for a tissue that moves under the blade: the cut
// path is where the blade cut the tissue, i.e. the cut point carried back to the
// tissue at rest, as a surgeon judges a cut against the line drawn on the tissue
// whatever the tissue did meanwhile. A point of a face descends from its original
// triangle (kOriginFaceProp); the cutter interpolates the homes of the vertices it
// adds in the triangle they split, so the point's home (the same weights of its
// face's homes) lies in the original triangle's home triangle, and the weights there
// give the point on the original triangle at rest.
class RestFrame {
 public:
  explicit RestFrame(const mesh::SurfaceMesh& start) : rest_(start) {}

  // Where p, on face f of a descendant of the start mesh, is at rest; none for a face
  // without an original triangle (the cut's walls).
  [[nodiscard]] std::optional<Eigen::Vector3d> at(const mesh::SurfaceMesh& m, mesh::Face f,
                                                  const Eigen::Vector3d& p) const {
    const mesh::Face o = original(m, f);
    if (!o.isValid()) return std::nullopt;
    const auto home = m.getVertexProperty<Eigen::Vector3d>(physics::kHomeProp);
    const auto home0 = rest_.getVertexProperty<Eigen::Vector3d>(physics::kHomeProp);
    if (!home || !home0) return std::nullopt;
    const auto& v = m.vertices(f);
    const Eigen::Vector3d b = closestBarycentric(p, m.position(v[0]), m.position(v[1]), m.position(v[2]));
    const Eigen::Vector3d h = b[0] * home[v[0]] + b[1] * home[v[1]] + b[2] * home[v[2]];
    const auto& w = rest_.vertices(o);
    const Eigen::Vector3d c = closestBarycentric(h, home0[w[0]], home0[w[1]], home0[w[2]]);
    return Eigen::Vector3d(c[0] * rest_.position(w[0]) + c[1] * rest_.position(w[1]) + c[2] * rest_.position(w[2]));
  }
  // The normal at rest of f's original triangle (zero without one).
  [[nodiscard]] Eigen::Vector3d normal(const mesh::SurfaceMesh& m, mesh::Face f) const {
    const mesh::Face o = original(m, f);
    return o.isValid() ? Eigen::Vector3d(rest_.faceNormal(o)) : Eigen::Vector3d::Zero();
  }

 private:
  [[nodiscard]] mesh::Face original(const mesh::SurfaceMesh& m, mesh::Face f) const {
    const auto tag = m.getFaceProperty<std::int64_t>(kOriginFaceProp);
    if (!tag || !m.isValid(f) || tag[f] < 0) return {};
    const mesh::Face o(static_cast<std::size_t>(tag[f]));
    return rest_.isValid(o) ? o : mesh::Face();
  }

  mesh::SurfaceMesh rest_;
};

struct HandState {
  bool have = false;
  devices::PoseSample last;
  bool contact = false;
  // grasper
  bool grasping = false;
  Eigen::Vector3d grasp = Eigen::Vector3d::Zero();
};

// The grasper's jaw point (the closed jaws' virtual tip) of one hand over time,
// linear between its samples, so physics sub-steps see the jaw move smoothly.
class JawTrack {
 public:
  void add(double t, const Eigen::Vector3d& p) { s_.emplace_back(t, p); }
  [[nodiscard]] Eigen::Vector3d at(double t) const {
    if (s_.empty()) return Eigen::Vector3d::Zero();
    auto it = std::upper_bound(s_.begin(), s_.end(), t, [](double x, const auto& e) { return x < e.first; });
    if (it == s_.begin()) return s_.front().second;
    if (it == s_.end()) return s_.back().second;
    const auto& a = *(it - 1);
    const auto& b = *it;
    const double u = b.first > a.first ? (t - a.first) / (b.first - a.first) : 1.0;
    return a.second + u * (b.second - a.second);
  }

 private:
  std::vector<std::pair<double, Eigen::Vector3d>> s_;
};

// The tissue objects under physics, and what the graspers hold: each held vertex is
// tied to the jaw point (plus its offset when taken) by a stiff penalty spring
// applied as the vertex's external force. The spring's stiffness is bounded by the
// vertex's mass (kp dt² <= m) and the held vertices are made heavier by kp dt² while
// held (selective mass scaling, as the physics' mass floor does for stiff springs),
// so the explicit penalty force stays stable at the 1 ms step.
//
// Held still (RunOptions::holdUnderBlade): the mesh's positions stay the still tissue
// the blade and the drawn path see; a vertex property holds the simulated tissue's
// displacement from it. A physics step swaps the simulated positions in and out (the
// displacement property holds the still positions meanwhile), so the physics sees
// the same cuts, springs and held vertices. A vertex a cut adds takes the mean
// displacement of its neighbours.
class TissueMotion {
 public:
  static constexpr const char* kDisplacementProp = "ld:sim_displacement";
  static constexpr const char* kKnownProp = "ld:sim_displacement_set";

  TissueMotion(cutting::CutEngine& engine, const physics::TissueParams& tp, const RunOptions& opt)
      : engine_(engine), tp_(tp), opt_(opt), still_(opt.physics && opt.holdUnderBlade) {
    params_.tissue = tp;
    settleNew();  // (marks the model's vertices settled)
    if (still_)
      for (auto& o : engine_.objects()) {
        mesh::SurfaceMesh& m = engine_.object(o.id).mesh;
        m.vertexProperty<Eigen::Vector3d>(kDisplacementProp, Eigen::Vector3d::Zero());
        auto known = m.vertexProperty<std::uint8_t>(kKnownProp, 0);
        for (mesh::Vertex v : m.vertices()) known[v] = 1;
      }
  }

  // Held still: vertices added since (by cuts) take their neighbours' mean displacement.
  void followEdits() {
    if (!still_) return;
    for (const auto& o : engine_.objects()) {
      mesh::SurfaceMesh& m = engine_.object(o.id).mesh;
      auto u = m.vertexProperty<Eigen::Vector3d>(kDisplacementProp, Eigen::Vector3d::Zero());
      auto known = m.vertexProperty<std::uint8_t>(kKnownProp, 0);
      std::vector<mesh::Vertex> fresh;
      for (mesh::Vertex v : m.vertices())
        if (!known[v]) fresh.push_back(v);
      for (int round = 0; round < 4 && !fresh.empty(); ++round) {
        std::vector<mesh::Vertex> left;
        for (mesh::Vertex v : fresh) {
          Eigen::Vector3d sum = Eigen::Vector3d::Zero();
          int n = 0;
          for (mesh::Face f : m.faces(v))
            for (mesh::Vertex w : m.vertices(f))
              if (w != v && known[w]) {
                sum += u[w];
                ++n;
              }
          if (n > 0) {
            u[v] = sum / n;
            known[v] = 1;
          } else {
            left.push_back(v);
          }
        }
        fresh = std::move(left);
      }
      for (mesh::Vertex v : fresh) known[v] = 1;  // isolated: not displaced
    }
  }

  // Moving tissue, after every sample: what the cuts added settles where its springs
  // balance, except the tips on the blade (they settle once it has moved on or left).
  void settleNew(std::span<const cutting::PreviewSegment> preview = {}) {
    if (opt_.physics && !still_) engine_.settleAdded(preview);
  }

  // The farthest the simulated tissue was from the still one after any step [mm].
  [[nodiscard]] double maxDisplacement() const { return std::sqrt(maxU2_); }

  // Steps every object from `from` to `to` in steps of at most physicsDt.
  void advance(double from, double to, const JawTrack* jaws, PhysicsStats& st) {
    if (!(to > from)) return;
    const int n = std::max(1, static_cast<int>(std::ceil((to - from) / opt_.physicsDt - 1e-9)));
    const double h = (to - from) / n;
    const auto t0 = std::chrono::steady_clock::now();
    swap(true);
    for (int j = 0; j < n; ++j) {
      const double tj = from + (j + 1) * h;
      for (int hand = 0; hand < 2; ++hand)
        if (!held_[hand].empty()) applyForces(hand, jaws[hand].at(tj));
      const std::size_t count = engine_.objects().size();
      for (std::size_t i = 0; i < count; ++i) {
        const int id = engine_.objects()[i].id;
        physics::step(params_, dynamics(id), engine_.object(id).mesh, h);
        ++st.steps;
      }
    }
    swap(false);
    st.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  // Closed jaws at `jaw` take hold of the object under `loc`: the vertices within
  // graspRadius of the grasp point (at least the face's nearest vertex).
  std::size_t hold(int hand, int object, const SurfaceLocation& loc, const Eigen::Vector3d& jaw) {
    release(hand);
    mesh::SurfaceMesh& m = engine_.object(object).mesh;
    const Eigen::Vector3d p = position(m, loc);
    std::unordered_set<mesh::Face> seen{loc.face};
    std::vector<mesh::Face> frontier{loc.face};
    std::unordered_set<mesh::Vertex> picked;
    const int rings = 1 + static_cast<int>(std::ceil(opt_.graspRadius));
    for (int r = 0; r <= rings && !frontier.empty(); ++r) {
      std::vector<mesh::Face> next;
      for (mesh::Face f : frontier)
        for (mesh::Vertex v : m.vertices(f)) {
          if ((m.position(v) - p).norm() <= opt_.graspRadius) picked.insert(v);
          for (mesh::Face g : m.faces(v))
            if (seen.insert(g).second) next.push_back(g);
        }
      frontier = std::move(next);
    }
    if (picked.empty()) {
      const auto& fv = m.vertices(loc.face);
      int k = 0;
      for (int i = 1; i < 3; ++i)
        if (loc.bary[i] > loc.bary[k]) k = i;
      picked.insert(fv[static_cast<std::size_t>(k)]);
    }
    auto mass = m.getVertexProperty<double>(physics::kMassProp);
    for (mesh::Vertex v : picked) {
      held_[hand].push_back({object, v, simulated(m, v) - jaw, m.position(v), m.layoutVersion()});
      mass[v] += opt_.graspStiffness * opt_.physicsDt * opt_.physicsDt;
    }
    dynamics(object).invalidate();
    return picked.size();
  }

  void release(int hand) {
    for (Held& h : held_[hand]) {
      if (!locate(h)) continue;
      mesh::SurfaceMesh& m = engine_.object(h.object).mesh;
      m.getVertexProperty<Eigen::Vector3d>(physics::kForceProp)[h.v].setZero();
      m.getVertexProperty<double>(physics::kMassProp)[h.v] = physics::lumpedMass(m, h.v, tp_);
      dynamics(h.object).invalidate();
    }
    held_[hand].clear();
  }

  // The force the jaws exert on the tissue [mN] with the jaw at `jaw`.
  Eigen::Vector3d force(int hand, const Eigen::Vector3d& jaw) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (Held& h : held_[hand])
      if (locate(h)) sum += spring(h, jaw);
    return sum;
  }

  void addStats(PhysicsStats& st) const {
    for (const auto& d : dyn_) {
      st.rejectedSteps += d.second->stability.warnings;
      st.implicitFallbacks += d.second->stability.implicitFallbacks;
    }
  }

 private:
  struct Held {
    int object;
    mesh::Vertex v;
    Eigen::Vector3d offset;  // from the jaw point when taken
    Eigen::Vector3d last;    // position when last seen (finds it again after a compaction)
    std::uint64_t layout;
  };

  physics::Dynamics& dynamics(int id) {
    for (auto& d : dyn_)
      if (d.first == id) return *d.second;
    dyn_.emplace_back(id, std::make_unique<physics::Dynamics>());
    return *dyn_.back().second;
  }

  // The held vertex in its object, found again by position after a separation
  // compacted the mesh (it may now be on the freed piece). False when it is gone.
  bool locate(Held& h) {
    const mesh::SurfaceMesh& m = engine_.object(h.object).mesh;
    if (m.layoutVersion() == h.layout) return m.isValid(h.v);
    double best = 1e-9;
    bool found = false;
    for (const auto& o : engine_.objects())
      for (mesh::Vertex v : o.mesh.vertices()) {
        const double d = (o.mesh.position(v) - h.last).norm();
        if (d <= best) {
          best = d;
          h.object = o.id;
          h.v = v;
          found = true;
        }
      }
    h.layout = engine_.object(h.object).mesh.layoutVersion();
    if (!found) h.v = mesh::Vertex();
    return found;
  }

  Eigen::Vector3d spring(const Held& h, const Eigen::Vector3d& jaw) {
    const mesh::SurfaceMesh& m = engine_.object(h.object).mesh;
    const double mass = m.getVertexProperty<double>(physics::kMassProp)[h.v];
    const double dt2 = opt_.physicsDt * opt_.physicsDt;
    const double kp = std::min(opt_.graspStiffness, mass / dt2);  // a cut may have reset the mass
    return kp * (jaw + h.offset - simulated(m, h.v));
  }

  // Where the physics has the vertex (outside a step: still + displacement).
  [[nodiscard]] Eigen::Vector3d simulated(const mesh::SurfaceMesh& m, mesh::Vertex v) const {
    if (!still_ || swapped_) return m.position(v);
    const auto u = m.getVertexProperty<Eigen::Vector3d>(kDisplacementProp);
    return u ? Eigen::Vector3d(m.position(v) + u[v]) : m.position(v);
  }

  // In: positions = simulated, the property = still positions. Out: the reverse.
  void swap(bool in) {
    if (!still_ || swapped_ == in) return;
    for (const auto& o : engine_.objects()) {
      mesh::SurfaceMesh& m = engine_.object(o.id).mesh;
      auto u = m.vertexProperty<Eigen::Vector3d>(kDisplacementProp, Eigen::Vector3d::Zero());
      for (mesh::Vertex v : m.vertices()) {
        const Eigen::Vector3d x = m.position(v);
        if (in) {
          m.position(v) = x + u[v];
          u[v] = x;
        } else {
          m.position(v) = u[v];
          u[v] = x - u[v];
          maxU2_ = std::max(maxU2_, u[v].squaredNorm());
        }
      }
    }
    swapped_ = in;
  }

  void applyForces(int hand, const Eigen::Vector3d& jaw) {
    for (Held& h : held_[hand]) {
      if (!locate(h)) continue;
      mesh::SurfaceMesh& m = engine_.object(h.object).mesh;
      m.getVertexProperty<Eigen::Vector3d>(physics::kForceProp)[h.v] = spring(h, jaw);
      // The position locate() compares with outside a step (the still one when held still).
      h.last = still_ ? m.getVertexProperty<Eigen::Vector3d>(kDisplacementProp)[h.v] : m.position(h.v);
    }
  }

  cutting::CutEngine& engine_;
  physics::TissueParams tp_;
  const RunOptions& opt_;
  bool still_ = false, swapped_ = false;
  double maxU2_ = 0.0;
  physics::Params params_;
  std::vector<std::pair<int, std::unique_ptr<physics::Dynamics>>> dyn_;
  std::vector<Held> held_[2];
};

}  // namespace

physics::TissueParams tissueParams(const TissueSettings& t, const RunOptions& opt) {
  physics::TissueParams p;
  p.K = t.stiffness;
  p.restRatio = t.restLengthRatio;
  p.homeK = t.homeStiffness;
  p.damping = t.damping;
  p.density = t.density * 1e-6 * opt.layerMm;  // g/cm³ = 1e-6 kg/mm³, times the layer
  p.massFloorDt = opt.physicsDt;
  return p;
}

double balanceHomes(mesh::SurfaceMesh& m, const physics::TissueParams& p) {
  if (!(p.homeK > 0.0)) throw CurriculumError("balanceHomes: needs a home stiffness above 0");
  if (!physics::hasTissueProperties(m)) throw CurriculumError("balanceHomes: the mesh has no tissue properties");
  physics::Params pp;
  pp.tissue = p;
  {
    physics::Dynamics d;
    const std::vector<Eigen::Vector3d> f = physics::forces(pp, d, m);
    auto home = m.getVertexProperty<Eigen::Vector3d>(physics::kHomeProp);
    for (mesh::Vertex v : m.vertices()) home[v] = m.position(v) - f[v.idx()] / p.homeK;
  }
  physics::recomputeMasses(m, p);  // lumped from the areas at the homes
  physics::Dynamics d;
  return physics::maxResidualForce(pp, d, m);
}

RunResult runTask(const Task& task, const mesh::SurfaceMesh& m, const devices::Trajectory& tr, const RunOptions& opt) {
  RunResult r;
  const physics::TissueParams tp = tissueParams(task.tissue, opt);
  cutting::CutParams cutParams = opt.cut;
  r.physics.on = opt.physics;
  r.physics.heldStill = opt.physics && opt.holdUnderBlade;
  mesh::SurfaceMesh start = m;
  tagOriginalFaces(start);  // one cut-path piece per original triangle
  if (opt.physics) {
    cutParams.tissue = tp;  // the cutter initialises new vertices and springs with these
    physics::attachTissueProperties(start, tp);
    if (tp.homeK > 0.0) {
      r.physics.startResidualMn = balanceHomes(start, tp);
    } else {
      physics::Params pp;
      pp.tissue = tp;
      physics::Dynamics d;
      r.physics.startResidualMn = physics::settle(pp, d, start).residual;
    }
  }
  // A tissue moving under the blade: the cut is recorded on the tissue at rest.
  std::optional<RestFrame> rest;
  if (opt.physics && !opt.holdUnderBlade) rest.emplace(start);
  cutting::CutEngine engine(cutParams);
  const int obj = engine.addObject(std::move(start));
  TissueMotion motion(engine, tp, opt);
  JawTrack jaws[2];
  for (const devices::PoseSample& s : tr.samples)
    if (s.tool == Tool::Grasper) jaws[s.hand == Hand::Left ? 0 : 1].add(s.t, s.pose.tip);
  double physT = tr.samples.empty() ? 0.0 : tr.samples.front().t;
  // Objects are looked up by id every time: separation may add objects.
  auto tissue = [&]() -> const mesh::SurfaceMesh& { return engine.object(obj).mesh; };
  TissuePath drawn = TissuePath::embed(tissue(), task.path, 1.0);
  LiveMetrics live(task.path, task.metrics, opt.seriesInterval);
  CutPathRecorder recorder;
  std::size_t fed = 0;
  std::optional<Eigen::Vector3d> lastRaw;  // previous cut point of the stroke (for path crossings)
  std::optional<Eigen::Vector3d> lastOff;  // the stroke's last cut point off the drawn path
  bool lastOnPath = false;                 // lastRaw is on the drawn path
  int lastObject = -1;
  mesh::Face hint;     // face of the previous cut point (local search)
  mesh::Face surface;  // the last surface (not wall) face the cut point was on
  std::vector<std::size_t> unsure;       // moving tissue: crossings not yet confirmed (drawn segments)
  int followed = -1, followedEdge = -1;  // the track the cut path follows, and its edge
  std::vector<int> seen;                 // the tracks of the previous cutting sample
  std::vector<int> passed;               // tracks that ran beside the followed one after it ended
  HandState hands[2];
  const double kGrasp = task.tissue.homeStiffness * 1e-3;  // N per mm of stretch (a spring proxy)

  auto followEdits = [&] {
    r.pathReembedded += drawn.followEdits(tissue());
    motion.followEdits();
  };
  auto feedCut = [&](double t) {
    const Polyline& p = recorder.path();
    for (; fed < p.size(); ++fed) {
      live.addCutPoint(t, p[fed].p);
      if (p[fed].stop) live.endCutPiece();
    }
  };
  auto endCut = [&](double t) {
    recorder.loseContact();
    feedCut(t);
    live.endCutPiece();
    lastRaw.reset();
    lastOff.reset();
    lastOnPath = false;
    unsure.clear();  // a crossing the cut did not go on from is not one
  };
  // The cut points the engine reports for this hand's sample: the cut path follows
  // the one nearest the working point (a hook descending through the surface also
  // slices with its other edge, ahead of the elbow: that is not where it works);
  // a stop when none is left.
  //
  // On a tissue moving under the blade, the blade's crossing is not always where it
  // cuts: behind a tip the pre-stretched cut ran ahead of (the track waits), on a lip
  // of the opening, or in the gap, at places that shift as the tissue rings. There
  // the cut path follows the cut the blade made in the tissue: the track's tip (its
  // last permanent vertex), carried to the tissue at rest. On a still tissue the
  // blade's point is the cut's pending point and stays the cut path.
  auto recordCut = [&](double t, const cutting::StepResult& step, const Eigen::Vector3d& ref) {
    const std::vector<cutting::CutPoint>& cps = step.cutPoints;
    // The cut path follows one cutting edge's cut: when the track it followed ends
    // while a track of the hand's other edge that ran beside it goes on (the hook's
    // foot, cutting on as the blade lifts out), that is not its continuation and is
    // not recorded (a new track is: a restart, or a layer met deeper on).
    std::vector<int> ids;
    for (const auto& c : cps) ids.push_back(c.track);
    auto has = [](const std::vector<int>& v, int id) { return std::find(v.begin(), v.end(), id) != v.end(); };
    auto nearest = [&] {
      std::optional<std::size_t> best;
      for (std::size_t i = 0; i < cps.size(); ++i)
        if (!has(passed, cps[i].track) &&
            (!best || (cps[i].point - ref).squaredNorm() < (cps[*best].point - ref).squaredNorm()))
          best = i;
      return best;
    };
    std::optional<std::size_t> pick = nearest();
    if (rest && pick && lastRaw && followed >= 0 && cps[*pick].segment != followedEdge && !has(ids, followed) &&
        has(seen, cps[*pick].track)) {
      for (const auto& c : cps)
        if (c.segment != followedEdge && has(seen, c.track)) passed.push_back(c.track);
      pick = nearest();
    }
    seen = ids;
    if (cps.empty()) passed.clear();
    if (!pick) {
      if (lastRaw) endCut(t);
      return;
    }
    const std::size_t ci = *pick;
    const cutting::CutPoint* cp = &cps[ci];
    followed = cp->track;
    followedEdge = cp->segment;
    // The engine reports one preview segment per cut point, in the same order.
    const bool tip = rest && step.preview.size() == cps.size();
    const Eigen::Vector3d src = tip ? step.preview[ci].from : cp->point;
    const mesh::SurfaceMesh& cm = engine.object(cp->object).mesh;
    double d = 0.0;
    SurfaceLocation loc = closestLocationNear(cm, cp->object == lastObject ? hint : mesh::Face(), src, 2, &d);
    if (d > 1e-3) loc = closestLocation(cm, src, &d);
    if (!cm.isValid(loc.face)) return;
    hint = loc.face;
    if (cp->object != lastObject) surface = mesh::Face();
    lastObject = cp->object;
    // Under physics a cut's walls retract and the blade's crossing can lie on a groove
    // wall: the cut path and the crossing test keep to the surface it was cutting (a
    // wall's normal would project the paths sideways).
    const auto kind = cm.getFaceProperty<int>(cutting::kFaceKindProp);
    if (!kind || kind[loc.face] == cutting::kSurface) surface = loc.face;
    const mesh::Face onSurface = cm.isValid(surface) ? surface : loc.face;
    Eigen::Vector3d point = src, normal = cm.faceNormal(onSurface);
    if (rest) {
      // On the tissue at rest, on the surface it was cutting (a point on a groove wall
      // goes to its nearest point there, at the lip: a wall's vertices are copies of
      // the lip's with their homes offset, which the original triangle does not hold).
      std::optional<Eigen::Vector3d> q = rest->at(cm, onSurface, src);
      if (!q) return;  // neither descends from the model (cannot happen on a tagged mesh)
      point = *q;
      normal = rest->normal(cm, onSurface);
    }
    recorder.contact(cm, onSurface, point);
    feedCut(t);
    // A cut point on the drawn path (the cut snaps to the mesh's vertices and edges,
    // and a path may run along them) touches it: whether the cut crossed is decided
    // when it leaves, from the last point it had off the path (touching and going back
    // is no crossing; the half-open segment test alone would count leaving the path).
    const double toPath = cp->object != obj ? std::numeric_limits<double>::infinity()
                          : rest            ? drawn.distanceAtRest(point)
                                            : drawn.distance(tissue(), point);
    const bool onPath = toPath <= 1e-9 * (1.0 + point.cwiseAbs().maxCoeff());
    if (lastRaw && cp->object == obj && !onPath && (!lastOnPath || lastOff)) {
      const Eigen::Vector3d& from = lastOnPath ? *lastOff : *lastRaw;
      int n = 0;
      if (rest) {
        const std::vector<std::size_t> crossed = drawn.crossingsAtRest(from, point, normal);
        unsure.insert(unsure.end(), crossed.begin(), crossed.end());
      } else {
        n = drawn.cutAcross(tissue(), from, point, normal);
      }
      for (int k = 0; k < n; ++k) live.addPathCrossing(t);
    }
    // On the moving tissue the cut recorded at rest wavers about the line it follows
    // (the tissue rings under the blade; the tips snap to the mesh), so a crossing
    // stands once the cut is crossingBandMm beyond the line; crossed back before that,
    // the two cancel.
    if (rest && !unsure.empty() && toPath >= opt.crossingBandMm) {
      if (unsure.size() % 2 == 1) {
        drawn.markCut(unsure.back());
        live.addPathCrossing(t);
      }
      unsure.clear();
    }
    if (!onPath) lastOff = point;
    lastOnPath = onPath;
    lastRaw = point;
  };

  // How far the tissue has carried the drawn path at the point nearest `at` (as
  // authored): linear between the two ends of the nearest segment.
  auto pathShift = [&](const Eigen::Vector3d& at) -> Eigen::Vector3d {
    const Polyline now = drawn.drawnPositions(tissue());
    const Polyline& was = task.path;
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    if (now.size() != was.size() || was.empty()) return shift;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < was.size(); ++i) {
      const bool segment = !was[i].stop && i + 1 < was.size();
      const Eigen::Vector3d a = was[i].p, ab = segment ? Eigen::Vector3d(was[i + 1].p - a) : Eigen::Vector3d::Zero();
      const double l2 = ab.squaredNorm();
      const double u = l2 > 0.0 ? std::clamp((at - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
      const double d2 = (a + u * ab - at).squaredNorm();
      if (d2 < best) {
        best = d2;
        shift = (1.0 - u) * (now[i].p - a);
        if (segment) shift += u * (now[i + 1].p - was[i + 1].p);
      }
    }
    return shift;
  };

  if (!tr.samples.empty()) live.start(tr.samples.front().t);
  for (const devices::PoseSample& sample : tr.samples) {
    ++r.samples;
    devices::PoseSample s = sample;
    if (opt.followMovingPath && rest && s.tool != Tool::Grasper)
      s.pose.tip += pathShift(workingPoint(s.tool, s.pose, engine.params().tool));
    const int hand = s.hand == Hand::Left ? 0 : 1;
    HandState& hs = hands[hand];
    if (opt.physics && s.t > physT) {
      motion.advance(physT, s.t, jaws, r.physics);
      physT = s.t;
      if (!r.physics.heldStill) drawn.refreshWorld(tissue());  // the path moved with the tissue
    }
    live.addTip({s.t, s.hand == Hand::Left ? HandSide::Left : HandSide::Right, s.pose.tip});
    if (s.tool == Tool::Grasper) {
      const bool closed = s.pose.jaw <= opt.grabJaw;
      if (closed && !hs.grasping) {
        // The jaws close on the nearest tissue object within grabDistance.
        double best = opt.grabDistance;
        int bestObj = -1;
        SurfaceLocation bestLoc;
        for (const auto& o : engine.objects()) {
          if (!opt.physics && o.id != obj) continue;
          double d = 0.0;
          const SurfaceLocation loc = closestLocation(o.mesh, s.pose.tip, &d);
          if (o.mesh.isValid(loc.face) && d <= best) {
            best = d;
            bestObj = o.id;
            bestLoc = loc;
          }
        }
        if (bestObj >= 0) {
          hs.grasping = true;
          hs.grasp = position(engine.object(bestObj).mesh, bestLoc);
          if (opt.physics) {
            r.physics.heldVertices += motion.hold(hand, bestObj, bestLoc, s.pose.tip);
            ++r.physics.grasps;
          }
        }
      } else if (!closed && hs.grasping) {
        hs.grasping = false;
        if (opt.physics) motion.release(hand);
      }
      double force = 0.0;  // N
      if (hs.grasping)
        force = opt.physics ? motion.force(hand, s.pose.tip).norm() * 1e-3 : kGrasp * (s.pose.tip - hs.grasp).norm();
      live.addGrasp({s.t, force, hs.grasping});
      r.grasp.push_back({s.t, force, hs.grasping});
      hs.last = s;
      hs.have = true;
      continue;
    }
    const bool cuttingTool = s.tool == Tool::Hook || s.tool == Tool::Scalpel;
    if (!cuttingTool) continue;
    if (hs.have && hs.last.tool != s.tool) {
      engine.endStroke(s.hand);  // instrument changed: the old one was lifted
      followEdits();
      endCut(s.t);
    }
    const cutting::StepResult step = engine.step(s.hand, s.tool, s.pose);
    if (step.topologyChanged) followEdits();
    motion.settleNew(step.preview);
    const Eigen::Vector3d ref = workingPoint(s.tool, s.pose, engine.params().tool);
    // A blade whose cut goes on (the engine reports a cut point) is in the tissue even
    // where no surface meets its edges: on a moving tissue the cut's lips retract from
    // it and it sits in the opening (the simulated tissue does not press on the
    // blade). Lifted out, its cuts end and the contact with them.
    std::optional<Eigen::Vector3d> hit = cuttingContact(step.contacts, ref);
    if (!hit && rest)
      for (const auto& c : step.cutPoints)
        if (!hit || (c.point - ref).squaredNorm() < (*hit - ref).squaredNorm()) hit = c.point;
    const bool now = hit.has_value();
    if (hs.have && hs.last.tool == s.tool && now != hs.contact && s.t > hs.last.t) {
      // Contact starts or ends between the two samples: find when (sampling-rate
      // independent contact times), on the tissue as it is now.
      // The contact point nearest the transition on the contact side, so that the
      // dwell sees the motion up to the transition at any sampling rate.
      double lo = 0.0, hi = 1.0;
      std::optional<Eigen::Vector3d> edge;
      for (int it = 0; it < opt.bisections; ++it) {
        const double mid = 0.5 * (lo + hi);
        const auto h = touchAt(engine, s.tool, interpolate(hs.last.pose, s.pose, mid));
        (h.has_value() == hs.contact ? lo : hi) = mid;
        if (h) edge = h;
      }
      const double tc = hs.last.t + (now ? hi : lo) * (s.t - hs.last.t);
      if (now) {
        live.addContact({tc, true, edge ? *edge : *hit});
      } else {
        if (edge) live.addContact({tc, true, *edge});
        live.addContact({tc, false, Eigen::Vector3d::Zero()});
      }
    }
    if (now) {
      ++r.contactSamples;
      live.addContact({s.t, true, *hit});
    } else {
      live.addContact({s.t, false, Eigen::Vector3d::Zero()});
    }
    recordCut(s.t, step, ref);
    hs.contact = now;
    hs.last = s;
    hs.have = true;
  }
  const double tEnd = tr.samples.empty() ? 0.0 : tr.samples.back().t;
  engine.finish();
  followEdits();
  endCut(tEnd);
  r.metrics = live.finish(tEnd);
  r.assessment = assess(r.metrics, task.scoring, task.proficiency);
  r.drawn = drawn.positions(tissue());
  r.drawnAsDrawn = drawn.drawnPositions(tissue());
  r.cut = recorder.path();
  r.series = live.series();
  r.cutStats = engine.stats();
  r.pathGlobalSearches = drawn.globalSearches();
  r.pathFreed = drawn.freedPoints();
  for (std::size_t i = 0; i < r.drawnAsDrawn.size() && i < task.path.size(); ++i)
    r.pathMovedMm = std::max(r.pathMovedMm, (r.drawnAsDrawn[i].p - task.path[i].p).norm());
  r.objects = engine.objects().size();
  motion.addStats(r.physics);
  r.physics.maxDisplacementMm = motion.maxDisplacement();
  return r;
}

nlohmann::json metricsJson(const Metrics& m, const Assessment& a) {
  auto dev = [&](const Deviation& d) {
    return nlohmann::json{{"xy", d.xy}, {"yz", d.yz}, {"xz", d.xz}, {"total", d.total()}, {"no_cut", m.noCut}};
  };
  return {{"deviation", dev(m.deviation)},
          {"deviation_thesis", dev(m.deviationThesis)},
          {"contact_time",
           {{"mean_s", m.contact.meanS},
            {"max_s", m.contact.maxS},
            {"total_s", m.contact.totalS},
            {"dwells", m.contact.dwells}}},
          {"contact_breaks", m.contactBreaks},
          {"path_breaks", m.pathBreaks},
          {"total_time_s", m.totalTimeS},
          {"stretch_force", {{"mean_n", m.stretchMeanN}, {"max_n", m.stretchMaxN}}},
          {"cut_distance", {{"mean_mm", m.cutDistanceMeanMm}, {"max_mm", m.cutDistanceMaxMm}}},
          {"band_fraction", m.bandFraction},
          {"path_length_mm", {{"left", m.pathLengthLeftMm}, {"right", m.pathLengthRightMm}}},
          {"score", a.score},
          {"penalty_s", a.penaltyS},
          {"passed", a.passed},
          {"reasons", {{"failed", a.failures}, {"met", a.passes}}}};
}

nlohmann::json runJson(const Task& task, const RunResult& r) {
  nlohmann::json j = metricsJson(r.metrics, r.assessment);
  j["task"] = {{"id", task.id}, {"version", task.version}, {"hash", contentHash(task)}};
  j["samples"] = r.samples;
  j["cut_points"] = r.cut.size();
  j["cutting"] = {{"engine", "ld::cutting::CutEngine"},           {"triangles_cut", r.cutStats.trianglesCut},
                  {"triangles_added", r.cutStats.trianglesAdded}, {"walk_failures", r.cutStats.walkFailures},
                  {"separations", r.cutStats.separations},        {"objects", r.objects}};
  j["drawn_path"] = {{"points", r.drawn.size()},       {"pieces", pieces(r.drawn).size()},
                     {"reembedded", r.pathReembedded}, {"global_searches", r.pathGlobalSearches},
                     {"freed", r.pathFreed},           {"max_moved_mm", r.pathMovedMm}};
  // The model behind the stretch force (README: curriculum).
  if (r.physics.on) {
    j["stretch_force"]["model"] = r.physics.heldStill
                                      ? "physics (the cut and the drawn path on the tissue held still under the blade)"
                                      : "physics";
    j["physics"] = {{"on", true},
                    {"mode", r.physics.heldStill ? "still" : "on"},
                    {"max_displacement_mm", r.physics.maxDisplacementMm},
                    {"steps", r.physics.steps},
                    {"ms", r.physics.seconds * 1e3},
                    {"us_per_step", r.physics.steps > 0 ? r.physics.seconds * 1e6 / r.physics.steps : 0.0},
                    {"start_residual_mn", r.physics.startResidualMn},
                    {"rejected_steps", r.physics.rejectedSteps},
                    {"implicit_fallbacks", r.physics.implicitFallbacks},
                    {"grasps", r.physics.grasps},
                    {"held_vertices", r.physics.heldVertices}};
  } else {
    j["stretch_force"]["model"] = "estimate: home stiffness x grasper displacement (--physics off)";
    j["physics"] = {{"on", false}, {"mode", "off"}};
  }
  return j;
}

}  // namespace ld::curriculum
