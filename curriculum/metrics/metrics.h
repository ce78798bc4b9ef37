#pragma once
// The assessment metrics of DESIGN.md computed from an attempt's event stream
// (contacts of the cutting instrument, cut points, path crossings, grasper forces,
// instrument tips). Plain C++ and Eigen: the simulation loop's observers and the
// headless task runner both fill AttemptEvents.
#include <vector>

#include <Eigen/Core>

#include "curriculum/metrics/deviation.h"
#include "curriculum/metrics/polyline.h"

namespace ld::curriculum {

struct MetricSettings {
  double contactRadius = 2.0;  // mm: a dwell ends when the contact moves this far
  double band = 2.0;           // mm: the drawn path counts as cut where the cut is this close
  double distanceStep = 0.25;  // mm: integration step for the mean cut distance
};

// Contact of the cutting instrument with tissue. A contact interval runs from its
// first sample with contact = true to the first sample with contact = false.
struct ContactSample {
  double t = 0.0;
  bool contact = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
};

struct ForceSample {
  double t = 0.0;
  double force = 0.0;  // N, magnitude of the grasper's stretch force
  bool grasping = false;
};

enum class HandSide { Left = 0, Right = 1 };

struct TipSample {
  double t = 0.0;
  HandSide hand = HandSide::Right;
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
};

struct AttemptEvents {
  double startTime = 0.0, endTime = 0.0;
  std::vector<ContactSample> contacts;
  Polyline cut;                       // cut points, stop at every loss of contact
  std::vector<double> pathCrossings;  // times the cut crossed the drawn path
  std::vector<ForceSample> grasp;
  std::vector<TipSample> tips;
};

struct ContactTime {
  double meanS = 0.0, maxS = 0.0, totalS = 0.0;
  int dwells = 0;
};

struct Metrics {
  Deviation deviation;
  Deviation deviationThesis;
  bool noCut = false;  // nothing was cut: deviation is deviationWithoutCut()
  ContactTime contact;
  int contactBreaks = 0;
  int pathBreaks = 0;
  double totalTimeS = 0.0;
  double stretchMeanN = 0.0, stretchMaxN = 0.0;
  double cutDistanceMeanMm = 0.0, cutDistanceMaxMm = 0.0;
  double bandFraction = 0.0;  // of the drawn path's length
  double pathLengthLeftMm = 0.0, pathLengthRightMm = 0.0;
};

// Dwell bookkeeping (thesis 6.2.2), shared by the batch and live computations. The
// motion between two contact samples is taken as straight, so the moment the contact
// leaves the reference ball is found exactly, whatever the sampling rate.
class DwellTracker {
 public:
  explicit DwellTracker(double radius) : radius_(radius) {}
  void add(const ContactSample& s);
  void finish(double tEnd);  // closes an open dwell and contact interval
  [[nodiscard]] ContactTime result() const;
  [[nodiscard]] int contactIntervals() const { return intervals_; }
  [[nodiscard]] bool inContact() const { return inContact_; }

 private:
  void closeDwell(double t);
  double radius_;
  bool inContact_ = false;
  Eigen::Vector3d ref_ = Eigen::Vector3d::Zero(), last_ = Eigen::Vector3d::Zero();
  double tRef_ = 0.0, tLast_ = 0.0, tStart_ = 0.0;
  double sum_ = 0.0, max_ = 0.0, total_ = 0.0;
  int count_ = 0, intervals_ = 0;
};

ContactTime contactTime(const std::vector<ContactSample>& contacts, double radius, double tEnd);
// Times contact was lost and later regained.
int contactBreaks(const std::vector<ContactSample>& contacts);
// Time-weighted (trapezoid) mean over the time the grasper holds tissue, and the max.
void stretchForce(const std::vector<ForceSample>& grasp, double& mean, double& max);
double pathLength(const std::vector<TipSample>& tips, HandSide hand);

double pointSegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b);
double distanceToPath(const Eigen::Vector3d& p, const Polyline& path);  // to its pieces
// Mean distance along the cut's pieces (length-weighted) and the max, to the drawn
// path's pieces. An attempt without cut length averages its points.
void cutDistance(const Polyline& drawn, const Polyline& cut, double step, double& mean, double& max);
// The parameter interval of [a,b] within `band` of segment [c,d] (convex in t), or
// false when none.
bool bandInterval(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector3d& d, double band, double& t0, double& t1);
// Fraction of the drawn path's piece length within `band` of the cut's pieces.
double bandFraction(const Polyline& drawn, const Polyline& cut, double band);

Metrics computeMetrics(const Polyline& drawn, const AttemptEvents& events, const MetricSettings& settings = {});

}  // namespace ld::curriculum
