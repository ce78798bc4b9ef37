#include "curriculum/metrics/metrics.h"

#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

using V = Eigen::Vector3d;

TEST(ContactTime, DwellEndsWhereTheContactLeavesTheRadius) {
  // Moving along x at 2 mm/s then 1 mm/s: leaves the 2 mm ball around (0,0,0) at
  // x = 2, t = 1.5; contact lost at t = 3. Then a still contact from 4 to 5.
  std::vector<ContactSample> c{{0.0, true, V(0, 0, 0)}, {1.0, true, V(1, 0, 0)}, {2.0, true, V(3, 0, 0)},
                               {3.0, false, V::Zero()}, {4.0, true, V(9, 9, 0)}, {5.0, false, V::Zero()}};
  const ContactTime ct = contactTime(c, 2.0, 6.0);
  EXPECT_EQ(ct.dwells, 3);
  EXPECT_TRUE(test::near(ct.maxS, 1.5, 1e-12));
  EXPECT_TRUE(test::near(ct.meanS, (1.5 + 1.5 + 1.0) / 3, 1e-12));
  EXPECT_TRUE(test::near(ct.totalS, 4.0, 1e-12));
  EXPECT_EQ(contactBreaks(c), 1);
}

TEST(ContactTime, IndependentOfSamplingForStraightMotion) {
  // 1 mm/s for 10 s with a 2 mm radius: five dwells of 2 s at any sampling rate.
  for (int hz : {3, 10, 100, 1000}) {
    std::vector<ContactSample> c;
    for (int i = 0; i <= 10 * hz; ++i) c.push_back({double(i) / hz, true, V(double(i) / hz, 0, 0)});
    c.push_back({10.0, false, V::Zero()});
    const ContactTime ct = contactTime(c, 2.0, 10.0);
    EXPECT_EQ(ct.dwells, 5) << hz;
    EXPECT_TRUE(test::near(ct.meanS, 2.0, 1e-9)) << hz;
    EXPECT_TRUE(test::near(ct.maxS, 2.0, 1e-9)) << hz;
    EXPECT_TRUE(test::near(ct.totalS, 10.0, 1e-9)) << hz;
  }
}

TEST(ContactTime, OpenContactClosesAtTheEnd) {
  std::vector<ContactSample> c{{1.0, true, V(0, 0, 0)}, {2.0, true, V(0.5, 0, 0)}};
  const ContactTime ct = contactTime(c, 2.0, 4.0);
  EXPECT_EQ(ct.dwells, 1);
  EXPECT_TRUE(test::near(ct.totalS, 3.0, 1e-12));
  EXPECT_EQ(contactBreaks(c), 0);
}

TEST(ContactBreaks, CountsLossesFollowedByRegain) {
  std::vector<ContactSample> c;
  const bool pattern[] = {false, true, true, false, true, false, false, true, false};
  for (int i = 0; i < 9; ++i) c.push_back({double(i), pattern[i], V::Zero()});
  EXPECT_EQ(contactBreaks(c), 2);  // three contact intervals
}

TEST(StretchForce, TimeWeightedMeanAndMax) {
  std::vector<ForceSample> g{
      {0.0, 2.0, true}, {2.0, 2.0, true}, {3.0, 4.0, true}, {3.5, 9.0, false}, {4.0, 1.0, false}};
  double mean = 0, max = 0;
  stretchForce(g, mean, max);
  EXPECT_TRUE(test::near(mean, (2.0 * 2 + 3.0 * 1) / 3.0, 1e-12));
  EXPECT_TRUE(test::near(max, 4.0, 1e-12));  // not grasping at 9 N
}

TEST(PathLength, PerHand) {
  std::vector<TipSample> t{{0, HandSide::Left, V(0, 0, 0)},
                           {0, HandSide::Right, V(100, 0, 0)},
                           {1, HandSide::Left, V(3, 4, 0)},
                           {1, HandSide::Right, V(101, 0, 0)},
                           {2, HandSide::Left, V(3, 4, 12)}};
  EXPECT_TRUE(test::near(pathLength(t, HandSide::Left), 17.0, 1e-12));
  EXPECT_TRUE(test::near(pathLength(t, HandSide::Right), 1.0, 1e-12));
}

