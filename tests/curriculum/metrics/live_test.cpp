#include "curriculum/metrics/live.h"

#include <cmath>
#include <random>

#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

using V = Eigen::Vector3d;

Polyline wavyDrawn() {
  std::vector<V> pts;
  for (int i = 0; i <= 40; ++i) pts.emplace_back(-30 + 1.5 * i, 8 * std::sin(0.12 * i), 2.5 + 0.3 * std::cos(0.2 * i));
  return makePolyline(pts);
}

// A cut that follows the drawn path with smooth lateral error, lifts twice.
AttemptEvents noisyAttempt(const Polyline& d, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ph(0, 6.28);
  const double p1 = ph(rng), p2 = ph(rng);
  AttemptEvents ev;
  ev.startTime = 0.0;
  const int n = 400;
  for (int k = 0; k <= n; ++k) {
    const double s = double(k) / n * (d.size() - 1);
    const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(s), d.size() - 2);
    const V base = d[i].p + (s - i) * (d[i + 1].p - d[i].p);
    const V p = base + V(0.4 * std::sin(0.05 * k + p1), 2.0 * std::sin(0.031 * k + p2) + 0.6 * std::sin(0.17 * k),
                         0.2 * std::sin(0.07 * k));
    const double t = 0.05 * k;
    const bool lifted = (k > 120 && k < 130) || (k > 300 && k < 304);
    ev.contacts.push_back({t, !lifted, p});
    if (!lifted) {
      ev.cut.push_back({p, false});
    } else if (!ev.cut.empty()) {
      ev.cut.back().stop = true;
    }
    ev.tips.push_back({t, HandSide::Right, p + V(0, 0, 1)});
    ev.tips.push_back({t, HandSide::Left, V(-35, 0.1 * k, 8)});
    ev.grasp.push_back({t, 1.0 + 0.5 * std::sin(0.1 * k), k > 20});
    if (k == 200) ev.pathCrossings.push_back(t);
  }
  ev.endTime = 0.05 * n;
  return ev;
}

void replay(const AttemptEvents& ev, LiveMetrics& live) {
  live.start(ev.startTime);
  std::size_t ci = 0;
  for (std::size_t k = 0; k < ev.contacts.size(); ++k) {
    const auto& c = ev.contacts[k];
    live.addContact(c);
    if (c.contact) {
      live.addCutPoint(c.t, ev.cut[ci].p);
      if (ev.cut[ci].stop) live.endCutPiece();
      ++ci;
    }
    live.addTip(ev.tips[2 * k]);
    live.addTip(ev.tips[2 * k + 1]);
    live.addGrasp(ev.grasp[k]);
    for (double t : ev.pathCrossings)
      if (t == c.t) live.addPathCrossing(t);
  }
}

TEST(LiveMetrics, AgreesWithBatchAtTheEnd) {
  const Polyline d = wavyDrawn();
  for (unsigned seed : {1u, 2u, 3u}) {
    const AttemptEvents ev = noisyAttempt(d, seed);
    LiveMetrics live(d);
    replay(ev, live);
    const Metrics m = live.finish(ev.endTime);
    const Metrics b = computeMetrics(d, ev);
    const Deviation& inc = live.liveDeviation().value();
    EXPECT_TRUE(live.liveDeviation().exact());
    for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) {
      // Exact, also in the cells where the cut crosses the path.
      EXPECT_TRUE(test::near(inc.plane(p), b.deviation.plane(p), 1e-9, 1e-6)) << "plane " << int(p);
      // What LiveMetrics reports at the end is the batch value.
      EXPECT_TRUE(test::near(m.deviation.plane(p), b.deviation.plane(p), 1e-9));
    }
    EXPECT_GT(b.deviation.xy, 10.0);
    EXPECT_TRUE(test::near(m.contact.meanS, b.contact.meanS, 1e-12));
    EXPECT_TRUE(test::near(m.contact.maxS, b.contact.maxS, 1e-12));
    EXPECT_TRUE(test::near(m.contact.totalS, b.contact.totalS, 1e-12));
    EXPECT_EQ(m.contactBreaks, b.contactBreaks);
    EXPECT_EQ(m.contactBreaks, 2);
    EXPECT_EQ(m.pathBreaks, 1);
    EXPECT_TRUE(test::near(m.totalTimeS, b.totalTimeS, 1e-12));
    EXPECT_TRUE(test::near(m.stretchMeanN, b.stretchMeanN, 1e-12));
    EXPECT_TRUE(test::near(m.stretchMaxN, b.stretchMaxN, 1e-12));
    EXPECT_TRUE(test::near(m.cutDistanceMeanMm, b.cutDistanceMeanMm, 1e-9));
    EXPECT_TRUE(test::near(m.cutDistanceMaxMm, b.cutDistanceMaxMm, 1e-12));
    EXPECT_TRUE(test::near(m.bandFraction, b.bandFraction, 1e-9));
    EXPECT_TRUE(test::near(m.pathLengthLeftMm, b.pathLengthLeftMm, 1e-9));
    EXPECT_TRUE(test::near(m.pathLengthRightMm, b.pathLengthRightMm, 1e-9));
    // The series covers the attempt in time order.
    ASSERT_GT(live.series().size(), 100u);
    for (std::size_t i = 1; i < live.series().size(); ++i) EXPECT_GE(live.series()[i].t, live.series()[i - 1].t);
    EXPECT_TRUE(test::near(live.series().back().t, ev.endTime, 1e-12));
  }
}

