#include "curriculum/scripted_trainee.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "curriculum/tissue_path.h"

namespace ld::curriculum {
namespace {

using Eigen::Vector3d;

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// A smooth zero-mean signal: a few slow sinusoids with seeded frequencies and phases.
struct Wander {
  double f[4], ph[4], w[4];
  Wander(std::mt19937& rng, double fmin, double fmax) {
    std::uniform_real_distribution<double> uf(fmin, fmax), up(0, 2 * std::numbers::pi);
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      f[k] = uf(rng);
      ph[k] = up(rng);
      w[k] = 1.0 / (k + 1);
      sum += w[k];
    }
    for (double& x : w) x /= sum;
  }
  [[nodiscard]] double operator()(double t) const {
    double v = 0;
    for (int k = 0; k < 4; ++k) v += w[k] * std::sin(2 * std::numbers::pi * f[k] * t + ph[k]);
    return v;
  }
};

struct Frame {
  Vector3d p, tangent, normal;
};

class PathFrames {
 public:
  PathFrames(const Task& task, const mesh::SurfaceMesh& m) {
    const auto pts = joinedPoints(task.path);
    const TissuePath tp = TissuePath::embed(m, task.path, 1.0);
    s_.push_back(0.0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      p_.push_back(pts[i]);
      n_.push_back(m.faceNormal(tp.points()[i].loc.face));
      if (i > 0) s_.push_back(s_.back() + (pts[i] - pts[i - 1]).norm());
    }
  }
  [[nodiscard]] double length() const { return s_.back(); }
  [[nodiscard]] Frame at(double s) const {
    s = std::clamp(s, 0.0, length());
    std::size_t i = static_cast<std::size_t>(std::upper_bound(s_.begin(), s_.end(), s) - s_.begin());
    i = std::clamp<std::size_t>(i, 1, s_.size() - 1);
    const double l = s_[i] - s_[i - 1];
    const double u = l > 0 ? (s - s_[i - 1]) / l : 0.0;
    Frame f;
    f.p = p_[i - 1] + u * (p_[i] - p_[i - 1]);
    // Tangent blended between neighbouring segments so that it turns smoothly.
    auto seg = [&](std::size_t k) { return (p_[k] - p_[k - 1]).normalized().eval(); };
    const Vector3d tPrev = i >= 2 ? seg(i - 1) : seg(i), tNext = i + 1 < p_.size() ? seg(i + 1) : seg(i);
    const Vector3d tCur = seg(i);
    Vector3d t = u < 0.5 ? ((0.5 - u) * tPrev + (0.5 + u) * tCur) : ((1.5 - u) * tCur + (u - 0.5) * tNext);
    f.tangent = t.normalized();
    Vector3d n = ((1 - u) * n_[i - 1] + u * n_[i]);
    n -= n.dot(f.tangent) * f.tangent;
    f.normal = n.normalized();
    return f;
  }

 private:
  std::vector<Vector3d> p_, n_;
  std::vector<double> s_;
};

}  // namespace

TraineeProfile traineeProfile(int level, unsigned seed) {
  TraineeProfile p;
  p.seed = seed;
  if (level <= 0) return p;
  level = std::min(level, 3);
  // Per novice level 1..3: slower (longer dwells), a larger lateral wander that turns
  // a little more often, growing fast corrections (more crossings of the line, where
  // the wander is near it), longer and more pauses, more lifts, a harder and jerkier
  // pull. Amplitudes grow faster than frequencies, so the cut leaves the band more.
  struct Row {
    double speed, wander, scale, fast, fastScale, pauseS;
  };
  constexpr Row kRows[] = {
      {6.5, 1.5, 1.0, 0.1, 1.0, 1.2}, {5.0, 2.8, 1.15, 0.35, 1.25, 1.5}, {3.0, 5.2, 1.3, 1.3, 1.5, 2.0}};
  const Row& r = kRows[level - 1];
  p.name = "novice" + std::to_string(level);
  p.speed = r.speed;
  p.speedWobble = 0.15 * level;
  p.lateralBias = 0.0;
  p.lateralNoise = r.wander;
  p.wanderScale = r.scale;
  p.fastNoise = r.fast;
  p.fastScale = r.fastScale;
  p.pauses = level;
  p.pauseS = r.pauseS;
  p.lifts = level;
  p.pull = 4.0 + 2.0 * level;
  p.pullNoise = 1.0 * level;
  return p;
}

