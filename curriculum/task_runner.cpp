#include "curriculum/task_runner.h"

#include <cmath>
#include <optional>

#include "curriculum/tissue_path.h"
#include "sim/collision/segment_triangle.h"
#include "sim/instruments/instrument.h"

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

struct HandState {
  bool have = false;
  devices::PoseSample last;
  bool contact = false;
  // grasper
  bool grasping = false;
  Eigen::Vector3d grasp = Eigen::Vector3d::Zero();
};

}  // namespace

RunResult runTask(const Task& task, const mesh::SurfaceMesh& m, const devices::Trajectory& tr, const RunOptions& opt) {
  RunResult r;
  cutting::CutEngine engine(opt.cut);
  int obj = 0;
  {
    mesh::SurfaceMesh tissue = m;
    tagOriginalFaces(tissue);  // one cut-path piece per original triangle
    obj = engine.addObject(std::move(tissue));
  }
  // Objects are looked up by id every time: separation may add objects.
  auto tissue = [&]() -> const mesh::SurfaceMesh& { return engine.object(obj).mesh; };
  TissuePath drawn = TissuePath::embed(tissue(), task.path, 1.0);
  LiveMetrics live(task.path, task.metrics, opt.seriesInterval);
  CutPathRecorder recorder;
  std::size_t fed = 0;
  std::optional<Eigen::Vector3d> lastRaw;  // previous cut point of the stroke (for path crossings)
  int lastObject = -1;
  mesh::Face hint;  // face of the previous cut point (local search)
  HandState hands[2];
  const double kGrasp = task.tissue.homeStiffness * 1e-3;  // N per mm of stretch (a spring proxy)

  auto followEdits = [&] { r.pathReembedded += drawn.followEdits(tissue()); };
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
  };
  // The cut points the engine reports for this hand's sample: the cut path follows
  // the one nearest the working point (a hook descending through the surface also
  // slices with its other edge, ahead of the elbow: that is not where it works);
  // a stop when none is left.
  auto recordCut = [&](double t, const std::vector<cutting::CutPoint>& cps, const Eigen::Vector3d& ref) {
    if (cps.empty()) {
      if (lastRaw) endCut(t);
      return;
    }
    const cutting::CutPoint* cp = &cps.front();
    for (const auto& c : cps)
      if ((c.point - ref).squaredNorm() < (cp->point - ref).squaredNorm()) cp = &c;
    const mesh::SurfaceMesh& cm = engine.object(cp->object).mesh;
    double d = 0.0;
    SurfaceLocation loc = closestLocationNear(cm, cp->object == lastObject ? hint : mesh::Face(), cp->point, 2, &d);
    if (d > 1e-3) loc = closestLocation(cm, cp->point, &d);
    if (!cm.isValid(loc.face)) return;
    hint = loc.face;
    lastObject = cp->object;
    recorder.contact(cm, loc.face, cp->point);
    feedCut(t);
    if (lastRaw && cp->object == obj) {
      const int n = drawn.cutAcross(tissue(), *lastRaw, cp->point, cm.faceNormal(loc.face));
      for (int k = 0; k < n; ++k) live.addPathCrossing(t);
    }
    lastRaw = cp->point;
  };

  if (!tr.samples.empty()) live.start(tr.samples.front().t);
  for (const devices::PoseSample& s : tr.samples) {
    ++r.samples;
    HandState& hs = hands[s.hand == Hand::Left ? 0 : 1];
    live.addTip({s.t, s.hand == Hand::Left ? HandSide::Left : HandSide::Right, s.pose.tip});
    if (s.tool == Tool::Grasper) {
      const bool closed = s.pose.jaw <= opt.grabJaw;
      if (closed && !hs.grasping) {
        double d = 0.0;
        const SurfaceLocation loc = closestLocation(tissue(), s.pose.tip, &d);
        if (tissue().isValid(loc.face) && d <= opt.grabDistance) {
          hs.grasping = true;
          hs.grasp = position(tissue(), loc);
        }
      } else if (!closed) {
        hs.grasping = false;
      }
      live.addGrasp({s.t, hs.grasping ? kGrasp * (s.pose.tip - hs.grasp).norm() : 0.0, hs.grasping});
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
    const Eigen::Vector3d ref = workingPoint(s.tool, s.pose, engine.params().tool);
    const std::optional<Eigen::Vector3d> hit = cuttingContact(step.contacts, ref);
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
    recordCut(s.t, step.cutPoints, ref);
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
  r.objects = engine.objects().size();
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
  j["drawn_path"] = {{"points", r.drawn.size()},
                     {"pieces", pieces(r.drawn).size()},
                     {"reembedded", r.pathReembedded},
                     {"global_searches", r.pathGlobalSearches}};
  // Honest about the model behind the stretch force (README: curriculum).
  j["stretch_force"]["model"] = "estimate: home stiffness x grasper displacement (no physics in task run)";
  return j;
}

}  // namespace ld::curriculum
