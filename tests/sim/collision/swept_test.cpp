#include "sim/collision/swept.h"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "tests/sim/collision/test_meshes.h"
#include "tests/support/test_support.h"

namespace ld::collision {
namespace {

using Eigen::Vector3d;
using mesh::Face;

// Faces touched by the segment at `samples + 1` evenly spaced times between the two
// poses: what a dense sampler would find.
// (The BVH query equals brute force: bvh_test.cpp.)
std::set<Face> denseFaces(const mesh::SurfaceMesh& m, const Vector3d& a0, const Vector3d& b0, const Vector3d& a1,
                          const Vector3d& b1, int samples) {
  const TriangleBvh bvh(m);
  std::set<Face> out;
  std::vector<SurfaceHit> hits;
  for (int i = 0; i <= samples; ++i) {
    const double s = static_cast<double>(i) / samples;
    bvh.intersectSegment(m, a0 + s * (a1 - a0), b0 + s * (b1 - b0), hits);
    for (const SurfaceHit& h : hits) out.insert(h.face);
  }
  return out;
}

::testing::AssertionResult covers(const std::vector<Face>& swept, const std::set<Face>& dense) {
  for (Face f : dense)
    if (!std::binary_search(swept.begin(), swept.end(), f))
      return ::testing::AssertionFailure() << "face " << f << " hit by a dense sample is missing from the swept result";
  return ::testing::AssertionSuccess();
}

TEST(Swept, FastStrokeBetweenTwoSamplesMissesNoTriangle) {
  const auto m = testing::grid(8);
  const TriangleBvh bvh(m);
  // A vertical blade moves 7 mm across the sheet in one sample.
  const Vector3d a0(0.5, 3.3, 1), b0(0.5, 3.3, -1), a1(7.5, 3.3, 1), b1(7.5, 3.3, -1);
  const SweptContacts s = sweepSegment(m, &bvh, a0, b0, a1, b1);
  // Only the two samples' faces would be found without the swept test.
  EXPECT_EQ(s.before.size(), 1u);
  EXPECT_EQ(s.after.size(), 1u);
  // Every mesh edge the line y = 3.3 crosses between x = 0.5 and 7.5, from the geometry:
  int expectedEdges = 0;
  for (mesh::Edge e : m.edges()) {
    const Vector3d p = m.position(m.vertex(e, 0)), q = m.position(m.vertex(e, 1));
    if ((p.y() - 3.3) * (q.y() - 3.3) < 0) {
      const double x = p.x() + (3.3 - p.y()) / (q.y() - p.y()) * (q.x() - p.x());
      if (x > 0.5 && x < 7.5) ++expectedEdges;
    }
  }
  EXPECT_EQ(static_cast<int>(s.edgeCrossings.size()), expectedEdges);
  for (std::size_t i = 0; i < s.edgeCrossings.size(); ++i) {
    const auto& c = s.edgeCrossings[i];
    EXPECT_TRUE(ld::test::near(c.point.y(), 3.3, 1e-12));
    EXPECT_TRUE(ld::test::near(c.time, (c.point.x() - 0.5) / 7.0, 1e-9));  // ordered by time = by x
    EXPECT_TRUE(ld::test::near(c.along, 0.5, 1e-9));                       // the sheet is halfway down the blade
    const Vector3d onEdge =
        m.position(m.vertex(c.edge, 0)) + c.edgeT * (m.position(m.vertex(c.edge, 1)) - m.position(m.vertex(c.edge, 0)));
    EXPECT_TRUE(ld::test::nearVec(onEdge, c.point, 1e-9));
    if (i > 0) {
      EXPECT_GE(c.time, s.edgeCrossings[i - 1].time);
    }
  }
  const auto dense = denseFaces(m, a0, b0, a1, b1, 2000);
  EXPECT_TRUE(covers(s.faces, dense));
  EXPECT_EQ(s.faces.size(), dense.size());  // and nothing else in this generic position
}

TEST(Swept, SlideInWithTheTipOutsideIsCaught) {
  const auto m = testing::grid(8);
  const TriangleBvh bvh(m);
  // The blade lies across the whole sheet, above it, then below it: neither sample
  // nor the paths of its ends (outside the sheet) touch anything.
  const Vector3d a0(-1, 3.3, 0.5), b0(9, 3.7, 0.5), a1(-1, 3.3, -0.5), b1(9, 3.7, -0.5);
  const SweptContacts s = sweepSegment(m, &bvh, a0, b0, a1, b1);
  EXPECT_TRUE(s.before.empty());
  EXPECT_TRUE(s.after.empty());
  EXPECT_TRUE(s.pathA.empty());
  EXPECT_TRUE(s.pathB.empty());
  EXPECT_FALSE(s.edgeCrossings.empty());
  EXPECT_TRUE(covers(s.faces, denseFaces(m, a0, b0, a1, b1, 2000)));
  for (const auto& c : s.edgeCrossings) EXPECT_TRUE(ld::test::near(c.time, 0.5, 1e-9));
}

TEST(Swept, BvhAndBruteForceAgreeAndDenseSamplingIsCoveredForRandomMotions) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (const auto& m : {testing::slab(6, 1.0, 2.0), testing::icosphere(2, 2.0)}) {
    const TriangleBvh bvh(m);
    for (int i = 0; i < testing::scaled(40); ++i) {
      const Vector3d c(3 * U(rng) + (m.bounds().center().x()), 3 * U(rng) + m.bounds().center().y(), U(rng));
      const Vector3d dir = Vector3d(0.4 * U(rng), 0.4 * U(rng), -1).normalized();
      const Vector3d a0 = c - 2.5 * dir, b0 = c + 2.5 * dir;
      // Translation plus a rotation (twist) of up to ~30 degrees between the samples.
      const Vector3d move(2 * U(rng), 2 * U(rng), 0.5 * U(rng));
      const Vector3d turn = 0.5 * Vector3d(U(rng), U(rng), 0);
      const Vector3d a1 = a0 + move + turn, b1 = b0 + move - turn;
      const SweptContacts fast = sweepSegment(m, &bvh, a0, b0, a1, b1);
      const SweptContacts brute = sweepSegment(m, nullptr, a0, b0, a1, b1);
      ASSERT_EQ(fast.faces, brute.faces) << i;
      ASSERT_EQ(fast.edgeCrossings.size(), brute.edgeCrossings.size()) << i;
      EXPECT_TRUE(covers(fast.faces, denseFaces(m, a0, b0, a1, b1, 400))) << "motion " << i;
    }
  }
}

// The swept test through a tree that followed cutting edits locally (faces split,
// slivers, leaves split in place): the same faces as brute force, and every face a
// dense sampler finds. Instrument scale: a 20 mm blade crossing a fine sheet fast.
TEST(Swept, AfterLocalEditsTheTreeStillMissesNothing) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> U(-1.0, 1.0), W(0.05, 0.95);
  mesh::SurfaceMesh m = testing::grid(24, 0.5);  // 12 x 12 mm
  TriangleBvh bvh(m);
  for (int i = 0; i < 400; ++i) {
    const Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
    if (!m.isValid(f)) continue;
    const auto& vs = m.vertices(f);
    double u = W(rng), v = W(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;
    m.splitFace(f, m.position(vs[0]) + u * (m.position(vs[1]) - m.position(vs[0])) +
                       v * (m.position(vs[2]) - m.position(vs[0])));
    if (i % 3 == 0) {
      const mesh::Edge e = m.edges(f)[rng() % 3];
      m.splitEdge(e, 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1))));
    }
    if (i % 7 == 0) bvh.sync(m);
  }
  ASSERT_NE(bvh.sync(m), SyncResult::Rebuilt);
  ASSERT_EQ(bvh.check(m), "");
  for (int i = 0; i < testing::scaled(30); ++i) {
    const Vector3d tip(6 + 4 * U(rng), 6 + 4 * U(rng), -5 - 2 * U(rng));
    const Vector3d dir = Vector3d(0.3 * U(rng), 0.3 * U(rng), -1).normalized();
    const Vector3d a0 = tip, b0 = tip - 20.0 * dir;
    const Vector3d move(4 * U(rng), 4 * U(rng), 0.3 * U(rng));
    const Vector3d turn = 0.3 * Vector3d(U(rng), U(rng), 0);
    const Vector3d a1 = a0 + move + turn, b1 = b0 + move - turn;
    const SweptContacts fast = sweepSegment(m, &bvh, a0, b0, a1, b1);
    const SweptContacts brute = sweepSegment(m, nullptr, a0, b0, a1, b1);
    ASSERT_EQ(fast.faces, brute.faces) << i;
    ASSERT_EQ(fast.edgeCrossings.size(), brute.edgeCrossings.size()) << i;
    // Dense samples lie on the bilinear patch, the sweep tests its strip triangles,
    // which stand within maxTwistDeviation of it: a face may be missed only where
    // the patch touches it within that distance of its border (the neighbour
    // across that border is reported instead).
    const double dev = SweepSettings{}.maxTwistDeviation;
    for (int k = 0; k <= 600; ++k) {
      const double s = k / 600.0;
      for (const SurfaceHit& h : bvh.intersectSegment(m, a0 + s * (a1 - a0), b0 + s * (b1 - b0))) {
        if (std::binary_search(fast.faces.begin(), fast.faces.end(), h.face)) continue;
        const auto& vs = m.vertices(h.face);
        double border = std::numeric_limits<double>::infinity();
        for (int c = 0; c < 3; ++c) {
          const Vector3d p = m.position(vs[c]), q = m.position(vs[(c + 1) % 3]);
          const double u = std::clamp((h.point - p).dot(q - p) / (q - p).squaredNorm(), 0.0, 1.0);
          border = std::min(border, (p + u * (q - p) - h.point).norm());
        }
        EXPECT_LE(border, dev) << "motion " << i << ": face " << h.face << " missed, hit " << border
                               << " mm inside its border";
      }
    }
  }
}

