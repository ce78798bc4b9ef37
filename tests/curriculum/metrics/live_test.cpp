#include "curriculum/metrics/live.h"

#include <cmath>
#include <iostream>
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

// The live deviation's tolerance against batch (README): refined cells are exact
// except in sub-cells w changes sign in, and never above the exact value.
constexpr double kLiveRel = 2e-2, kLiveAbs = 5e-3;  // relative, and mm² (per plane)

// The live value against the batch deviation of the cut so far and the drawn path up
// to the progress point, in every plane (it keeps the largest errors).
struct Checker {
  const Polyline& d;
  LiveDeviation live;
  Polyline soFar;
  double worstRel = 0.0, worstAbs = 0.0;
  explicit Checker(const Polyline& drawn, std::size_t maxPieces = LiveDeviation::kMaxPieces)
      : d(drawn), live(drawn, LiveDeviation::kCellMm, 1u << 18, maxPieces) {}
  void add(const V& p, bool check, double relTol, double absTol) {
    live.addCutPoint(p);
    soFar.push_back({p, false});
    if (!check) return;
    Polyline dTrunc;
    for (std::size_t i = 0; i <= live.progressSegment(); ++i) dTrunc.push_back(d[i]);
    dTrunc.push_back({live.progressPoint(), true});
    const Deviation ref = deviation(dTrunc, soFar);
    for (Plane pl : {Plane::XY, Plane::YZ, Plane::XZ}) {
      const double got = live.value().plane(pl), want = ref.plane(pl), err = std::abs(got - want);
      worstAbs = std::max(worstAbs, err);
      if (want > 1e-9) worstRel = std::max(worstRel, err / want);
      ASSERT_TRUE(test::near(got, want, absTol, relTol)) << soFar.size() << " plane " << int(pl);
      // Refined cells count |integral| per sub-cell: never above the exact value.
      ASSERT_LE(got, want + 1e-9 * (1.0 + want)) << soFar.size() << " plane " << int(pl);
    }
  }
};

