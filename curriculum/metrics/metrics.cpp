#include "curriculum/metrics/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace ld::curriculum {

void DwellTracker::closeDwell(double t) {
  const double d = std::max(0.0, t - tRef_);
  sum_ += d;
  max_ = std::max(max_, d);
  ++count_;
}

void DwellTracker::add(const ContactSample& s) {
  if (!s.contact) {
    if (inContact_) {
      closeDwell(s.t);
      total_ += std::max(0.0, s.t - tStart_);
      inContact_ = false;
    }
    return;
  }
  if (!inContact_) {
    inContact_ = true;
    ++intervals_;
    ref_ = last_ = s.point;
    tRef_ = tLast_ = tStart_ = s.t;
    return;
  }
  // Walk the straight motion last_ -> s.point; each exit from the reference ball
  // closes a dwell at the exit point and time, which becomes the new reference.
  Eigen::Vector3d a = last_;
  double ta = tLast_;
  const Eigen::Vector3d b = s.point;
  const double r2 = radius_ * radius_;
  for (int guard = 0; guard < 1000000 && (b - ref_).squaredNorm() > r2; ++guard) {
    const Eigen::Vector3d d = b - a, f = a - ref_;
    const double dd = d.squaredNorm();
    if (dd <= 0.0) break;
    const double fd = f.dot(d);
    const double disc = std::max(0.0, fd * fd - dd * (f.squaredNorm() - r2));
    const double u = std::clamp((-fd + std::sqrt(disc)) / dd, 0.0, 1.0);
    const double tc = ta + u * (s.t - ta);
    const Eigen::Vector3d pc = a + u * d;
    closeDwell(tc);
    ref_ = pc;
    tRef_ = tc;
    a = pc;
    ta = tc;
  }
  last_ = b;
  tLast_ = s.t;
}

void DwellTracker::finish(double tEnd) {
  if (!inContact_) return;
  closeDwell(tEnd);
  total_ += std::max(0.0, tEnd - tStart_);
  inContact_ = false;
}

ContactTime DwellTracker::result() const {
  ContactTime c;
  c.dwells = count_;
  c.meanS = count_ > 0 ? sum_ / count_ : 0.0;
  c.maxS = max_;
  c.totalS = total_;
  return c;
}

ContactTime contactTime(const std::vector<ContactSample>& contacts, double radius, double tEnd) {
  DwellTracker d(radius);
  for (const auto& s : contacts) d.add(s);
  d.finish(tEnd);
  return d.result();
}

int contactBreaks(const std::vector<ContactSample>& contacts) {
  int intervals = 0;
  bool in = false;
  for (const auto& s : contacts) {
    if (s.contact && !in) ++intervals;
    in = s.contact;
  }
  return std::max(0, intervals - 1);
}

void stretchForce(const std::vector<ForceSample>& grasp, double& mean, double& max) {
  double integral = 0.0, time = 0.0;
  max = 0.0;
  for (std::size_t i = 0; i < grasp.size(); ++i) {
    if (grasp[i].grasping) max = std::max(max, grasp[i].force);
    if (i > 0 && grasp[i].grasping && grasp[i - 1].grasping) {
      const double dt = grasp[i].t - grasp[i - 1].t;
      integral += 0.5 * (grasp[i].force + grasp[i - 1].force) * dt;
      time += dt;
    }
  }
  mean = time > 0.0 ? integral / time : max;
}

double pathLength(const std::vector<TipSample>& tips, HandSide hand) {
  double len = 0.0;
  const TipSample* prev = nullptr;
  for (const auto& s : tips) {
    if (s.hand != hand) continue;
    if (prev) len += (s.tip - prev->tip).norm();
    prev = &s;
  }
  return len;
}

double pointSegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0.0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

double distanceToPath(const Eigen::Vector3d& p, const Polyline& path) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < path.size(); ++i) {
    const bool single = (i == 0 || path[i - 1].stop) && (path[i].stop || i + 1 == path.size());
    if (single) best = std::min(best, (p - path[i].p).norm());
    if (i > 0 && !path[i - 1].stop) best = std::min(best, pointSegmentDistance(p, path[i - 1].p, path[i].p));
  }
  return best;
}

void cutDistance(const Polyline& drawn, const Polyline& cut, double step, double& mean, double& max) {
  mean = max = 0.0;
  if (drawn.empty() || cut.empty()) return;
  double integral = 0.0, length = 0.0, pointSum = 0.0;
  for (std::size_t i = 0; i < cut.size(); ++i) {
    const double di = distanceToPath(cut[i].p, drawn);
    max = std::max(max, di);
    pointSum += di;
    if (i == 0 || cut[i - 1].stop) continue;
    const Eigen::Vector3d a = cut[i - 1].p, b = cut[i].p;
    const double len = (b - a).norm();
    const int n = std::max(1, static_cast<int>(std::ceil(len / step)));
    double prev = distanceToPath(a, drawn);
    for (int k = 1; k <= n; ++k) {
      const double dk = k == n ? di : distanceToPath(a + (b - a) * (double(k) / n), drawn);
      max = std::max(max, dk);
      integral += 0.5 * (prev + dk) * len / n;
      prev = dk;
    }
    length += len;
  }
  mean = length > 0.0 ? integral / length : pointSum / static_cast<double>(cut.size());
}

