#include "sim/collision/point_triangle.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "tests/sim/collision/test_meshes.h"

namespace ld::collision {
namespace {

using Eigen::Vector3d;

// q is the nearest point of a triangle to p exactly when q lies in the triangle and
// no corner v is on p's side of the plane through q square to p - q:
// (p - q) . (v - q) <= 0 (the triangle is convex, the product linear in v).
void expectNearest(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c, const Vector3d& q) {
  const double scale = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm(), (p - a).norm(), 1.0});
  const double tol = 1e-9 * scale * scale;
  // In the triangle: on its plane and on the inner side of each edge (within tol).
  const Vector3d n = (b - a).cross(c - a);
  if (n.norm() > 1e-9 * scale * scale) {
    const Vector3d u = n.normalized();
    EXPECT_NEAR((q - a).dot(u), 0.0, 1e-9 * scale);
    const Vector3d corners[3] = {a, b, c};
    for (int i = 0; i < 3; ++i) {
      const Vector3d& x = corners[i];
      const Vector3d& y = corners[(i + 1) % 3];
      EXPECT_GE((y - x).cross(q - x).dot(u), -1e-9 * scale * (y - x).norm()) << "edge " << i;
    }
  }
  for (const Vector3d& v : {a, b, c}) EXPECT_LE((p - q).dot(v - q), tol) << "corner " << v.transpose();
}

TEST(PointTriangle, SegmentNearestPointIsClampedToItsEnds) {
  const Vector3d a(1, 0, 0), b(3, 0, 0);
  EXPECT_NEAR((closestPointOnSegment(Vector3d(2.5, 4, -1), a, b) - Vector3d(2.5, 0, 0)).norm(), 0.0, 1e-15);
  EXPECT_NEAR((closestPointOnSegment(Vector3d(-2, 1, 0), a, b) - a).norm(), 0.0, 1e-15);
  EXPECT_NEAR((closestPointOnSegment(Vector3d(5, 0, 3), a, b) - b).norm(), 0.0, 1e-15);
  EXPECT_NEAR((closestPointOnSegment(Vector3d(5, 0, 3), a, a) - a).norm(), 0.0, 1e-15);  // no length
}

TEST(PointTriangle, EachRegionOfTheUnitTriangle) {
  const Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  struct Case {
    Vector3d p, q;
  };
  const Case cases[] = {
      {{-1, -1, 2}, a},                 // corner a
      {{2, -0.5, -1}, b},               // corner b
      {{-0.2, 3, 0.5}, c},              // corner c
      {{0.5, -2, 1}, {0.5, 0, 0}},      // edge ab
      {{-3, 0.25, 0}, {0, 0.25, 0}},    // edge ca
      {{1, 1, 7}, {0.5, 0.5, 0}},       // edge bc
      {{0.2, 0.3, -4}, {0.2, 0.3, 0}},  // inside
  };
  for (const Case& k : cases) {
    const Vector3d q = closestPointOnTriangle(k.p, a, b, c);
    EXPECT_NEAR((q - k.q).norm(), 0.0, 1e-12) << "p " << k.p.transpose();
    expectNearest(k.p, a, b, c, q);
  }
}

TEST(PointTriangle, RandomAndNeedleTrianglesMeetTheNearestPointCondition) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  auto rv = [&] { return Vector3d(U(rng), U(rng), U(rng)); };
  const int n = testing::scaled(200000);
  for (int i = 0; i < n; ++i) {
    Vector3d a = rv(), b = rv(), c = rv();
    if (i % 4 == 1) c = a + (b - a) * (0.5 + 0.5 * U(rng)) + 1e-4 * rv();  // needle
    if (i % 4 == 2) c = b + 1e-3 * rv();                                   // short side
    const Vector3d p = 3.0 * rv();
    const Vector3d q = closestPointOnTriangle(p, a, b, c);
    ASSERT_TRUE(q.allFinite());
    SCOPED_TRACE(i);
    expectNearest(p, a, b, c, q);
    if (::testing::Test::HasFailure()) return;
  }
}

TEST(PointTriangle, TriangleWithoutAreaGivesTheNearestPointOfItsSides) {
  const Vector3d a(0, 0, 0), b(2, 0, 0), c(1, 0, 0);  // on a line
  EXPECT_NEAR((closestPointOnTriangle(Vector3d(1.5, 1, 0), a, b, c) - Vector3d(1.5, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((closestPointOnTriangle(Vector3d(3, 0, 1), a, b, c) - b).norm(), 0.0, 1e-12);
  EXPECT_NEAR((closestPointOnTriangle(Vector3d(-1, 0, 0), a, a, a) - a).norm(), 0.0, 1e-12);
}

TEST(PointTriangle, NearestOnSurfaceIsTheNearestFaceWithinTheRadius) {
  mesh::SurfaceMesh m;
  testing::addGrid(m, 8, 1.0, 0.0);
  const TriangleBvh bvh(m);
  std::vector<mesh::Face> scratch;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1.0, 9.0);
  for (int i = 0; i < 2000; ++i) {
    const Vector3d p(U(rng), U(rng), 0.25 * U(rng));
    double brute = std::numeric_limits<double>::infinity();
    for (const mesh::Face f : m.faces()) {
      const auto& v = m.vertices(f);
      brute =
          std::min(brute, (closestPointOnTriangle(p, m.position(v[0]), m.position(v[1]), m.position(v[2])) - p).norm());
    }
    for (const double radius : {0.1, 0.5, 2.0}) {
      const NearestOnSurface near = nearestOnSurface(m, bvh, p, radius, scratch);
      if (brute <= radius) {
        EXPECT_NEAR(near.distance, brute, 1e-12) << p.transpose() << " radius " << radius;
        ASSERT_TRUE(near.face.isValid());
        const auto& v = m.vertices(near.face);
        EXPECT_NEAR(
            (closestPointOnTriangle(p, m.position(v[0]), m.position(v[1]), m.position(v[2])) - near.point).norm(), 0.0,
            1e-12);
        EXPECT_NEAR((near.point - p).norm(), near.distance, 1e-12);
      } else {
        EXPECT_EQ(near.distance, std::numeric_limits<double>::infinity()) << p.transpose() << " radius " << radius;
        EXPECT_FALSE(near.face.isValid());
      }
    }
  }
}

}  // namespace
}  // namespace ld::collision