TEST(LiveMetrics, AgreesWithBatchAtTheEnd) {
  const Polyline d = wavyDrawn();
  for (unsigned seed : {1u, 2u, 3u}) {
    const AttemptEvents ev = noisyAttempt(d, seed);
    LiveMetrics live(d);
    replay(ev, live);
    const Metrics m = live.finish(ev.endTime);
    const Metrics b = computeMetrics(d, ev);
    const Deviation& inc = live.liveDeviation().value();
    for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) {
      // Within the tolerance (refined cells where the cut crowds them), never above.
      EXPECT_TRUE(test::near(inc.plane(p), b.deviation.plane(p), kLiveAbs, kLiveRel)) << "plane " << int(p);
      EXPECT_LE(inc.plane(p), b.deviation.plane(p) * (1 + 1e-9)) << "plane " << int(p);
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

TEST(LiveDeviation, AgreesWithTheDrawnPathUpToTheProgressPointAtEverySample) {
  // Within the tolerance with the default cap; exact to round-off with no cap (every
  // cell by the exact sweep, also where the cut crosses the path).
  const Polyline d = wavyDrawn();
  const AttemptEvents ev = noisyAttempt(d, 5);
  Checker capped(d), exact(d, 1u << 20);
  for (std::size_t k = 0; k < ev.cut.size(); ++k) {
    capped.add(ev.cut[k].p, true, kLiveRel, kLiveAbs);
    exact.add(ev.cut[k].p, k % 3 == 0, 1e-6, 1e-9);
    if (HasFatalFailure()) return;
  }
  EXPECT_TRUE(exact.live.exact());
  EXPECT_GT(capped.live.refinedCells(), 0u);
  std::cout << "noisy attempt: worst relative error " << capped.worstRel << ", absolute " << capped.worstAbs << " mm2 ("
            << capped.live.refinedCells() << " refined cells); uncapped " << exact.worstRel << "\n";
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
  LiveDeviation live(d, LiveDeviation::kCellMm, 1u << 18, 1u << 20);  // no cap: the exact sweep
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

TEST(LiveDeviation, BackAndForthOverOnePlaceStaysWithinToleranceAtEverySample) {
  // A trainee working one place: along 6 mm of a gently curved path, then back and
  // forth over it (passes 0.1 mm apart in y and slightly tilted in z, wobbling), so
  // cells there collect a piece per pass and are refined. Live agrees with the batch
  // value at every sample within the tolerance, and exactly at the end.
  std::vector<V> pts;
  for (int i = 0; i <= 12; ++i) pts.emplace_back(0.5 * i, 0.3 * std::sin(0.4 * i), 0.1 * i);
  const Polyline d = makePolyline(pts);
  Checker c(d);
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0, 0.02);
  const int n = 700;
  for (int k = 0; k <= n; ++k) {
    const double u = std::fmod(0.07 * k, 12.0), x = u < 6.0 ? u : 12.0 - u;
    const int pass = static_cast<int>(0.07 * k / 6.0);
    const V p(x + g(rng), 0.3 * std::sin(0.8 * x) + 0.4 * std::sin(0.9 * x + pass) + g(rng),
              0.2 * x + 0.15 * std::sin(1.3 * x + 0.5 * pass));
    c.add(p, true, kLiveRel, kLiveAbs);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(c.live.refinedCells(), 20u);  // the fallback was exercised
  EXPECT_FALSE(c.live.exact());
  c.live.finish();
  // What LiveMetrics reports at the end is the batch value; the live one is close.
  const Deviation b = deviation(d, c.soFar);
  EXPECT_TRUE(test::near(c.live.value().total(), b.total(), kLiveAbs, kLiveRel));
  std::cout << "back and forth: worst relative error " << c.worstRel << ", absolute " << c.worstAbs << " mm2, "
            << c.live.refinedCells() << " refined cells\n";
}

TEST(LiveDeviation, ExactCellsWithoutACapAgreeToRoundOff) {
  // The same stream with no cap on the pieces: the exact per-cell sweep everywhere.
  std::vector<V> pts;
  for (int i = 0; i <= 12; ++i) pts.emplace_back(0.5 * i, 0.3 * std::sin(0.4 * i), 0.1 * i);
  const Polyline d = makePolyline(pts);
  Checker c(d, 1u << 20);
  for (int k = 0; k <= 300; ++k) {
    const double u = std::fmod(0.07 * k, 12.0), x = u < 6.0 ? u : 12.0 - u;
    const V p(x, 0.3 * std::sin(0.8 * x) + 0.4 * std::sin(0.9 * x + k / 86), 0.2 * x);
    c.add(p, k % 5 == 0, 1e-6, 1e-9);
    if (HasFatalFailure()) return;
  }
  EXPECT_EQ(c.live.refinedCells(), 0u);
  EXPECT_TRUE(c.live.exact());
}

TEST(LiveDeviation, DenseZigzagAcrossThePathAtEverySample) {
  // Crossing the path every 0.6 mm at 1 kHz density (8 µm steps, as at 8 mm/s): the
  // cells along the cut collect its many short pieces and are refined; w changes sign
  // at the crossings (and everywhere in the YZ plane, where the zigzag folds onto itself), so live stays within the
  // tolerance of batch at every sample.
  const Polyline d = makePolyline({V(0, 0.05, 0), V(3, -0.05, 0.2), V(6, 0.1, 0)});
  Checker c(d);
  for (int k = 0; k <= 600; ++k) {
    const double x = 0.008 * k, tri = std::abs(std::fmod(x / 0.6, 2.0) - 1.0);
    c.add(V(x, 0.7 * (tri - 0.5), 0.04 * std::sin(3 * x)), true, kLiveRel, kLiveAbs);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(c.live.refinedCells(), 10u);
  c.live.finish();
  EXPECT_TRUE(test::near(c.live.value().xy, deviation(d, c.soFar).xy, kLiveAbs, kLiveRel));
  // Uncapped, the same stream is exact to round-off.
  Checker e(d, 1u << 20);
  for (int k = 0; k <= 600; ++k) {
    const double x = 0.008 * k, tri = std::abs(std::fmod(x / 0.6, 2.0) - 1.0);
    e.add(V(x, 0.7 * (tri - 0.5), 0.04 * std::sin(3 * x)), k % 10 == 0, 1e-6, 1e-9);
    if (HasFatalFailure()) return;
  }
  EXPECT_TRUE(e.live.exact());
  std::cout << "zigzag: worst relative error " << c.worstRel << " (refined), " << e.worstRel << " (uncapped)\n";
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