TEST(Swept, SamplingRateDoesNotChangeTheFacesTouched) {
  // One stroke, swept as 10 steps and as 100 steps: the same faces.
  const auto m = testing::slab(10, 1.0, 2.0);
  const TriangleBvh bvh(m);
  auto pose = [](double s) {
    const Vector3d tip(1.2 + 7.5 * s, 2.1 + 5.0 * s * s, -1.0 - 1.5 * std::sin(3.0 * s));
    const Vector3d dir = Vector3d(0.2 * std::cos(4 * s), 0.1, -1).normalized();
    return std::pair<Vector3d, Vector3d>(tip, Vector3d(tip - 6.0 * dir));
  };
  auto sweepAll = [&](int steps) {
    std::set<Face> faces;
    for (int i = 0; i < steps; ++i) {
      const auto [a0, b0] = pose(static_cast<double>(i) / steps);
      const auto [a1, b1] = pose(static_cast<double>(i + 1) / steps);
      for (Face f : sweepSegment(m, &bvh, a0, b0, a1, b1).faces) faces.insert(f);
    }
    return faces;
  };
  const auto coarse = sweepAll(10), fine = sweepAll(100);
  // The coarse chords cut the corners of the curved stroke by less than a cell here,
  // so both must touch the same faces.
  std::vector<Face> onlyFine, onlyCoarse;
  std::set_difference(fine.begin(), fine.end(), coarse.begin(), coarse.end(), std::back_inserter(onlyFine));
  std::set_difference(coarse.begin(), coarse.end(), fine.begin(), fine.end(), std::back_inserter(onlyCoarse));
  std::printf("stroke: %zu faces at 10 steps, %zu at 100 steps, %zu only fine, %zu only coarse\n", coarse.size(),
              fine.size(), onlyFine.size(), onlyCoarse.size());
  EXPECT_EQ(coarse, fine);
  EXPECT_GT(coarse.size(), 20u);
}

TEST(Swept, StripsFollowTheTwist) {
  const SweepSettings s;
  EXPECT_EQ(sweepStrips(Vector3d(0, 0, 0), Vector3d(0, 0, -5), Vector3d(3, 0, 0), Vector3d(3, 0, -5), s), 1);
  EXPECT_GT(sweepStrips(Vector3d(0, 0, 0), Vector3d(0, 0, -5), Vector3d(0, 0, 0), Vector3d(1, 0, -5), s), 1);
  EXPECT_EQ(sweepStrips(Vector3d(0, 0, 0), Vector3d(0, 0, -5), Vector3d(100, 0, 0), Vector3d(0, 100, -5), s),
            s.maxStrips);
}

}  // namespace
}  // namespace ld::collision
