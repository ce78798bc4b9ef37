#include "sim/collision/bvh.h"

#include <algorithm>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "sim/collision/motion_scan.h"
#include "tests/sim/collision/test_meshes.h"
#include "tests/support/test_support.h"

namespace ld::collision {
namespace {

using Eigen::Vector3d;
using ld::test::near;
using ld::test::nearVec;
using mesh::Face;
using mesh::SurfaceMesh;

::testing::AssertionResult sameHits(const std::vector<SurfaceHit>& x, const std::vector<SurfaceHit>& y) {
  if (x.size() != y.size())
    return ::testing::AssertionFailure() << "bvh gives " << x.size() << " hits, brute force " << y.size();
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (x[i].face != y[i].face || x[i].kind != y[i].kind || x[i].t != y[i].t || x[i].edge != y[i].edge ||
        x[i].vertex != y[i].vertex)
      return ::testing::AssertionFailure()
             << "hit " << i << " differs: face " << x[i].face << " vs " << y[i].face << ", kind " << int(x[i].kind)
             << " vs " << int(y[i].kind) << ", t " << x[i].t << " vs " << y[i].t;
  }
  return ::testing::AssertionSuccess();
}

// Random segments: generic ones across the bounds, and ones through vertices and
// edge midpoints (exact boundary hits), some very short.
struct SegmentSource {
  std::mt19937_64 rng;
  explicit SegmentSource(std::uint64_t seed) : rng(seed) {}
  std::pair<Vector3d, Vector3d> next(const SurfaceMesh& m) {
    const auto bb = m.bounds();
    const Vector3d lo = bb.min - 0.2 * bb.extent() - Vector3d::Constant(0.1);
    const Vector3d hi = bb.max + 0.2 * bb.extent() + Vector3d::Constant(0.1);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    auto rnd = [&] { return Vector3d(lo + (hi - lo).cwiseProduct(Vector3d(U(rng), U(rng), U(rng)))); };
    const int kind = static_cast<int>(rng() % 4);
    if (kind == 0) return {rnd(), rnd()};
    // Through a feature of a random live face.
    Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
    while (!m.isValid(f)) f = Face(static_cast<std::uint32_t>(rng() % m.facesSize()));
    const auto& vs = m.vertices(f);
    Vector3d p = m.position(vs[rng() % 3]);
    if (kind == 2) p = 0.5 * (m.position(vs[0]) + m.position(vs[1]));
    if (kind == 3) p = (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0;
    const Vector3d d = (rnd() - p).normalized() * (0.01 + 2.0 * U(rng)) * bb.extent().norm();
    return {p + d, p - U(rng) * d};
  }
};

// All hits, the first hit and the yes/no answer, each against brute force.
void expectSegmentMatches(const SurfaceMesh& m, const TriangleBvh& bvh, const Vector3d& a, const Vector3d& b) {
  const auto brute = intersectSegment(m, a, b);
  ASSERT_TRUE(sameHits(bvh.intersectSegment(m, a, b), brute)) << "segment " << a.transpose() << " -> " << b.transpose();
  SurfaceHit first;
  const bool found = bvh.firstHit(m, a, b, first);
  ASSERT_EQ(found, !brute.empty()) << "segment " << a.transpose() << " -> " << b.transpose();
  if (found) {
    ASSERT_TRUE(sameHits({first}, {brute.front()})) << "first hit of " << a.transpose() << " -> " << b.transpose();
  }
  ASSERT_EQ(bvh.anyHit(m, a, b), !brute.empty());
}

void expectBvhMatchesBruteForce(const SurfaceMesh& m, const TriangleBvh& bvh, SegmentSource& src, int n) {
  for (int i = 0; i < n; ++i) {
    const auto [a, b] = src.next(m);
    expectSegmentMatches(m, bvh, a, b);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

TEST(TriangleBvh, BuildTracksEveryFaceOnce) {
  const SurfaceMesh m = testing::icosphere(3);
  const TriangleBvh bvh(m);
  EXPECT_EQ(bvh.check(m), "");
  const auto s = bvh.stats();
  EXPECT_EQ(s.faces, m.nFaces());
  EXPECT_LE(s.maxDepth, 14u);                                       // 1280 faces, leaves of <= 4: a balanced tree
  EXPECT_TRUE(nearVec(bvh.bounds().max, Vector3d(1, 1, 1), 1e-5));  // floats rounded outwards, grown by pad()
}

TEST(TriangleBvh, QueriesEqualBruteForceOnSeveralMeshes) {
  SegmentSource src(7);
  for (const SurfaceMesh& m : {testing::icosphere(3), testing::slab(12, 1.0, 3.0), testing::grid(20, 0.5)}) {
    const TriangleBvh bvh(m);
    expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(600));
  }
}

TEST(TriangleBvh, ThroughASlabFindsTopAndBottom) {
  const SurfaceMesh m = testing::slab(8, 1.0, 2.0);
  const TriangleBvh bvh(m);
  const auto hits = bvh.intersectSegment(m, Vector3d(2.3, 4.6, 5), Vector3d(2.3, 4.6, -5));
  ASSERT_EQ(hits.size(), 2u);
  EXPECT_TRUE(near(hits[0].point.z(), 0.0, 1e-12));
  EXPECT_EQ(hits[0].direction, 1);  // into the top (outward normal +z)
  EXPECT_TRUE(near(hits[1].point.z(), -2.0, 1e-12));
  EXPECT_EQ(hits[1].direction, -1);  // out through the bottom (outward normal -z)
}

TEST(TriangleBvh, RefitFollowsMovingVertices) {
  SurfaceMesh m = testing::grid(10);
  TriangleBvh bvh(m);
  for (mesh::Vertex v : m.vertices()) m.position(v).z() += 5.0;                                // the sheet moves up
  EXPECT_TRUE(bvh.intersectSegment(m, Vector3d(3.3, 3.3, 6), Vector3d(3.3, 3.3, 4)).empty());  // stale boxes
  bvh.refit(m);
  EXPECT_EQ(bvh.check(m), "");
  ASSERT_EQ(bvh.intersectSegment(m, Vector3d(3.3, 3.3, 6), Vector3d(3.3, 3.3, 4)).size(), 1u);
  // Local refit: only one vertex moves.
  const mesh::Vertex v(static_cast<std::uint32_t>(5 * 11 + 5));
  m.position(v).z() += 3.0;
  const std::vector<mesh::Vertex> moved = {v};
  bvh.refitVertices(m, moved);
  EXPECT_EQ(bvh.check(m), "");
  const auto hits = bvh.intersectSegment(m, Vector3d(5, 5, 9), Vector3d(5, 5, 7));
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].kind, HitKind::OnVertex);
  EXPECT_EQ(hits[0].vertex, v);
}

// Fat boxes (setMotionMargin): every vertex moves a little each step, refitMoved()
// re-anchors only what left its anchor's reach. Moves below the margin leave the
// boxes alone, moves above it re-anchor; in both cases every box still contains its
// faces (check) and every query equals brute force, including segments aimed at the
// faces that moved (SegmentSource aims at features at their current positions).
TEST(TriangleBvh, FatBoxesStayExactUnderSmallAndLargeMoves) {
  std::mt19937_64 rng(5);
  SegmentSource src(6);
  std::normal_distribution<double> N(0.0, 1.0);
  for (int meshKind = 0; meshKind < 2; ++meshKind) {
    SurfaceMesh m = meshKind == 0 ? testing::slab(8, 1.0, 2.0) : testing::slab(34, 1.0, 2.0);  // SAH / Morton build
    TriangleBvh bvh(m);
    const double margin = 0.2;
    bvh.setMotionMargin(m, margin);
    ASSERT_EQ(bvh.check(m), "");
    std::size_t reanchoredSmall = 0, reanchoredLarge = 0;
    for (int step = 0; step < testing::scaled(60); ++step) {
      const bool large = step % 5 == 4;
      if (large) {
        // A patch jumps by more than the margin; the rest does not move.
        const Vector3d c = m.position(mesh::Vertex(static_cast<std::uint32_t>(rng() % m.verticesSize())));
        for (Vector3d& p : m.positions())
          if ((p - c).norm() < 2.5) p += Vector3d(N(rng), N(rng), N(rng)).normalized() * (1.5 * margin);
      } else {
        // Everything drifts by a few percent of the margin per coordinate.
        for (Vector3d& p : m.positions()) p += 0.01 * Vector3d(N(rng), N(rng), N(rng));
      }
      const std::size_t n = bvh.refitMoved(m);
      (large ? reanchoredLarge : reanchoredSmall) += n;
      ASSERT_EQ(bvh.check(m), "") << "step " << step;
      expectBvhMatchesBruteForce(m, bvh, src, 10);
      if (::testing::Test::HasFatalFailure()) return;
      // Every face of the moved surface is found by a segment through its centroid.
      for (int k = 0; k < 20; ++k) {
        const Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
        const auto& vs = m.vertices(f);
        const Vector3d p0 = m.position(vs[0]), p1 = m.position(vs[1]), p2 = m.position(vs[2]);
        const Vector3d c = (p0 + p1 + p2) / 3.0, nrm = (p1 - p0).cross(p2 - p0).normalized();
        std::vector<SurfaceHit> hits;
        bvh.intersectSegment(m, c + 0.05 * nrm, c - 0.05 * nrm, hits);
        const bool found = std::any_of(hits.begin(), hits.end(), [&](const SurfaceHit& h) { return h.face == f; });
        ASSERT_EQ(found, !intersectSegment(m, c + 0.05 * nrm, c - 0.05 * nrm).empty()) << "face " << f;
        ASSERT_FALSE(hits.empty()) << "the segment through face " << f << "'s centroid found nothing";
      }
    }
    // Small drifts accumulate: some vertices do cross the margin over the run, but far
    // fewer than a refit per step would touch; the jumps always re-anchor.
    EXPECT_LT(reanchoredSmall, m.nVertices() * static_cast<std::size_t>(testing::scaled(60)) / 10);
    EXPECT_GT(reanchoredLarge, 0u);
  }
}

// With a caller's bound on the moves (physics::Dynamics::maxMove) the pass is skipped
// while the moves fit in the slack the last pass left; a bound that is exact (the
// largest move itself) keeps every query exact. Then the same under topology edits
// (sync) and vertices moved by a caller between passes (refitVertices).
TEST(TriangleBvh, FatBoxesWithAMoveBoundSkipPassesAndStayExact) {
  std::mt19937_64 rng(8);
  SegmentSource src(9);
  std::uniform_real_distribution<double> U(-1.0, 1.0), S(0.05, 0.95);
  SurfaceMesh m = testing::slab(12, 1.0, 2.0);
  TriangleBvh bvh(m);
  bvh.setMotionMargin(m, 0.1);
  int skipped = 0, passes = 0;
  for (int step = 0; step < testing::scaled(200); ++step) {
    // A wave: each step moves every vertex by up to `amp` per coordinate.
    const double amp = step % 50 < 40 ? 0.004 : 0.03;
    double largest = 0.0;
    for (Vector3d& p : m.positions()) {
      const Vector3d d(amp * U(rng), amp * U(rng), amp * U(rng));
      p += d;
      largest = std::max(largest, d.cwiseAbs().maxCoeff());
    }
    if (step % 7 == 3) {  // the cutter edits between steps: split a face
      const Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
      if (m.isValid(f)) {
        double u = S(rng), v = S(rng);
        if (u + v > 1) u = 1 - u, v = 1 - v;
        const auto& vs = m.vertices(f);
        m.splitFace(f, m.position(vs[0]) + u * (m.position(vs[1]) - m.position(vs[0])) +
                           v * (m.position(vs[2]) - m.position(vs[0])));
      }
      bvh.sync(m);
    }
    if (step % 11 == 5) {  // and slides a vertex by more than the margin (told by name)
      const mesh::Vertex v(static_cast<std::uint32_t>(rng() % m.verticesSize()));
      m.position(v) += Vector3d(0.0, 0.0, 0.25);
      const std::vector<mesh::Vertex> moved = {v};
      bvh.refitVertices(m, moved);
    }
    const std::size_t n = bvh.refitMoved(m, largest);
    // A skipped pass returns 0 without reading; count by whether anything could move.
    (n == 0 ? skipped : passes) += 1;
    ASSERT_EQ(bvh.check(m), "") << "step " << step;
    if (step % 4 == 0) expectBvhMatchesBruteForce(m, bvh, src, 10);
    if (::testing::Test::HasFatalFailure()) return;
  }
  EXPECT_GT(skipped, testing::scaled(200) / 2) << "small moves within the slack need no pass";
  EXPECT_GT(passes, 0);
}

// What the physics does for refitTravelled (physics::Dynamics::groupTravel): each
// group's largest move per coordinate summed, plus the step's rounding room, and the
// groups past the limit listed until the tree has taken them. Groups cover the
// vertices there are at each step (new ones start at 0), unless told to lag.
struct TravelSums {
  static constexpr std::size_t G = 16;
  std::vector<double> travel;
  std::vector<std::uint32_t> past;
  void add(const std::vector<Vector3d>& before, const SurfaceMesh& m, const TriangleBvh& bvh, bool lag = false) {
    const std::size_t n = lag ? before.size() : m.verticesSize();
    travel.resize((n + G - 1) / G, 0.0);
    std::vector<double> step(travel.size(), 0.0);
    for (std::size_t v = 0; v < std::min(n, before.size()); ++v)
      step[v / G] = std::max(step[v / G], (m.positions()[v] - before[v]).cwiseAbs().maxCoeff());
    for (std::size_t g = 0; g < travel.size(); ++g) {
      travel[g] += step[g] + bvh.travelPad();
      if (!(travel[g] <= bvh.travelLimit())) past.push_back(static_cast<std::uint32_t>(g));
    }
  }
  std::size_t take(const SurfaceMesh& m, TriangleBvh& bvh) {
    const std::size_t n = bvh.refitTravelled(m, travel, past, G);
    past.clear();
    return n;
  }
};

// With each group's moves summed (refitTravelled) only the groups past the limit are
// looked at: no pass over all the vertices after the first, far fewer vertices read
// than with the step's largest move, and every box still holds its corners (check) and
// every query is exact: also with faces split between steps (vertices past the groups
// for a step, then in new groups), a group whose sum is not a number, a slow group
// swinging back and forth (entries below 0), a tissue-wide jump (over a quarter of the
// groups listed: one pass) and a return from refitMoved.
TEST(TriangleBvh, TravelledBoxesLookOnlyAtTheListedGroups) {
  std::mt19937_64 rng(31);
  SegmentSource src(32);
  std::uniform_real_distribution<double> U(-1.0, 1.0), S(0.05, 0.95);
  SurfaceMesh m = testing::slab(16, 1.0, 2.0);
  TriangleBvh byTravel(m), byMax(m);
  const double margin = 0.1;
  byTravel.setMotionMargin(m, margin);
  byMax.setMotionMargin(m, margin);
  EXPECT_NEAR(byTravel.travelLimit(), (1.0 - TriangleBvh::kTravelReach) * margin, 1e-15);
  TravelSums sums;
  EXPECT_THROW(byTravel.refitTravelled(m, sums.travel, sums.past, 0), CollisionError);
  const double slow = 0.002 * margin;
  // Two lips: runs of vertices that keep moving fast in one direction.
  std::vector<std::uint32_t> fast;
  for (std::uint32_t v = 40; v < 46; ++v) fast.push_back(v);
  for (std::uint32_t v = 300; v < 304; ++v) fast.push_back(v);
  std::size_t reanchored = 0, listed = 0;
  const int steps = testing::scaled(300);
  for (int step = 0; step < steps; ++step) {
    const std::vector<Vector3d> before = m.positions();
    const bool jump = step == steps / 2;
    for (Vector3d& p : m.positions()) p += (jump ? 100.0 : 1.0) * slow * Vector3d(U(rng), U(rng), U(rng));
    for (std::uint32_t v : fast) m.positions()[v] += Vector3d(0.03, -0.02, 0.01 * U(rng));
    // A group swinging by 0.9 of the limit and back: listed every other step, looked
    // at, and (its vertices near their anchors) given an entry below 0.
    for (std::uint32_t v = 160; v < 176; ++v) m.positions()[v].y() += (step % 2 ? -0.9 : 0.9) * byTravel.travelLimit();
    double largest = 0.0;
    for (std::size_t v = 0; v < before.size(); ++v)
      largest = std::max(largest, (m.positions()[v] - before[v]).cwiseAbs().maxCoeff());
    const bool split = step % 9 == 4;
    if (split) {  // the cutter splits a face: its new vertex is past the groups this step
      const Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
      double u = S(rng), v = S(rng);
      if (u + v > 1) u = 1 - u, v = 1 - v;
      const auto& vs = m.vertices(f);
      const mesh::Vertex nv = m.splitFace(f, m.position(vs[0]) + u * (m.position(vs[1]) - m.position(vs[0])) +
                                                 v * (m.position(vs[2]) - m.position(vs[0])));
      ASSERT_TRUE(nv.isValid());
      fast.push_back(nv.idx());  // and it moves fast from the next step on
      byTravel.sync(m);
      byMax.sync(m);
    }
    sums.add(before, m, byTravel, split);
    if (step == 77) sums.travel[3] = std::numeric_limits<double>::quiet_NaN(), sums.past.push_back(3);
    listed += sums.past.size();
    if (step == 200) {  // someone else's refit in between: the mode is left and taken up again
      byTravel.refitMoved(m, largest);
      sums.past.clear();
    } else {
      reanchored += sums.take(m, byTravel);
    }
    byMax.refitMoved(m, largest);
    ASSERT_EQ(byTravel.check(m), "") << "step " << step;
    ASSERT_EQ(byMax.check(m), "") << "step " << step;
    if (step % 5 == 0) expectBvhMatchesBruteForce(m, byTravel, src, 10);
    if (::testing::Test::HasFatalFailure()) return;
  }
  // The lips leave their reach every few steps; with the largest move as the bound each
  // time means a pass over everything, with the sums only the listed groups.
  EXPECT_GT(byMax.motionPasses(), static_cast<std::size_t>(steps) / 5);
  EXPECT_LE(byTravel.motionPasses(), 4u) << "the first call, the jump, the return after refitMoved";
  EXPECT_GT(reanchored, 10u * static_cast<std::size_t>(steps) / 8) << "the lips were re-anchored";
  EXPECT_LT(listed * TravelSums::G, 30u * static_cast<std::size_t>(steps)) << "only a few groups a step";
  EXPECT_GT(listed, static_cast<std::size_t>(steps) / 2) << "the swinging group is listed";
}

// A slab with fat boxes in refitTravelled's mode, group 2 (vertices 32-47) looked at
// while still: its entry is -reach, the lowest there is.
struct QuietGroup2 {
  SurfaceMesh m = testing::slab(16, 1.0, 2.0);
  TriangleBvh bvh{m};
  double margin = 0.1, reach = TriangleBvh::kTravelReach * margin;
  TravelSums sums;
  std::vector<Vector3d> before;
  QuietGroup2() {
    bvh.setMotionMargin(m, margin);
    before = m.positions();
    sums.add(before, m, bvh);
    sums.take(m, bvh);
    sums.past.push_back(2);
    sums.take(m, bvh);
  }
  // A step that moves group 2 by d along x.
  void moveGroup2(double d) {
    before = m.positions();
    for (std::uint32_t v = 2 * TravelSums::G; v < 3 * TravelSums::G; ++v) m.positions()[v].x() += d;
  }
};

// A vertex someone else moves while a group's entry is below 0 (the cutter's groove
// bottom slides) must be anchored anew: its group's entry no longer bounds it. Here
// one vertex of the quiet group is slid by 0.9 reach (within the reach: a fit alone
// would keep its anchor), then the group moves just under what its entry allows; the
// box must still hold it.
TEST(TriangleBvh, TravelledBoxesTakeVerticesMovedBySomeoneElse) {
  QuietGroup2 q;
  EXPECT_NEAR(q.sums.travel[2], -q.reach, 1e-12);
  const mesh::Vertex x(2 * TravelSums::G + 5);
  q.m.position(x).x() += 0.9 * q.reach;
  const std::vector<mesh::Vertex> moved = {x};
  q.bvh.refitVertices(q.m, moved);
  ASSERT_EQ(q.bvh.check(q.m), "");
  q.moveGroup2(0.99 * (q.bvh.travelLimit() + q.reach));
  q.sums.add(q.before, q.m, q.bvh);
  EXPECT_TRUE(q.sums.past.empty()) << "the entry allows the move";
  q.sums.take(q.m, q.bvh);
  EXPECT_EQ(q.bvh.check(q.m), "") << "the slid vertex left its box";
  SegmentSource src(33);
  expectBvhMatchesBruteForce(q.m, q.bvh, src, 20);
}

// A region that moves every step and says which vertices it moved (physics' awake
// list): only the listed vertices are read, those that left half the margin are
// re-anchored, and every box still holds its corners and every query is exact, with
// the list repeating vertices, a patch of it jumping past the margin, and faces split
// between steps.
TEST(TriangleBvh, ListedMovesAreReadOnlyFromTheList) {
  std::mt19937_64 rng(41);
  std::normal_distribution<double> N(0.0, 1.0);
  SegmentSource src(42);
  SurfaceMesh m = testing::slab(34, 1.0, 2.0);
  TriangleBvh bvh(m);
  const double margin = 0.2;
  bvh.setMotionMargin(m, margin);
  std::vector<std::uint32_t> region;
  for (mesh::Vertex v : m.vertices())
    if ((m.position(v).head<2>() - Eigen::Vector2d(17.0, 17.0)).norm() < 5.0) region.push_back(v.idx());
  ASSERT_GT(region.size(), 100u);
  ASSERT_LT(4 * region.size(), m.nVertices());
  std::size_t listed = 0, small = 0, large = 0;
  const int steps = testing::scaled(60);
  for (int step = 0; step < steps; ++step) {
    const bool jump = step % 10 == 9;
    std::vector<std::uint32_t> list = region;
    if (step % 3 == 0) list.insert(list.end(), region.begin(), region.begin() + 20);  // repeats
    for (std::uint32_t v : region) {
      Vector3d& p = m.positions()[v];
      if (jump && (p.head<2>() - Eigen::Vector2d(16.0, 17.0)).norm() < 2.0)
        p += Vector3d(N(rng), N(rng), N(rng)).normalized() * (1.5 * margin);
      else
        p += 0.005 * Vector3d(N(rng), N(rng), N(rng));
    }
    if (step % 7 == 3) {  // a cut's edit between steps
      const mesh::Vertex v(region[rng() % region.size()]);
      const Face f = *m.faces(v).begin();
      const auto& vs = m.vertices(f);
      const mesh::Vertex added = m.splitFace(f, (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0);
      bvh.sync(m);
      region.push_back(added.idx());
    }
    listed += list.size();
    (jump ? large : small) += bvh.refitListed(m, list);
    ASSERT_EQ(bvh.check(m), "") << "step " << step;
    if (step % 3 == 0) expectBvhMatchesBruteForce(m, bvh, src, 10);
    if (::testing::Test::HasFatalFailure()) return;
  }
  EXPECT_LT(20 * small, listed) << "drifts within half the margin are not refitted";
  EXPECT_GT(large, 0u) << "a jump past the margin is";
  // Listed moves do not leave the boxes slack they do not have: a vertex not listed,
  // moved, is caught by the pass of refitMoved (which reads every vertex).
  m.positions()[0].z() += 3.0;
  EXPECT_GT(bvh.refitMoved(m), 0u);
  EXPECT_EQ(bvh.check(m), "");
  const std::vector<std::uint32_t> bad{static_cast<std::uint32_t>(m.verticesSize())};
  EXPECT_THROW(bvh.refitListed(m, bad), CollisionError);
  bvh.setMotionMargin(m, 0.0);
  EXPECT_THROW(bvh.refitListed(m, bad), CollisionError) << "also with tight boxes";
}

// In refitTravelled's mode a short list is anchored where it is and the mode goes on
// (no pass over all the vertices at the next call); a long one ends the mode (the next
// call makes one pass). Either way the boxes hold and queries are exact.
TEST(TriangleBvh, ListedMovesInTheTravelledMode) {
  QuietGroup2 q;
  const mesh::Vertex x(2 * TravelSums::G + 5);
  q.m.position(x).x() += 0.9 * q.reach;
  const std::vector<std::uint32_t> one = {x.idx()};
  EXPECT_EQ(q.bvh.refitListed(q.m, one), 1u);
  ASSERT_EQ(q.bvh.check(q.m), "");
  const std::size_t passes = q.bvh.motionPasses();
  q.moveGroup2(0.99 * (q.bvh.travelLimit() + q.reach));
  q.sums.add(q.before, q.m, q.bvh);
  EXPECT_TRUE(q.sums.past.empty()) << "the entry allows the move";
  q.sums.take(q.m, q.bvh);
  EXPECT_EQ(q.bvh.motionPasses(), passes) << "still in the mode";
  EXPECT_EQ(q.bvh.check(q.m), "") << "the listed vertex left its box";
  // A long list, moved by 0.6 margin: re-anchored, and the mode ends.
  std::vector<std::uint32_t> many;
  for (std::uint32_t v = 0; v < 2 * TriangleBvh::kFewListed; ++v) {
    q.m.positions()[v].y() += 0.6 * q.margin;
    many.push_back(v);
  }
  q.before = q.m.positions();
  EXPECT_EQ(q.bvh.refitListed(q.m, many), many.size());
  ASSERT_EQ(q.bvh.check(q.m), "");
  q.moveGroup2(0.3 * q.reach);
  q.sums.add(q.before, q.m, q.bvh);
  q.sums.take(q.m, q.bvh);
  EXPECT_EQ(q.bvh.motionPasses(), passes + 1) << "one pass coming back into the mode";
  EXPECT_EQ(q.bvh.check(q.m), "");
  SegmentSource src(43);
  expectBvhMatchesBruteForce(q.m, q.bvh, src, 20);
}

// Entries kept from an earlier stay in the mode (below 0) must not outlive another
// refit: refitMoved leaves group 2's vertices 0.9 reach from their anchors (within its
// own slack), so coming back the entries must start from there, and a move the old
// entry would have allowed gets the group listed and looked at.
TEST(TriangleBvh, TravelledEntriesRestartAfterAnotherRefit) {
  QuietGroup2 q;
  auto& [m, bvh, margin, reach, sums, before] = q;
  q.moveGroup2(0.9 * reach);  // a step the physics could not sum
  bvh.refitMoved(m, 0.9 * reach);
  ASSERT_EQ(bvh.check(m), "");
  q.moveGroup2(0.0);  // a summed step: back in the mode
  sums.add(before, m, bvh);
  EXPECT_EQ(sums.take(m, bvh), 0u) << "all within the reach";
  EXPECT_EQ(bvh.motionPasses(), 3u) << "a pass on entry, refitMoved's, one coming back";
  EXPECT_NEAR(sums.travel[2], 0.9 * reach - reach, 1e-9) << "every entry from the farthest vertex";
  q.moveGroup2(0.99 * (bvh.travelLimit() + reach));
  sums.add(before, m, bvh);
  sums.take(m, bvh);
  EXPECT_EQ(bvh.check(m), "") << "group 2's old entry was taken for true";
  SegmentSource src(34);
  expectBvhMatchesBruteForce(m, bvh, src, 20);
}

// The fat-box pass's scan in every build this CPU runs (portable, SSE2, AVX2, AVX-512):
// forced in turn, automatic again at the end of the scope.
std::vector<ScanKernel> scanKernels() {
  std::vector<ScanKernel> ks;
  for (ScanKernel k : {ScanKernel::Portable, ScanKernel::Sse2, ScanKernel::Avx2, ScanKernel::Avx512})
    if (scanKernelSupported(k)) ks.push_back(k);
  return ks;
}
struct ForcedScan {
  explicit ForcedScan(ScanKernel k) { EXPECT_TRUE(forceScanKernel(k)); }
  ~ForcedScan() { forceScanKernel(std::nullopt); }
  ForcedScan(const ForcedScan&) = delete;
  ForcedScan& operator=(const ForcedScan&) = delete;
};

// Each build of the scan against a reference written out here: one coordinate (any of
// the 24 of a block, in any block) farther than theta, NaN or infinite must stop the
// scan at its block, one at exactly theta must not, and the largest distance of the
// blocks passed over must be the same to the bit (a lane left out of the test or the
// max would show here).
TEST(TriangleBvh, ScanKernelsFindEveryLoudCoordinate) {
  constexpr std::size_t nb = 5, n = 24 * nb;
  const double theta = 0.125;
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> P(-150.0, 150.0), D(-0.1, 0.1);
  std::vector<double> x0(n);
  std::vector<float> a(n);
  for (std::size_t i = 0; i < n; ++i) {
    a[i] = static_cast<float>(P(rng));
    x0[i] = static_cast<double>(a[i]) + D(rng);
  }
  const double bad[] = {theta + 1e-9, -(theta + 1e-3), std::numeric_limits<double>::quiet_NaN(),
                        std::numeric_limits<double>::infinity(), theta};
  const std::vector<ScanKernel> kernels = scanKernels();
  EXPECT_GE(kernels.size(), 1u);
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t kind = 0; kind < std::size(bad); ++kind) {
      std::vector<double> x = x0;
      x[p] = static_cast<double>(a[p]) + bad[kind];
      const bool loud = kind + 1 < std::size(bad);  // the last one sits exactly at theta
      for (std::size_t from : {std::size_t{0}, std::size_t{1}}) {
        const std::size_t want = loud && p / 24 >= from ? p / 24 : nb;
        double wantWorst = 0.03;  // (the caller's running value goes in)
        for (std::size_t i = 24 * from; i < 24 * want; ++i)
          wantWorst = std::max(wantWorst, std::abs(x[i] - static_cast<double>(a[i])));
        for (ScanKernel k : kernels) {
          double worst = 0.03;
          EXPECT_EQ(detail::scanQuietBlocks(k, x.data(), a.data(), from, nb, theta, worst), want)
              << scanKernelName(k) << " coordinate " << p << " kind " << kind << " from block " << from;
          EXPECT_EQ(worst, wantWorst) << scanKernelName(k) << " coordinate " << p << " kind " << kind;
        }
      }
    }
}

// Anchoring: each coordinate rounded to the nearest float, in every build and for
// every count (the vector bodies and the tails).
TEST(TriangleBvh, AnchorCoordinatesRoundToNearest) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> P(-1000.0, 1000.0);
  for (std::size_t n = 0; n <= 37; ++n) {
    std::vector<double> x(n);
    for (double& v : x) v = P(rng);
    for (ScanKernel k : scanKernels()) {
      std::vector<float> a(n + 1, -1.0f);
      detail::anchorCoordinates(k, x.data(), a.data(), n);
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(a[i], static_cast<float>(x[i])) << scanKernelName(k) << " " << i;
      EXPECT_EQ(a[n], -1.0f) << scanKernelName(k) << ": wrote past " << n;
    }
  }
}