devices::Trajectory scriptedAttempt(const Task& task, const mesh::SurfaceMesh& m, const TraineeProfile& prof,
                                    double rateHz) {
  const PathFrames path(task, m);
  std::mt19937 rng(prof.seed);
  // The same draws at every level (a fixed seed), scaled by the level's frequencies.
  const Wander lateral(rng, prof.wanderScale / 40.0, prof.wanderScale / 10.0), surge(rng, 0.05, 0.2),
      depthW(rng, 0.1, 0.4), pullW(rng, 0.2, 0.8), fast(rng, prof.fastScale / 4.0, prof.fastScale / 1.5);
  const double L = path.length();
  const double tApproach = 1.0, tDescend = 0.5;
  const double t0 = tApproach + tDescend;  // cutting starts
  const double speed = prof.speed;
  // Pauses and lifts at evenly spread fractions of the path (offset so they differ).
  std::vector<double> pauseAt, liftAt;
  for (int k = 0; k < prof.pauses; ++k) pauseAt.push_back(L * (k + 0.5) / (prof.pauses + 0.5) * 0.9);
  for (int k = 0; k < prof.lifts; ++k) liftAt.push_back(L * (k + 0.8) / (prof.lifts + 0.8) * 0.9);
  // Arc length reached after moving time tau (pauses excluded): s = v tau + wobble.
  const double wobbleAmp = prof.speedWobble * speed / (2 * std::numbers::pi * 0.2);
  auto arc = [&](double tau) { return speed * tau + wobbleAmp * (surge(tau) - surge(0.0)); };
  // Moving time needed to reach s (arc is increasing: wobble slope < speed).
  auto tauOf = [&](double s) {
    double lo = 0, hi = 10 * (s / speed + 1);
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      (arc(mid) < s ? lo : hi) = mid;
    }
    return hi;
  };
  std::vector<double> pauseTau;
  for (double s : pauseAt) pauseTau.push_back(tauOf(s));
  std::vector<double> liftTime;  // wall time a lift starts
  const double tauEnd = tauOf(L);
  auto wallOf = [&](double tau) {
    double t = t0 + tau;
    for (double pt : pauseTau)
      if (tau > pt) t += prof.pauseS;
    return t;
  };
  for (double s : liftAt) liftTime.push_back(wallOf(tauOf(s)));
  const double tCutEnd = wallOf(tauEnd);
  const double tEnd = tCutEnd + 0.8;
  auto tauAt = [&](double t) {
    double tau = t - t0, spent = 0.0;
    for (double pt : pauseTau) {
      if (tau - spent <= pt) break;
      spent += std::min(prof.pauseS, tau - spent - pt);
    }
    return std::clamp(tau - spent, 0.0, tauEnd);
  };

  // Grasper: holds the tissue 12 mm before the path's start, pulls it back along -tangent.
  const Frame start = path.at(0.0);
  double dg = 0;
  const Vector3d grasp = position(m, closestLocation(m, start.p - 12.0 * start.tangent, &dg));

  devices::Trajectory tr;
  const long n = static_cast<long>(std::floor(tEnd * rateHz + 1e-9));
  for (long i = 0; i <= n; ++i) {
    const double t = std::min(tEnd, static_cast<double>(i) / rateHz);
    // ---- left hand: grasper
    {
      devices::PoseSample s;
      s.t = t;
      s.hand = instruments::Hand::Left;
      s.tool = instruments::Tool::Grasper;
      const double closeT = 0.4;
      const double pull = smoothstep((t - 0.6) / 1.0) * (prof.pull + prof.pullNoise * pullW(t)) *
                          (1.0 - smoothstep((t - tCutEnd) / 0.5));
      const double lift = 5.0 * (1.0 - smoothstep(t / closeT));
      s.pose.tip = grasp - pull * start.tangent + lift * start.normal;
      s.pose.dir = -start.normal;
      s.pose.up = start.tangent;
      s.pose.jaw = t < closeT ? 1.0 - t / closeT : 0.0;
      s.pose.pedal = false;
      tr.samples.push_back(s);
    }
    // ---- right hand: hook
    {
      devices::PoseSample s;
      s.t = t;
      s.hand = instruments::Hand::Right;
      s.tool = instruments::Tool::Hook;
      const double sArc = arc(tauAt(t));
      const Frame f = path.at(sArc);
      const Vector3d side = f.normal.cross(f.tangent).normalized();
      // Spatial: mm of wander per mm of path (a pause stops it; any rate samples the same motion).
      const double off = prof.lateralBias + prof.lateralNoise * lateral(sArc) + prof.fastNoise * fast(sArc);
      // Height of the elbow above the surface: approach from 5 mm above, cut at -depth,
      // lifts of 3 mm, rise at the end.
      double h = -prof.depth * (1.0 + 0.2 * depthW(t));
      h = 5.0 + (h - 5.0) * smoothstep((t - tApproach) / tDescend);
      for (double lt : liftTime) {
        const double up = smoothstep((t - lt) / 0.15) * (1.0 - smoothstep((t - lt - prof.liftS) / 0.15));
        h += up * (3.0 + prof.depth);
      }
      h += smoothstep((t - tCutEnd) / 0.4) * (6.0 + prof.depth);
      const Vector3d c = f.p + off * side + h * f.normal;  // the elbow
      // The hook's tip is raised 0.3 mm over its 4 mm (never flat on the tissue).
      s.pose.up = (f.tangent + 0.075 * f.normal).normalized();
      s.pose.dir = (-f.normal + 0.075 * f.tangent).normalized();
      s.pose.tip = c + 4.0 * s.pose.up;  // elbow B = tip - 4 up
      s.pose.jaw = 0.0;
      s.pose.pedal = t >= tApproach && t <= tCutEnd + 0.2;
      tr.samples.push_back(s);
    }
    if (t >= tEnd) break;
  }
  return tr;
}

}  // namespace ld::curriculum
