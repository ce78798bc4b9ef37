#include "sim/collision/walk.h"

#include <algorithm>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "tests/sim/collision/test_meshes.h"
#include "tests/support/test_support.h"

namespace ld::collision {
namespace {

using Eigen::Vector3d;
using mesh::Face;

bool sharesVertex(const mesh::SurfaceMesh& m, Face f, Face g) {
  for (auto v : m.vertices(f))
    for (auto w : m.vertices(g))
      if (v == w) return true;
  return false;
}

TEST(Walk, NeighbourhoodIsTheFaceThenEveryFaceSharingAVertexOnce) {
  const auto m = testing::grid(6);
  for (Face f : m.faces()) {
    std::vector<Face> n;
    faceNeighbourhood(m, f, n);
    ASSERT_FALSE(n.empty());
    EXPECT_EQ(n[0], f);
    std::set<Face> unique(n.begin(), n.end());
    EXPECT_EQ(unique.size(), n.size());
    std::set<Face> expected;
    for (Face g : m.faces())
      if (sharesVertex(m, f, g)) expected.insert(g);
    EXPECT_EQ(unique, expected);
  }
  std::vector<Face> n;
  faceNeighbourhood(m, Face(2u * 6u * 3u + 6u), n);  // an interior face of a diagonal grid
  EXPECT_EQ(n.size(), 13u);
}

TEST(Walk, NeighbourhoodQueryFindsTheMovedContact) {
  const auto m = testing::grid(6);
  const auto first = intersectSegment(m, Vector3d(2.3, 2.6, 1), Vector3d(2.3, 2.6, -1));
  ASSERT_EQ(first.size(), 1u);
  std::vector<SurfaceHit> next;
  intersectNeighbourhood(m, first[0].face, Vector3d(2.9, 2.2, 1), Vector3d(2.9, 2.2, -1), next);
  const auto brute = intersectSegment(m, Vector3d(2.9, 2.2, 1), Vector3d(2.9, 2.2, -1));
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].face, brute[0].face);
  EXPECT_TRUE(ld::test::nearVec(next[0].point, Vector3d(2.9, 2.2, 0), 1e-12));
  // Far away: not in the neighbourhood (the walk is local by design).
  intersectNeighbourhood(m, first[0].face, Vector3d(5.5, 5.2, 1), Vector3d(5.5, 5.2, -1), next);
  EXPECT_TRUE(next.empty());
}

TEST(Walk, WalkAcrossEdgesReachesTheHitOfBruteForce) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> U(0.1, 9.9);
  const auto m = testing::grid(10);
  for (int i = 0; i < testing::scaled(200); ++i) {
    const Vector3d p(U(rng), U(rng), 0.0), tilt(0.3 * (U(rng) - 5) / 5, 0.3 * (U(rng) - 5) / 5, 0.0);
    const Vector3d a = p + Vector3d(0, 0, 1) + tilt, b = p - Vector3d(0, 0, 1) - tilt;
    const auto brute = intersectSegment(m, a, b);
    ASSERT_EQ(brute.size(), 1u);
    const Face start(static_cast<std::uint32_t>(rng() % m.facesSize()));
    const auto hit = walkToHit(m, start, a, b);
    ASSERT_TRUE(hit.has_value()) << i;
    EXPECT_TRUE(ld::test::nearVec(hit->point, brute[0].point, 1e-12));
    // A segment that stops short of the sheet: the walk ends without a hit.
    EXPECT_FALSE(walkToHit(m, start, a, Vector3d(a + 0.4 * (b - a))).has_value());
  }
  // On a closed sphere the walk reaches one of the two crossings.
  const auto s = testing::icosphere(3);
  const Vector3d a(0.2, 0.1, 3), b(0.2, 0.1, -3);
  const auto brute = intersectSegment(s, a, b);
  ASSERT_EQ(brute.size(), 2u);
  const auto hit = walkToHit(s, Face(0u), a, b);
  ASSERT_TRUE(hit.has_value());
  EXPECT_TRUE(hit->face == brute[0].face || hit->face == brute[1].face);
}

}  // namespace
}  // namespace ld::collision