// Far from the origin a float anchor is off its vertex by far more than the boxes' pad
// (2^-24 of 3e5 mm is 18 um): right after the refit (no grow at query time), after a
// pass and after a local refit the boxes around the anchors must still hold the faces.
// (The boxes' outward rounding to float nearly covers the anchors' rounding by itself;
// the explicit widening makes it certain, so this does not catch its absence.)
TEST(TriangleBvh, FatBoxesHoldTheirFacesFarFromTheOrigin) {
  SurfaceMesh m = testing::icosphere(2, 1.0);
  for (mesh::Vertex v : m.vertices()) m.position(v) += Vector3d(3e5, -2e5, 1e5);
  TriangleBvh bvh(m);
  bvh.setMotionMargin(m, 0.01);
  EXPECT_EQ(bvh.check(m), "");
  SegmentSource src(32);
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(200));
  // A small move, a pass (nothing re-anchored) and a local refit after an edit.
  for (Vector3d& p : m.positions()) p.z() += 0.001;
  EXPECT_EQ(bvh.refitMoved(m, 0.001), 0u);
  EXPECT_EQ(bvh.check(m), "");
  const Face f(3u);
  m.splitFace(f, m.centroid(f));
  bvh.sync(m);
  EXPECT_EQ(bvh.check(m), "");
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(200));
}

