#pragma once
// Live metrics: updated as each event arrives, at a cost per event that does not
// grow with the attempt's length, producing the time series the live charts draw.
//
// The live deviation compares the cut so far with the drawn path up to the trainee's
// progress point P (the nearest point of the drawn path to the cut's end, searched
// forward in a short window, never moving back). Each new cut point changes the loop
// of DESIGN.md by one small closed polygon Q (P_old, drawn points up to P_new, the new
// cut point, the old one), so the winding number changes by w_Q only on Q's support.
// The change of ∫|w| is then ∫|W + w_Q| − ∫|W| evaluated over the earlier polygons
// whose bounding boxes meet Q's: exact, and local. finish() adds the polygon that
// closes the loop from P to the drawn path's end, which yields the batch value.
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "curriculum/metrics/deviation.h"
#include "curriculum/metrics/metrics.h"

namespace ld::curriculum {

class LiveDeviation {
 public:
  // maxOverlap bounds the work per point where a projection folds many polygons onto
  // one place (then the live value is approximate until finish()).
  explicit LiveDeviation(const Polyline& drawn, std::size_t maxOverlap = 64);
  void addCutPoint(const Eigen::Vector3d& p);
  // Closes the loop at the drawn path's end: the value then equals deviation().
  void finish();
  [[nodiscard]] const Deviation& value() const { return value_; }
  [[nodiscard]] bool exact() const { return exact_; }
  [[nodiscard]] std::size_t progressSegment() const { return seg_; }
  [[nodiscard]] const Eigen::Vector3d& progressPoint() const { return p_; }

 private:
  struct PlaneAcc {
    std::vector<std::vector<Segment2>> polys;
    std::vector<Eigen::Vector4d> boxes;  // min x, min y, max x, max y
    std::unordered_map<std::int64_t, std::vector<std::uint32_t>> grid;
    std::vector<std::uint32_t> big;
  };
  void addPolygon(const std::vector<Eigen::Vector3d>& poly);
  double addToPlane(PlaneAcc& acc, const std::vector<Eigen::Vector2d>& loop);
  Eigen::Vector3d closestAhead(const Eigen::Vector3d& p, std::size_t& seg, double& u) const;
  Eigen::Vector3d drawnPoint(std::size_t seg, double u) const;

  std::vector<Eigen::Vector3d> d_;
  std::size_t maxOverlap_;
  std::size_t seg_ = 0;
  double u_ = 0.0;
  bool started_ = false, finished_ = false, exact_ = true;
  Eigen::Vector3d lastCut_ = Eigen::Vector3d::Zero(), p_ = Eigen::Vector3d::Zero();
  PlaneAcc planes_[3];
  Deviation value_;
};

struct SeriesPoint {
  double t = 0.0;
  Metrics m;
};

class LiveMetrics {
 public:
  LiveMetrics(Polyline drawn, const MetricSettings& settings = {}, double seriesInterval = 0.05);
  void start(double t);
  void addTip(const TipSample& s);
  void addContact(const ContactSample& s);
  void addCutPoint(double t, const Eigen::Vector3d& p);
  void endCutPiece();  // the last cut point ends a piece (contact lost)
  void addPathCrossing(double t);
  void addGrasp(const ForceSample& s);
  // Values now (the live deviation; the contact time counts the open dwell so far).
  [[nodiscard]] Metrics current() const;
  // Closes everything at tEnd; the deviation then is the exact batch value.
  Metrics finish(double tEnd);
  [[nodiscard]] const std::vector<SeriesPoint>& series() const { return series_; }
  [[nodiscard]] const LiveDeviation& liveDeviation() const { return dev_; }
  [[nodiscard]] const Polyline& cut() const { return cut_; }

 private:
  void touch(double t);
  void addCutSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

  Polyline drawn_;
  MetricSettings s_;
  double interval_;
  LiveDeviation dev_;
  DwellTracker dwell_;
  Polyline cut_;
  double t0_ = 0.0, tNow_ = 0.0, lastSeries_ = -1e300;
  bool started_ = false;
  int pathBreaks_ = 0;
  // stretch force
  double fIntegral_ = 0.0, fTime_ = 0.0, fMax_ = 0.0;
  ForceSample lastForce_;
  bool haveForce_ = false;
  // tips
  double len_[2] = {0.0, 0.0};
  Eigen::Vector3d lastTip_[2];
  bool haveTip_[2] = {false, false};
  // cut distance and band coverage
  double distIntegral_ = 0.0, distLength_ = 0.0, distMax_ = 0.0, distPointSum_ = 0.0;
  std::vector<std::vector<std::pair<double, double>>> coverage_;  // per drawn segment
  std::vector<double> coveredLen_;
  double coveredTotal_ = 0.0, drawnLength_ = 0.0;
  std::vector<SeriesPoint> series_;
};

}  // namespace ld::curriculum
