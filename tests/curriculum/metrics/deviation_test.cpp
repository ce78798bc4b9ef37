#include "curriculum/metrics/deviation.h"

#include <random>

#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

using V = Eigen::Vector3d;

Polyline line(std::initializer_list<V> pts) { return makePolyline(std::vector<V>(pts)); }

Polyline reversed(const Polyline& p) {
  std::vector<V> pts;
  for (auto it = p.rbegin(); it != p.rend(); ++it) pts.push_back(it->p);
  return makePolyline(pts);
}

TEST(Deviation, IdenticalPathsGiveZero) {
  const Polyline d = line({V(0, 0, 2.5), V(10, 3, 2.5), V(20, -4, 3.0), V(30, 0, 1.0)});
  const Deviation dev = deviation(d, d);
  EXPECT_TRUE(test::near(dev.total(), 0.0, 1e-9));
  // The same curve sampled differently is still the same curve.
  const Deviation dev2 = deviation(d, densify(d, 0.7));
  EXPECT_TRUE(test::near(dev2.total(), 0.0, 1e-9));
}

TEST(Deviation, ParallelOffsetGivesOffsetTimesLength) {
  const double L = 37.0, dy = 1.5, dz = 0.75;
  const Polyline d = line({V(0, 0, 0), V(L, 0, 0)});
  const Polyline a = line({V(0, dy, dz), V(L * 0.3, dy, dz), V(L, dy, dz)});
  const Deviation dev = deviation(d, a);
  EXPECT_TRUE(test::near(dev.xy, dy * L, 1e-9));
  EXPECT_TRUE(test::near(dev.xz, dz * L, 1e-9));
  // In YZ the four points fold onto a segment: no area.
  EXPECT_TRUE(test::near(dev.yz, 0.0, 1e-9));
  EXPECT_TRUE(test::near(dev.total(), (dy + dz) * L, 1e-9));
}

TEST(Deviation, CrossingSegmentsAddBothTriangles) {
  const Polyline d = line({V(0, 0, 0), V(10, 10, 0)});
  const Polyline a = line({V(0, 10, 0), V(10, 0, 0)});
  // Two triangles of 25 mm² each; a signed area would give 0.
  EXPECT_TRUE(test::near(deviation(d, a).xy, 50.0, 1e-9));
  // Unequal lobes: crossing at x = 2.5 of a 10 mm long pair.
  const Polyline a2 = line({V(0, 1, 0), V(10, -3, 0)});
  const Polyline d2 = line({V(0, 0, 0), V(10, 0, 0)});
  EXPECT_TRUE(test::near(deviation(d2, a2).xy, 0.5 * 2.5 * 1 + 0.5 * 7.5 * 3, 1e-9));
}

TEST(Deviation, ExactOnKnownPolygonShapes) {
  // A cut that leaves the line, runs 2 mm beside it and comes back: a trapezoid.
  const Polyline d = line({V(0, 0, 0), V(20, 0, 0)});
  const Polyline a = line({V(0, 0, 0), V(5, 2, 0), V(15, 2, 0), V(20, 0, 0)});
  EXPECT_TRUE(test::near(deviation(d, a).xy, 2.0 * (10 + 20) / 2, 1e-9));
  // Lobes on both sides add up.
  const Polyline z = line({V(0, 0, 0), V(5, 2, 0), V(10, 0, 0), V(15, -2, 0), V(20, 0, 0)});
  EXPECT_TRUE(test::near(deviation(d, z).xy, 20.0, 1e-9));
}

TEST(Deviation, InvariantUnderReversalResamplingAndCollinearSplits) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-5, 5);
  std::vector<V> dp, ap;
  for (int i = 0; i < 12; ++i) {
    dp.emplace_back(4.0 * i, u(rng), 2.5 + 0.2 * u(rng));
    ap.emplace_back(4.0 * i + 0.5 * u(rng), u(rng), 2.5 + 0.2 * u(rng));
  }
  const Polyline d = makePolyline(dp), a = makePolyline(ap);
  const Deviation ref = deviation(d, a);
  ASSERT_GT(ref.xy, 10.0);
  const Deviation rev = deviation(reversed(d), reversed(a));
  const Deviation res = deviation(densify(d, 0.33), densify(a, 1.1));
  // Split into pieces at points of collinear subdivision: joined by their own segments.
  Polyline split = densify(a, 2.0);
  for (std::size_t i = 1; i + 1 < split.size(); i += 3) split[i].stop = true;
  const Deviation spl = deviation(d, split);
  for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) {
    EXPECT_TRUE(test::near(rev.plane(p), ref.plane(p), 1e-9, 1e-12));
    EXPECT_TRUE(test::near(res.plane(p), ref.plane(p), 1e-9, 1e-12));
    EXPECT_TRUE(test::near(spl.plane(p), ref.plane(p), 1e-9, 1e-12));
  }
}