// The whole pass with each build forced: the same vertices re-anchored, the same
// passes and the same boxes and grow (bounds() to the bit), every query exact.
TEST(TriangleBvh, FatBoxPassesAreTheSameWithEveryScanKernel) {
  const SurfaceMesh start = testing::slab(17, 1.0, 2.0);
  struct Trace {
    std::vector<std::size_t> reanchored;
    std::vector<double> box;
    std::size_t passes = 0;
  };
  const std::vector<ScanKernel> kernels = scanKernels();
  std::vector<Trace> traces;
  for (ScanKernel k : kernels) {
    SCOPED_TRACE(std::string(scanKernelName(k)));
    ForcedScan forced(k);
    SurfaceMesh m = start;
    TriangleBvh bvh(m);
    bvh.setMotionMargin(m, 0.1);
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    SegmentSource src(24);
    Trace t;
    for (int step = 0; step < testing::scaled(120); ++step) {
      // A drift everywhere and now and then a patch that jumps (a few vertices past
      // the re-anchor distance, in different blocks of 8 and the tail).
      double largest = 0.0;
      const Vector3d c = m.position(mesh::Vertex(static_cast<std::uint32_t>(rng() % m.verticesSize())));
      const bool jump = step % 6 == 5;
      for (Vector3d& p : m.positions()) {
        Vector3d d(0.003 * U(rng), 0.003 * U(rng), 0.003 * U(rng));
        if (jump && (p - c).norm() < 1.5) d.z() += 0.07;
        p += d;
        largest = std::max(largest, d.cwiseAbs().maxCoeff());
      }
      t.reanchored.push_back(bvh.refitMoved(m, step % 10 == 9 ? std::numeric_limits<double>::infinity() : largest));
      const Box b = bvh.bounds();
      t.box.insert(t.box.end(), {b.min.x(), b.min.y(), b.min.z(), b.max.x(), b.max.y(), b.max.z()});
      ASSERT_EQ(bvh.check(m), "") << "step " << step;
      if (step % 8 == 0) expectBvhMatchesBruteForce(m, bvh, src, 10);
      if (::testing::Test::HasFatalFailure()) return;
    }
    t.passes = bvh.motionPasses();
    // About one pass in ten steps (the jumps and the unbounded steps); under
    // AddressSanitizer the test runs a quarter of the steps (scaled).
    EXPECT_GT(t.passes, static_cast<std::size_t>(testing::scaled(120) / 12));
    traces.push_back(std::move(t));
  }
  for (std::size_t i = 1; i < traces.size(); ++i) {
    EXPECT_EQ(traces[i].reanchored, traces[0].reanchored) << scanKernelName(kernels[i]);
    EXPECT_EQ(traces[i].box, traces[0].box) << scanKernelName(kernels[i]);
    EXPECT_EQ(traces[i].passes, traces[0].passes) << scanKernelName(kernels[i]);
  }
}