bool bandInterval(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector3d& d, double band, double& t0, double& t1) {
  auto f = [&](double t) { return pointSegmentDistance(a + t * (b - a), c, d); };
  // Quick rejection by bounding boxes grown by the band.
  const Eigen::Vector3d lo1 = a.cwiseMin(b), hi1 = a.cwiseMax(b), lo2 = c.cwiseMin(d), hi2 = c.cwiseMax(d);
  if (((lo1.array() - band) > hi2.array()).any() || ((lo2.array() - band) > hi1.array()).any()) return false;
  // f is convex: golden-section search for its minimum, then bisect both sides.
  double lo = 0.0, hi = 1.0;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo), f1 = f(x1), f2 = f(x2);
  for (int it = 0; it < 80 && hi - lo > 1e-13; ++it) {
    if (f1 <= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - g * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + g * (hi - lo);
      f2 = f(x2);
    }
  }
  double tm = 0.5 * (lo + hi);
  for (double cand : {0.0, 1.0})
    if (f(cand) < f(tm)) tm = cand;
  if (f(tm) > band) return false;
  auto boundary = [&](double inside, double outside) {
    if (f(outside) <= band) return outside;
    for (int it = 0; it < 60; ++it) {
      const double m = 0.5 * (inside + outside);
      (f(m) <= band ? inside : outside) = m;
    }
    return inside;
  };
  t0 = boundary(tm, 0.0);
  t1 = boundary(tm, 1.0);
  return true;
}

namespace {

double coveredLength(std::vector<std::pair<double, double>>& iv) {
  std::sort(iv.begin(), iv.end());
  double covered = 0.0, curLo = -1.0, curHi = -1.0;
  for (const auto& [lo, hi] : iv) {
    if (lo > curHi) {
      covered += curHi - curLo;
      curLo = lo;
      curHi = hi;
    } else {
      curHi = std::max(curHi, hi);
    }
  }
  covered += curHi - curLo;
  return covered;
}

}  // namespace

double bandFraction(const Polyline& drawn, const Polyline& cut, double band) {
  const double total = piecesLength(drawn);
  if (total <= 0.0 || cut.empty()) return 0.0;
  double covered = 0.0;
  std::vector<std::pair<double, double>> iv;
  for (std::size_t i = 1; i < drawn.size(); ++i) {
    if (drawn[i - 1].stop) continue;
    const Eigen::Vector3d a = drawn[i - 1].p, b = drawn[i].p;
    iv.clear();
    for (std::size_t j = 0; j < cut.size(); ++j) {
      const bool segment = j > 0 && !cut[j - 1].stop;
      const bool single = (j == 0 || cut[j - 1].stop) && (cut[j].stop || j + 1 == cut.size());
      double t0, t1;
      if (segment && bandInterval(a, b, cut[j - 1].p, cut[j].p, band, t0, t1)) iv.emplace_back(t0, t1);
      if (single && bandInterval(a, b, cut[j].p, cut[j].p, band, t0, t1)) iv.emplace_back(t0, t1);
    }
    covered += coveredLength(iv) * (b - a).norm();
  }
  return std::clamp(covered / total, 0.0, 1.0);
}

Metrics computeMetrics(const Polyline& drawn, const AttemptEvents& ev, const MetricSettings& s) {
  Metrics m;
  if (!ev.cut.empty()) {
    m.deviation = deviation(drawn, ev.cut);
    m.deviationThesis = deviationThesis(drawn, ev.cut);
  } else {
    m.deviation = m.deviationThesis = deviationWithoutCut(drawn, s.band);
    m.noCut = true;
  }
  m.contact = contactTime(ev.contacts, s.contactRadius, ev.endTime);
  m.contactBreaks = contactBreaks(ev.contacts);
  m.pathBreaks = static_cast<int>(ev.pathCrossings.size());
  m.totalTimeS = std::max(0.0, ev.endTime - ev.startTime);
  stretchForce(ev.grasp, m.stretchMeanN, m.stretchMaxN);
  cutDistance(drawn, ev.cut, s.distanceStep, m.cutDistanceMeanMm, m.cutDistanceMaxMm);
  m.bandFraction = bandFraction(drawn, ev.cut, s.band);
  m.pathLengthLeftMm = pathLength(ev.tips, HandSide::Left);
  m.pathLengthRightMm = pathLength(ev.tips, HandSide::Right);
  return m;
}

}  // namespace ld::curriculum