TEST(Deviation, PiecesAreJoinedInOrderByStraightSegments) {
  // Two pieces of cut, 0..4 and 6..10 at y = 1: joined, the gap is a straight
  // segment at y = 1 too, so the area is that of the full offset.
  Polyline a = line({V(0, 1, 0), V(4, 1, 0), V(6, 1, 0), V(10, 1, 0)});
  a[1].stop = true;
  const Polyline d = line({V(0, 0, 0), V(10, 0, 0)});
  EXPECT_TRUE(test::near(deviation(d, a).xy, 10.0, 1e-9));
}

double gridAbsWinding(const std::vector<Eigen::Vector2d>& loop, int n) {
  Eigen::Vector2d lo = loop[0], hi = loop[0];
  for (const auto& p : loop) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector2d h = (hi - lo) / n;
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector2d p = lo + Eigen::Vector2d((i + 0.5) * h.x(), (j + 0.5) * h.y());
      sum += std::abs(windingNumber(loop, p));
    }
  return sum * h.x() * h.y();
}

TEST(Deviation, AgreesWithFineGridWindingOnRandomPaths) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> u(0, 20);
  for (int trial = 0; trial < 4; ++trial) {
    std::vector<V> dp, ap;
    for (int i = 0; i < 9; ++i) {
      dp.emplace_back(u(rng), u(rng), u(rng));
      ap.emplace_back(u(rng), u(rng), u(rng));
    }
    const Polyline d = makePolyline(dp), a = makePolyline(ap);
    const Deviation exact = deviation(d, a);
    for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) {
      const double grid = gridAbsWinding(deviationLoop(d, a, p), 500);
      EXPECT_TRUE(test::near(exact.plane(p), grid, 0.0, 0.005)) << "trial " << trial << " plane " << int(p);
    }
  }
}

TEST(Deviation, WindingLoopsCountedWithMultiplicity) {
  // A loop going twice around a square has |w| = 2 inside.
  const std::vector<Eigen::Vector2d> twice{{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}, {1, 0}, {1, 1}, {0, 1}};
  EXPECT_TRUE(test::near(absWindingArea(twice), 2.0, 1e-12));
  // Figure eight: two unit squares of opposite orientation.
  const std::vector<Eigen::Vector2d> eight{{0, 0}, {1, 0}, {1, 1}, {2, 1}, {2, 0}, {1, 0}, {1, 1}, {0, 1}};
  EXPECT_TRUE(test::near(absWindingArea(eight), 2.0, 1e-12));
}

TEST(DeviationThesis, AgreesOnSimpleCasesButDependsOnSampling) {
  const Polyline d = line({V(0, 0, 0), V(20, 0, 0)});
  const Polyline offset = line({V(0, 2, 0), V(20, 2, 0)});
  EXPECT_TRUE(test::near(deviationThesis(d, offset).xy, 40.0, 1e-9));
  // A cut that overshoots and comes back: sampling the drawn line more densely
  // changes how the thesis's triangles are stitched, not the area between the curves.
  const Polyline a = line({V(0, 2, 0), V(15, 2, 0), V(10, 4, 0), V(20, 2, 0)});
  const double oursCoarse = deviation(d, a).xy, oursFine = deviation(densify(d, 0.5), densify(a, 0.5)).xy;
  const double thesisCoarse = deviationThesis(d, a).xy, thesisFine = deviationThesis(densify(d, 0.5), a).xy;
  EXPECT_TRUE(test::near(oursCoarse, 45.0, 1e-9));
  EXPECT_TRUE(test::near(oursCoarse, oursFine, 1e-9));
  EXPECT_TRUE(test::near(deviation(densify(d, 0.5), a).xy, oursCoarse, 1e-9));
  EXPECT_GT(std::abs(thesisCoarse - thesisFine), 0.2 * oursCoarse)
      << "thesis coarse " << thesisCoarse << " fine " << thesisFine << " ours " << oursCoarse;
}

}  // namespace
}  // namespace ld::curriculum