// The pass's bookkeeping, vertex by vertex: a vertex that stays just below the
// re-anchor distance must count in the slack the pass leaves (wherever it sits in the
// scan's blocks of 8 and in the tail), or a later skipped pass would leave it outside
// its box; past 1/32 of the vertices the pass stops early and refits everything, and
// those boxes must still carry the margin for the skipped passes that follow.
// (With each build of the scan.)
void fatBoxPassKeepsItsWorstVertexInTheSlack();
TEST(TriangleBvh, FatBoxPassKeepsItsWorstVertexInTheSlack) {
  for (ScanKernel k : scanKernels()) {
    SCOPED_TRACE(std::string(scanKernelName(k)));
    ForcedScan forced(k);
    fatBoxPassKeepsItsWorstVertexInTheSlack();
    if (::testing::Test::HasFatalFailure()) return;
  }
}

void fatBoxPassKeepsItsWorstVertexInTheSlack() {
  const double margin = 0.1, theta = 0.5 * margin;  // a bound given: re-anchor at half
  SegmentSource src(12);
  SurfaceMesh m = testing::slab(10, 1.0, 2.0);
  const std::size_t nv = m.verticesSize();
  ASSERT_GT(nv % 8, 0u) << "the mesh should leave a tail after the blocks of 8";
  for (std::size_t v : {std::size_t{0}, std::size_t{3}, std::size_t{7}, std::size_t{8}, std::size_t{13}, nv / 2, nv - 9,
                        nv - 2, nv - 1}) {
    const std::vector<Vector3d> rest(m.positions().begin(), m.positions().end());
    TriangleBvh bvh(m);
    bvh.setMotionMargin(m, margin);
    const mesh::Vertex x(static_cast<std::uint32_t>(v));
    // Just below theta, with a bound that forces a pass: nobody is re-anchored, and the
    // slack left is margin - 0.049.
    m.position(x).z() += 0.049;
    EXPECT_EQ(bvh.refitMoved(m, 0.2), 0u) << "vertex " << v;
    EXPECT_EQ(bvh.motionPasses(), 1u);
    ASSERT_EQ(bvh.check(m), "") << "vertex " << v;
    // Within that slack: skipped, and the box still holds the vertex (0.089 < margin).
    m.position(x).z() += 0.04;
    EXPECT_EQ(bvh.refitMoved(m, 0.04), 0u);
    EXPECT_EQ(bvh.motionPasses(), 1u) << "vertex " << v << ": 0.04 fits in the slack";
    ASSERT_EQ(bvh.check(m), "") << "vertex " << v;
    // Beyond it: a pass (with the slack of a pass that forgot the vertex, this move
    // would be skipped and the box would miss it), which re-anchors the vertex.
    m.position(x).z() += 0.02;
    EXPECT_EQ(bvh.refitMoved(m, 0.02), 1u) << "vertex " << v;
    EXPECT_EQ(bvh.motionPasses(), 2u) << "vertex " << v;
    ASSERT_EQ(bvh.check(m), "") << "vertex " << v;
    expectBvhMatchesBruteForce(m, bvh, src, 10);
    std::copy(rest.begin(), rest.end(), m.positions().begin());
  }
  // Exactly nv / 32 vertices past theta: refitted locally; one more: everything.
  for (std::size_t extra = 0; extra < 2; ++extra) {
    const std::vector<Vector3d> rest(m.positions().begin(), m.positions().end());
    TriangleBvh bvh(m);
    bvh.setMotionMargin(m, margin);
    const std::size_t n = nv / 32 + extra;
    for (std::size_t i = 0; i < n; ++i) m.positions()[nv - 1 - 3 * i].z() += 1.5 * theta;
    EXPECT_EQ(bvh.refitMoved(m, 2.0 * theta), extra ? m.nVertices() : n);
    ASSERT_EQ(bvh.check(m), "");
    std::copy(rest.begin(), rest.end(), m.positions().begin());
  }
  // Everything past theta, found in the first blocks: the pass stops and refits all
  // (boxes around the new anchors); moves adding up to just under the margin are
  // skipped, and the queries must grow the boxes by them: every box still holds its
  // faces, segment queries equal brute force, and the box and triangle queries the
  // cutter and the swept test use find every face (a grow that forgot the skipped
  // moves would miss them).
  {
    TriangleBvh bvh(m);
    bvh.setMotionMargin(m, margin);
    for (Vector3d& p : m.positions()) p.z() += 0.07;
    EXPECT_EQ(bvh.refitMoved(m, 0.2), m.nVertices());
    for (int k = 0; k < 3; ++k) {
      for (Vector3d& p : m.positions()) p.z() -= 0.03;
      EXPECT_EQ(bvh.refitMoved(m, 0.03), 0u);
      ASSERT_EQ(bvh.check(m), "") << "skipped pass " << k;
    }
    EXPECT_EQ(bvh.motionPasses(), 1u);
    expectBvhMatchesBruteForce(m, bvh, src, 20);
    std::vector<Face> near;
    for (Face f : m.faces()) {
      const auto& vs = m.vertices(f);
      const Vector3d t[3] = {m.position(vs[0]), m.position(vs[1]), m.position(vs[2])};
      Box box;
      for (const Vector3d& p : t) box.extend(p);
      near.clear();
      bvh.facesOverlapping(box, near);
      ASSERT_NE(std::find(near.begin(), near.end(), f), near.end()) << "facesOverlapping misses " << f;
      near.clear();
      bvh.facesNearTriangle(t[0], t[1], t[2], near);
      ASSERT_NE(std::find(near.begin(), near.end(), f), near.end()) << "facesNearTriangle misses " << f;
    }
    const Box root = bvh.bounds();
    for (const Vector3d& p : m.positions())
      ASSERT_TRUE((p.array() >= root.min.array()).all() && (p.array() <= root.max.array()).all());
  }
}

