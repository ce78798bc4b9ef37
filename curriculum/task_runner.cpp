#include "curriculum/task_runner.h"

#include <cmath>
#include <optional>

#include "curriculum/tissue_path.h"
#include "sim/collision/bvh.h"
#include "sim/instruments/instrument.h"

namespace ld::curriculum {
namespace {

using instruments::Hand;
using instruments::Pose;
using instruments::Tool;

struct Hit {
  Eigen::Vector3d point;
  mesh::Face face;
};

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

class Contacts {
 public:
  explicit Contacts(const mesh::SurfaceMesh& m) : m_(m), bvh_(m) {}
  // Where the cutting edges meet the surface: of all hits, the one nearest the working
  // point (the hook's elbow, the scalpel's tip), so that a hook lying flat on the
  // tissue or dipping its tip does not make the contact point jump along the edge.
  std::optional<Hit> cuttingHit(Tool tool, const Pose& pose) {
    std::optional<Hit> best;
    double bestD = 0.0;
    bool bestCoplanar = true;
    bool first = true;
    Eigen::Vector3d ref = pose.tip;
    for (const auto& s : instruments::segments(tool, pose)) {
      if (s.role != instruments::SegmentRole::CuttingEdge) continue;
      if (first) ref = s.a;
      first = false;
      bvh_.intersectSegment(m_, s.a, s.b, hits_);
      for (const auto& h : hits_) {
        // A coplanar overlap only counts when nothing crosses: its point is ill-defined.
        const bool coplanar = h.kind == collision::HitKind::Coplanar;
        const double d = (h.point - ref).squaredNorm();
        if (!best || (bestCoplanar && !coplanar) || (coplanar == bestCoplanar && d < bestD)) {
          best = Hit{h.point, h.face};
          bestD = d;
          bestCoplanar = coplanar;
        }
      }
    }
    return best;
  }

 private:
  const mesh::SurfaceMesh& m_;
  collision::TriangleBvh bvh_;
  std::vector<collision::SurfaceHit> hits_;
};

struct HandState {
  bool have = false;
  devices::PoseSample last;
  bool contact = false;
  Hit hit{};
  // grasper
  bool grasping = false;
  Eigen::Vector3d grasp = Eigen::Vector3d::Zero();
};

}  // namespace

RunResult runTask(const Task& task, const mesh::SurfaceMesh& m, const devices::Trajectory& tr, const RunOptions& opt) {
  RunResult r;
  TissuePath drawn = TissuePath::embed(m, task.path, 1.0);
  Contacts contacts(m);
  LiveMetrics live(task.path, task.metrics, opt.seriesInterval);
  CutPathRecorder recorder;
  std::size_t fed = 0;
  std::optional<Eigen::Vector3d> lastRaw;  // previous cut point of the stroke (for path crossings)
  HandState hands[2];
  const double kGrasp = task.tissue.homeStiffness * 1e-3;  // N per mm of stretch (a spring proxy)

  auto feedCut = [&](double t) {
    const Polyline& p = recorder.path();
    for (; fed < p.size(); ++fed) {
      live.addCutPoint(t, p[fed].p);
      if (p[fed].stop) live.endCutPiece();
    }
  };
  auto cutAt = [&](double t, const Hit& h) {
    recorder.contact(m, h.face, h.point);
    feedCut(t);
    if (lastRaw) {
      const int n = drawn.cutAcross(m, *lastRaw, h.point, m.faceNormal(h.face));
      for (int k = 0; k < n; ++k) live.addPathCrossing(t);
    }
    lastRaw = h.point;
  };
  auto endCut = [&](double t) {
    recorder.loseContact();
    feedCut(t);
    live.endCutPiece();
    lastRaw.reset();
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
        const SurfaceLocation loc = closestLocation(m, s.pose.tip, &d);
        if (m.isValid(loc.face) && d <= opt.grabDistance) {
          hs.grasping = true;
          hs.grasp = position(m, loc);
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
    const std::optional<Hit> hit = contacts.cuttingHit(s.tool, s.pose);
    const bool now = hit.has_value();
    if (hs.have && hs.last.tool == s.tool && now != hs.contact && s.t > hs.last.t) {
      // Contact starts or ends between the two samples: find when.
      double lo = 0.0, hi = 1.0;
      std::optional<Hit> edge = now ? hit : hs.contact ? std::optional<Hit>(hs.hit) : std::nullopt;
      for (int it = 0; it < opt.bisections; ++it) {
        const double mid = 0.5 * (lo + hi);
        const auto h = contacts.cuttingHit(s.tool, interpolate(hs.last.pose, s.pose, mid));
        if (h.has_value() == hs.contact) {
          lo = mid;
          if (h) edge = h;
        } else {
          hi = mid;
          if (h) edge = h;
        }
      }
      const double tc = hs.last.t + (now ? hi : lo) * (s.t - hs.last.t);
      const bool wasCutting = hs.contact && (s.tool == Tool::Scalpel || hs.last.pose.pedal);
      if (now) {
        live.addContact({tc, true, edge->point});
        if (s.tool == Tool::Scalpel || hs.last.pose.pedal) cutAt(tc, *edge);
      } else {
        if (edge) {
          live.addContact({tc, true, edge->point});
          if (wasCutting) cutAt(tc, *edge);
        }
        live.addContact({tc, false, Eigen::Vector3d::Zero()});
        if (wasCutting) endCut(tc);
      }
    }
    if (now) {
      ++r.contactSamples;
      live.addContact({s.t, true, hit->point});
      const bool cutting = s.tool == Tool::Scalpel || s.pose.pedal;
      if (cutting)
        cutAt(s.t, *hit);
      else if (lastRaw)
        endCut(s.t);  // pedal released: the stroke ends here
    } else {
      live.addContact({s.t, false, Eigen::Vector3d::Zero()});
      if (lastRaw) endCut(s.t);
    }
    hs.contact = now;
    if (hit) hs.hit = *hit;
    hs.last = s;
    hs.have = true;
  }
  const double tEnd = tr.samples.empty() ? 0.0 : tr.samples.back().t;
  endCut(tEnd);
  r.metrics = live.finish(tEnd);
  r.assessment = assess(r.metrics, task.scoring, task.proficiency);
  r.drawn = drawn.positions(m);
  r.cut = recorder.path();
  r.series = live.series();
  return r;
}

nlohmann::json metricsJson(const Metrics& m, const Assessment& a) {
  auto dev = [](const Deviation& d) {
    return nlohmann::json{{"xy", d.xy}, {"yz", d.yz}, {"xz", d.xz}, {"total", d.total()}};
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
  return j;
}

}  // namespace ld::curriculum