TEST(CutDistance, MeanAlongTheCutAndMax) {
  const Polyline d = makePolyline({V(0, 0, 0), V(10, 0, 0)});
  double mean, max;
  cutDistance(d, makePolyline({V(0, 1, 0), V(10, 1, 0)}), 0.25, mean, max);
  EXPECT_TRUE(test::near(mean, 1.0, 1e-12));
  EXPECT_TRUE(test::near(max, 1.0, 1e-12));
  // Distance growing linearly from 0 to 2 (3-D: up in z).
  cutDistance(d, makePolyline({V(0, 0, 0), V(10, 0, 2)}), 0.25, mean, max);
  EXPECT_TRUE(test::near(mean, 1.0, 1e-3));
  EXPECT_TRUE(test::near(max, 2.0, 1e-3));
  // Length-weighted: dense points near the line do not drag the mean down.
  Polyline dense = densify(makePolyline({V(0, 1, 0), V(10, 1, 0)}), 0.01);
  cutDistance(d, dense, 0.25, mean, max);
  EXPECT_TRUE(test::near(mean, 1.0, 1e-9));
}

TEST(BandFraction, CoveredLengthWithinTheBand) {
  const Polyline d = makePolyline({V(0, 0, 0), V(10, 0, 0)});
  // Cut at y = 1 over x in [0, 5]: covers x in [0, 5 + sqrt(3)] with a 2 mm band.
  EXPECT_TRUE(
      test::near(bandFraction(d, makePolyline({V(0, 1, 0), V(5, 1, 0)}), 2.0), (5 + std::sqrt(3.0)) / 10, 1e-9));
  // Too far away: nothing.
  EXPECT_TRUE(test::near(bandFraction(d, makePolyline({V(0, 3, 0), V(10, 3, 0)}), 2.0), 0.0, 1e-12));
  // Two pieces (the join is not a cut): x in [0,2] and [8,10] at y = 0.
  Polyline two = makePolyline({V(0, 0, 0), V(2, 0, 0), V(8, 0, 0), V(10, 0, 0)});
  two[1].stop = true;
  EXPECT_TRUE(test::near(bandFraction(d, two, 1.0), 0.6, 1e-9));
}

TEST(Metrics, FromAConstructedAttempt) {
  const Polyline d = makePolyline({V(0, 0, 2.5), V(20, 0, 2.5)});
  AttemptEvents ev;
  ev.startTime = 0.0;
  ev.endTime = 12.0;
  ev.cut = makePolyline({V(0, 1, 2.5), V(20, 1, 2.5)});
  ev.pathCrossings = {3.0, 7.5};
  ev.contacts = {{1.0, true, V(0, 1, 2.5)}, {10.5, true, V(19, 1, 2.5)}, {11.0, false, V::Zero()}};
  ev.grasp = {{0.0, 1.0, true}, {12.0, 1.0, true}};
  ev.tips = {{0, HandSide::Right, V(0, 0, 10)}, {12, HandSide::Right, V(0, 0, 20)}};
  const Metrics m = computeMetrics(d, ev, {});
  EXPECT_TRUE(test::near(m.deviation.xy, 20.0, 1e-9));
  EXPECT_EQ(m.pathBreaks, 2);
  EXPECT_EQ(m.contactBreaks, 0);
  EXPECT_TRUE(test::near(m.totalTimeS, 12.0, 1e-12));
  EXPECT_TRUE(test::near(m.contact.totalS, 10.0, 1e-12));
  EXPECT_EQ(m.contact.dwells, 10);  // 2 mm steps at 2 mm/s, exits at t = 2..10, loss at 11
  EXPECT_TRUE(test::near(m.contact.maxS, 1.0, 1e-9));
  EXPECT_TRUE(test::near(m.bandFraction, 1.0, 1e-12));
  EXPECT_TRUE(test::near(m.cutDistanceMeanMm, 1.0, 1e-12));
  EXPECT_TRUE(test::near(m.stretchMeanN, 1.0, 1e-12));
  EXPECT_TRUE(test::near(m.pathLengthRightMm, 10.0, 1e-12));
  EXPECT_TRUE(test::near(m.pathLengthLeftMm, 0.0, 1e-12));
}

}  // namespace
}  // namespace ld::curriculum