TEST(TriangleBvh, MotionMarginMisuseThrows) {
  SurfaceMesh m = testing::grid(4);
  TriangleBvh bvh(m);
  EXPECT_THROW(bvh.setMotionMargin(m, -1.0), CollisionError);
  EXPECT_THROW(bvh.setMotionMargin(m, std::numeric_limits<double>::quiet_NaN()), CollisionError);
  bvh.setMotionMargin(m, 0.5);
  bvh.setMotionMargin(m, 0.0);  // back to tight boxes: refitMoved is a refit
  m.position(mesh::Vertex(0u)).z() += 3.0;
  EXPECT_EQ(bvh.refitMoved(m), m.nVertices());
  EXPECT_EQ(bvh.check(m), "");
}

// The property test: random local edits (split edge, split face, delete face, move
// vertices), the mesh validated and the tree synced after each, queries compared
// with brute force throughout.
TEST(TriangleBvh, StaysEqualToBruteForceUnderRandomEdits) {
  std::mt19937_64 rng(99);
  SegmentSource src(11);
  std::uniform_real_distribution<double> U(0.05, 0.95);
  // Kind 3 has more than 4096 faces: the Morton-order build (smaller ones use binned SAH).
  // Kinds 4 and 5 repeat 1 and 2 with fat boxes (setMotionMargin): moved vertices then
  // go to refitMoved() half of the time (the moves are about as large as the margin).
  for (int meshKind = 0; meshKind < 6; ++meshKind) {
    SurfaceMesh m = meshKind == 0                    ? testing::icosphere(2)
                    : meshKind == 1 || meshKind == 4 ? testing::slab(6, 1.0, 2.0)
                    : meshKind == 2 || meshKind == 5 ? testing::grid(8)
                                                     : testing::slab(34, 1.0, 2.0);
    const bool fat = meshKind >= 4;
    TriangleBvh bvh(m);
    if (fat) bvh.setMotionMargin(m, 0.05);
    int local = 0, rebuilt = 0;
    for (int step = 0; step < testing::scaled(300); ++step) {
      const int op = static_cast<int>(rng() % 10);
      if (op < 4) {  // split an edge
        mesh::Edge e(static_cast<std::uint32_t>(rng() % m.edgesSize()));
        if (!m.isValid(e)) continue;
        const double s = U(rng);
        m.splitEdge(e, (1 - s) * m.position(m.vertex(e, 0)) + s * m.position(m.vertex(e, 1)));
      } else if (op < 8) {  // split a face
        Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
        if (!m.isValid(f)) continue;
        double u = U(rng), v = U(rng);
        if (u + v > 1) u = 1 - u, v = 1 - v;
        const auto& vs = m.vertices(f);
        const Vector3d p = m.position(vs[0]) + u * (m.position(vs[1]) - m.position(vs[0])) +
                           v * (m.position(vs[2]) - m.position(vs[0]));
        m.splitFace(f, p);
      } else if (op == 8 && (meshKind == 2 || meshKind == 5)) {
        // Delete a face (open meshes only: the others stay closed).
        Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
        if (!m.isValid(f)) continue;
        m.deleteFace(f);
      } else if (op == 8) {  // open the surface as cutting does: separate an edge or split a vertex
        mesh::Edge e(static_cast<std::uint32_t>(rng() % m.edgesSize()));
        if (!m.isValid(e) || m.isBoundary(e)) continue;
        if (rng() % 2 == 0) {
          if (!m.separateEdge(e).isValid()) continue;
        } else {
          const mesh::Vertex v = m.vertex(e, 0);
          const Face fan[1] = {m.face(e, 0)};
          if (!m.splitVertex(v, fan).isValid()) continue;
        }
      } else {  // move a few vertices
        std::vector<mesh::Vertex> moved;
        std::normal_distribution<double> N(0.0, 0.05);
        for (int k = 0; k < 5; ++k) {
          mesh::Vertex v(static_cast<std::uint32_t>(rng() % m.verticesSize()));
          if (!m.isValid(v)) continue;
          m.position(v) += Vector3d(N(rng), N(rng), N(rng));
          moved.push_back(v);
        }
        if (fat && rng() % 2 == 0)
          bvh.refitMoved(m);
        else
          bvh.refitVertices(m, moved);
      }
      ASSERT_TRUE(m.validate().ok()) << m.validate().message();
      if (rng() % 3 == 0) continue;  // sometimes several edits between two syncs
      const SyncResult r = bvh.sync(m);
      local += r == SyncResult::Local;
      rebuilt += r == SyncResult::Rebuilt;
      ASSERT_EQ(bvh.check(m), "") << "step " << step;
      if (step % 20 == 0) expectBvhMatchesBruteForce(m, bvh, src, 20);
    }
    bvh.sync(m);
    ASSERT_EQ(bvh.check(m), "");
    expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(200));
    EXPECT_GT(local, testing::scaled(300) / 4) << "edits should be absorbed locally";
    EXPECT_LT(rebuilt * 8, local) << "most syncs should be local";
    // Compaction renumbers faces: the tree notices and rebuilds.
    if (m.hasGarbage()) {
      m.garbageCollection();
      EXPECT_EQ(bvh.sync(m), SyncResult::Rebuilt);
      EXPECT_EQ(bvh.check(m), "");
      expectBvhMatchesBruteForce(m, bvh, src, 100);
    }
  }
}