TEST(LiveDeviation, ExactAgainstTheDrawnPathUpToTheProgressPoint) {
  const Polyline d = wavyDrawn();
  const AttemptEvents ev = noisyAttempt(d, 5);
  LiveDeviation live(d);
  Polyline soFar;
  int checked = 0;
  for (std::size_t k = 0; k < ev.cut.size(); ++k) {
    live.addCutPoint(ev.cut[k].p);
    soFar.push_back({ev.cut[k].p, false});
    if (k % 7 != 3) continue;
    // The drawn path truncated at the progress point.
    Polyline dTrunc;
    for (std::size_t i = 0; i <= live.progressSegment(); ++i) dTrunc.push_back(d[i]);
    dTrunc.push_back({live.progressPoint(), true});
    const Deviation ref = deviation(dTrunc, soFar);
    for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ})
      EXPECT_TRUE(test::near(live.value().plane(p), ref.plane(p), 1e-9, 1e-6)) << k << " plane " << int(p);
    ++checked;
  }
  EXPECT_GT(checked, 40);
}

TEST(LiveDeviation, ExactWhereTheCutStaysOnOneSide) {
  // No crossing: w keeps one sign, the grid sums are exact at every point.
  const Polyline d = wavyDrawn();
  LiveDeviation live(d);
  Polyline soFar;
  for (int k = 0; k <= 300; ++k) {
    const double s = double(k) / 300 * (d.size() - 1);
    const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(s), d.size() - 2);
    const V p = d[i].p + (s - i) * (d[i + 1].p - d[i].p) + V(0, 0.8 + 0.5 * std::sin(0.05 * k), 0);
    live.addCutPoint(p);
    soFar.push_back({p, false});
    if (k % 50 != 25) continue;
    Polyline dTrunc;
    for (std::size_t j = 0; j <= live.progressSegment(); ++j) dTrunc.push_back(d[j]);
    dTrunc.push_back({live.progressPoint(), true});
    EXPECT_TRUE(test::near(live.value().xy, deviation(dTrunc, soFar).xy, 1e-7, 1e-9)) << k;
  }
}

TEST(LiveDeviation, CellIntegralsAddUpToTheSignedArea) {
  // A lone square (w = +1 inside) and an hourglass (two lobes of opposite sign): the
  // grid sum of |cell| equals ∫|w| when no cell holds both signs.
  const Polyline d = makePolyline({V(0, 0, 0), V(4, 0, 0)});
  LiveDeviation a(d, 0.5);
  a.addCutPoint(V(0, 3, 0));
  a.addCutPoint(V(4, 3, 0));
  a.finish();
  EXPECT_TRUE(test::near(a.value().xy, 12.0, 1e-9));
  LiveDeviation b(d, 0.5);
  b.addCutPoint(V(0, 2, 0));
  b.addCutPoint(V(4, -2, 0));
  b.finish();
  EXPECT_TRUE(test::near(b.value().xy, deviation(d, makePolyline({V(0, 2, 0), V(4, -2, 0)})).xy, 1e-9));
  EXPECT_TRUE(test::near(b.value().xy, 4.0, 1e-9));  // two triangles 2 x 2 / 2
}

TEST(LiveDeviation, ExactInCellsWhereTheCutCrossesThePath) {
  // A zigzag across a straight path at odd angles (and on cell borders: y = 0 is one),
  // crossing it inside cells: live equals the batch value at every point.
  const Polyline d = makePolyline({V(0, 0, 0), V(5, 0, 0), V(10, 0, 0)});
  LiveDeviation live(d);
  Polyline soFar;
  for (int k = 0; k <= 60; ++k) {
    const V p(0.163 * k, (k % 2 ? 0.37 : -0.29) + 0.01 * k, 0.05 * std::sin(0.3 * k));
    live.addCutPoint(p);
    soFar.push_back({p, false});
    Polyline dTrunc;
    for (std::size_t i = 0; i <= live.progressSegment(); ++i) dTrunc.push_back(d[i]);
    dTrunc.push_back({live.progressPoint(), true});
    const Deviation ref = deviation(dTrunc, soFar);
    for (Plane pl : {Plane::XY, Plane::XZ})
      EXPECT_TRUE(test::near(live.value().plane(pl), ref.plane(pl), 1e-9, 1e-6)) << k << " plane " << int(pl);
  }
  live.finish();
  EXPECT_TRUE(test::near(live.value().xy, deviation(d, soFar).xy, 1e-9, 1e-6));
}

TEST(LiveDeviation, ParallelOffsetGrowsLinearly) {
  const Polyline d = makePolyline({V(0, 0, 0), V(10, 0, 0), V(20, 0, 0)});
  LiveDeviation live(d);
  for (int i = 0; i <= 20; ++i) {
    live.addCutPoint(V(i, 1.5, 0));
    EXPECT_TRUE(test::near(live.value().xy, 1.5 * i, 1e-9)) << i;
  }
  live.finish();
  EXPECT_TRUE(test::near(live.value().xy, 30.0, 1e-9));
}

}  // namespace
}  // namespace ld::curriculum