TEST(TriangleBvh, LocalInsertionSplitsLeavesAndKeepsDepthBounded) {
  SurfaceMesh m = testing::grid(4);
  TriangleBvh bvh(m);
  // Hammer one face with splits: all new faces land in the same neighbourhood.
  std::mt19937_64 rng(3);
  Face f(0);
  for (int i = 0; i < testing::scaled(1200); ++i) {
    const auto& vs = m.vertices(f);
    const Vector3d p = (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0;
    m.splitFace(f, p);
    f = Face(static_cast<std::uint32_t>(m.facesSize() - 1 - rng() % 3));
    bvh.sync(m);
  }
  EXPECT_EQ(bvh.check(m), "");
  EXPECT_LE(bvh.stats().maxDepth, TriangleBvh::kMaxDepth);
  SegmentSource src(5);
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(300));
}

TEST(TriangleBvh, MisuseThrows) {
  const SurfaceMesh m = testing::grid(3);
  TriangleBvh bvh;
  EXPECT_THROW(bvh.refit(m), CollisionError);
  bvh.build(m);
  SurfaceMesh other = testing::grid(1);
  EXPECT_THROW(bvh.intersectSegment(other, Vector3d(0, 0, 1), Vector3d(0, 0, -1)), CollisionError);
}

}  // namespace
}  // namespace ld::collision

namespace ld::collision {
namespace {

// Cutting opens the mesh with separateEdge/splitVertex: faces move onto new
// vertices without new face handles. The tree must follow.
TEST(TriangleBvh, FollowsSeparatedEdgesAndSplitVertices) {
  SurfaceMesh m = testing::grid(8);
  TriangleBvh bvh(m);
  // Separate the horizontal edges along y = 4 from the left boundary inwards.
  int separated = 0;
  for (int i = 0; i < 5; ++i) {
    const mesh::Vertex p(static_cast<std::uint32_t>(4 * 9 + i)), q(static_cast<std::uint32_t>(4 * 9 + i + 1));
    const mesh::Edge e = m.findEdge(p, q);
    if (!e.isValid() || m.isBoundary(e)) continue;
    separated += m.separateEdge(e).isValid() ? 1 : 0;
  }
  ASSERT_GT(separated, 2);
  ASSERT_TRUE(m.validate().ok()) << m.validate().message();
  // The new copies belong to the faces below the cut: pull them down so the cut opens.
  const std::size_t before = 81;
  std::vector<mesh::Vertex> moved;
  for (std::size_t v = before; v < m.verticesSize(); ++v) {
    m.position(mesh::Vertex(v)) += Vector3d(0, -0.3, -0.5);
    moved.emplace_back(v);
  }
  EXPECT_NE(bvh.sync(m), SyncResult::Unchanged);
  bvh.refitVertices(m, moved);
  EXPECT_EQ(bvh.check(m), "");
  SegmentSource src(21);
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(400));
  // A segment through the opened gap sees exactly what brute force sees.
  const auto hits = bvh.intersectSegment(m, Vector3d(2.5, 3.9, 1), Vector3d(2.5, 3.9, -2));
  EXPECT_TRUE(sameHits(hits, intersectSegment(m, Vector3d(2.5, 3.9, 1), Vector3d(2.5, 3.9, -2))));
}

}  // namespace
}  // namespace ld::collision

namespace ld::collision {
namespace {

// The cheap rejection in front of the exact test must never change an answer:
// random triangles (slivers, tiny and huge ones, shared corners) and segments made
// to touch them at the tolerance's edge (ends on a plane, through corners and
// edges, in the plane, just outside an edge by about the tolerance).
TEST(TriangleBvh, EqualsBruteForceOnATriangleSoupWithAdversarialSegments) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> U(-1.0, 1.0), W(0.0, 1.0);
  SurfaceMesh m;
  std::vector<mesh::Vertex> vs;
  for (int i = 0; i < 300; ++i) {
    const Vector3d c(10 * U(rng), 10 * U(rng), 10 * U(rng));
    const double size = std::pow(10.0, -3.0 + 4.0 * W(rng));
    const Vector3d p0 = c + size * Vector3d(U(rng), U(rng), U(rng));
    Vector3d p1 = c + size * Vector3d(U(rng), U(rng), U(rng));
    Vector3d p2 = c + size * Vector3d(U(rng), U(rng), U(rng));
    if (i % 5 == 0) p2 = p0 + (p1 - p0) * W(rng) + 1e-4 * size * Vector3d(U(rng), U(rng), U(rng));  // sliver
    m.addFace(m.addVertex(p0), m.addVertex(p1), m.addVertex(p2));
  }
  const TriangleBvh bvh(m);
  ASSERT_EQ(bvh.check(m), "");
  const double eps = effectiveTolerance(Tolerance{}, 20.0);
  for (int i = 0; i < testing::scaled(4000); ++i) {
    const Face f(static_cast<std::uint32_t>(rng() % m.facesSize()));
    const auto& fv = m.vertices(f);
    const Vector3d p0 = m.position(fv[0]), p1 = m.position(fv[1]), p2 = m.position(fv[2]);
    const Vector3d n = (p1 - p0).cross(p2 - p0).normalized();
    double u = W(rng), v = W(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;
    Vector3d q = p0 + u * (p1 - p0) + v * (p2 - p0);
    switch (rng() % 6) {
      case 0:
        q = p0;
        break;
      case 1:
        q = p1 + W(rng) * (p2 - p1);
        break;
      case 2: {  // just outside an edge, by a small multiple of the tolerance
        const Vector3d e = p1 - p0, out = e.cross(n).normalized();
        q = p0 + W(rng) * e + (0.5 + 2.0 * W(rng)) * eps * out;
        break;
      }
      default:
        break;
    }
    const Vector3d d = Vector3d(U(rng), U(rng), U(rng)).normalized() * (0.1 + 5 * W(rng));
    Vector3d a = q - W(rng) * d, b = a + d;
    const int kind = static_cast<int>(rng() % 4);
    if (kind == 1) b = q + 1e-3 * eps * n;                                    // ends on the plane (within tol)
    if (kind == 2) a = q + 2 * eps * W(rng) * n, b = q + (p1 - p0) * W(rng);  // nearly in the plane
    if (kind == 3) a = q - (0.9 + 0.2 * W(rng)) * eps * n + d.cross(n), b = q + 3 * eps * n - d.cross(n);
    expectSegmentMatches(m, bvh, a, b);
    if (HasFatalFailure()) return;
  }
}

// The boxes carry a pad for the coordinates they were built at; a mesh moved far
// away (larger relative tolerance) or queried with far-away segments still gives
// the brute-force answer.
TEST(TriangleBvh, MeshMovedFarAwayStillMatchesBruteForce) {
  SurfaceMesh m = testing::icosphere(2, 1.0);
  TriangleBvh bvh(m);
  for (mesh::Vertex v : m.vertices()) m.position(v) += Vector3d(3e5, -2e5, 1e5);
  bvh.refit(m);
  EXPECT_EQ(bvh.check(m), "");
  SegmentSource src(31);
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(400));
}

// Edits between syncs are read from the mesh's journal: local (no rebuild) while
// small, a rebuild after compaction.
TEST(TriangleBvh, SyncReadsTheEditJournalLocally) {
  SurfaceMesh m = testing::slab(10, 1.0, 2.0);
  TriangleBvh bvh(m);
  const std::size_t builds = bvh.stats().builds;
  EXPECT_EQ(bvh.sync(m), SyncResult::Unchanged);
  EXPECT_FALSE(bvh.needsSync(m));
  const Face f(5u);
  const auto& vs = m.vertices(f);
  m.splitFace(f, (m.position(vs[0]) + m.position(vs[1]) + m.position(vs[2])) / 3.0);
  m.splitEdge(m.edges(f)[1],
              m.position(m.vertex(m.edges(f)[1], 0)) * 0.3 + m.position(m.vertex(m.edges(f)[1], 1)) * 0.7);
  EXPECT_TRUE(bvh.needsSync(m));
  EXPECT_EQ(bvh.sync(m), SyncResult::Local);
  EXPECT_EQ(bvh.stats().builds, builds);
  EXPECT_EQ(bvh.check(m), "");
  const Vector3d c = m.centroid(f);
  expectSegmentMatches(m, bvh, c + Vector3d(0, 0, 1), c - Vector3d(0, 0, 3));
  m.deleteFace(Face(0u));
  m.garbageCollection();
  EXPECT_EQ(bvh.sync(m), SyncResult::Rebuilt);
  EXPECT_EQ(bvh.check(m), "");
}

// The active-region refit: only the leaves around the listed vertices (given as
// plain indices, as physics keeps them) and their ancestors are refitted.
TEST(TriangleBvh, RegionRefitFromVertexIndices) {
  SurfaceMesh m = testing::slab(34, 1.0, 2.0);
  ASSERT_GT(m.nFaces(), 4096u);
  TriangleBvh bvh(m);
  std::vector<std::uint32_t> region;
  for (mesh::Vertex v : m.vertices()) {
    Vector3d& p = m.position(v);
    if (p.z() > -0.5 && (p.head<2>() - Eigen::Vector2d(17.0, 17.0)).norm() < 4.0) {
      p.z() += 0.7 + 0.1 * std::sin(p.x());  // lifted, as a grasper pulls
      region.push_back(static_cast<std::uint32_t>(v.idx()));
    }
  }
  ASSERT_GT(region.size(), 20u);
  EXPECT_NE(bvh.check(m), "") << "the lift must leave the old boxes";
  bvh.refitVertices(m, std::span<const std::uint32_t>(region));
  EXPECT_EQ(bvh.check(m), "");
  SegmentSource src(5);
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(100));
  // Vertical segments through the lifted patch only.
  for (double x = 14.2; x < 20.0; x += 0.77) {
    expectSegmentMatches(m, bvh, Vector3d(x, 17.3, 1.0), Vector3d(x, 17.3, 0.3));
    EXPECT_FALSE(bvh.intersectSegment(m, Vector3d(x, 17.3, 1.0), Vector3d(x, 17.3, 0.3)).empty());
  }
  // The full refit gives the same answers and the same invariants.
  bvh.refit(m);
  EXPECT_EQ(bvh.check(m), "");
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(50));
}

// Separation as the cutter does it: the mesh (and its tree) copied, each copy cut
// down to one component and compacted; remap() renumbers the kept faces through the
// compaction maps instead of rebuilding (a small piece is rebuilt: cheap).
TEST(TriangleBvh, RemapAfterCompactionKeepsTheTree) {
  SurfaceMesh m = testing::grid(46);  // 4232 faces: Morton-order build
  // Cut a column of faces out: two components (x < 30 and x > 31).
  for (Face f : m.faces()) {
    const auto& vs = m.vertices(f);
    const double cx = (m.position(vs[0]).x() + m.position(vs[1]).x() + m.position(vs[2]).x()) / 3.0;
    if (cx > 30.0 && cx < 31.0) m.deleteFace(f);
  }
  TriangleBvh bvh(m);
  ASSERT_EQ(bvh.sync(m), SyncResult::Unchanged);
  const mesh::Components comp = m.connectedComponents();
  ASSERT_EQ(comp.count, 2);
  SurfaceMesh piece = m;
  TriangleBvh pieceTree = bvh;
  const auto keep = [&](SurfaceMesh& mm, int label) {
    for (Face f : mm.faces())
      if (comp.faceLabel[f.idx()] != label) mm.deleteFace(f);
    for (mesh::Vertex v : mm.vertices())
      if (mm.isIsolated(v)) mm.deleteVertex(v);
  };
  std::size_t n0 = 0;
  for (Face f : m.faces()) n0 += comp.faceLabel[f.idx()] == 0 ? 1 : 0;
  const int big = 2 * n0 > m.nFaces() ? 0 : 1;  // two thirds of the faces
  keep(m, big);
  // An edit the tree has not seen yet, just before the compaction.
  Face split;
  for (Face f : m.faces()) {
    split = f;
    if (f.idx() > 500) break;
  }
  const auto& sv = m.vertices(split);
  m.splitFace(split, (m.position(sv[0]) + m.position(sv[1]) + m.position(sv[2])) / 3.0);
  const mesh::Compaction c = m.garbageCollection();
  ASSERT_TRUE(m.validate().ok());
  EXPECT_EQ(bvh.remap(m, c), SyncResult::Local);
  EXPECT_EQ(bvh.stats().builds, 1u) << "the parent keeps its tree";
  EXPECT_EQ(bvh.check(m), "");
  EXPECT_EQ(bvh.sync(m), SyncResult::Unchanged);
  SegmentSource src(8);
  expectBvhMatchesBruteForce(m, bvh, src, testing::scaled(150));

  keep(piece, 1 - big);
  const mesh::Compaction pc = piece.garbageCollection();
  EXPECT_EQ(pieceTree.remap(piece, pc), SyncResult::Rebuilt) << "a third of the faces: its own tree";
  EXPECT_EQ(pieceTree.check(piece), "");
  expectBvhMatchesBruteForce(piece, pieceTree, src, testing::scaled(100));

  // A compaction that drops little: the tree is renumbered, still exact after edits.
  SurfaceMesh m2 = testing::slab(34, 1.0, 2.0);
  TriangleBvh t2(m2);
  const Face f0(100u);
  const auto& v0 = m2.vertices(f0);
  m2.splitFace(f0, (m2.position(v0[0]) + m2.position(v0[1]) + m2.position(v0[2])) / 3.0);
  ASSERT_EQ(t2.sync(m2), SyncResult::Local);
  const mesh::Compaction c2 = m2.garbageCollection();
  EXPECT_EQ(t2.remap(m2, c2), SyncResult::Local);
  EXPECT_EQ(t2.check(m2), "");
  // A second remap with the same (now stale) maps changes nothing.
  EXPECT_EQ(t2.remap(m2, c2), SyncResult::Unchanged);
  EXPECT_EQ(t2.check(m2), "");
  expectBvhMatchesBruteForce(m2, t2, src, testing::scaled(50));
}

}  // namespace
}  // namespace ld::collision
