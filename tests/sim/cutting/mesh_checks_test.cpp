#include "sim/cutting/mesh_checks.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace ld::cutting {
namespace {

using Vec3 = Eigen::Vector3d;

// The smallest height as the cutter's flips test it: |ab × ac|² < h² L².
bool thin(const Vec3& a, const Vec3& b, const Vec3& c, double h) {
  const Vec3 ab = b - a, ac = c - a;
  const double L2 = std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
  return ab.cross(ac).squaredNorm() < h * h * L2;
}

// thinRoom is negative exactly for a thin triangle, and moving every corner by up to
// the room it gives (random directions, and the flattening one: the corner opposite
// the longest edge toward it, the edge's ends toward that corner) never makes a
// triangle thin; on an equilateral triangle the room is within 2.42x of the true limit.
TEST(ThinRoom, CornersMovedWithinTheRoomNeverMakeTheTriangleThin) {
  const double h = 0.025;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  auto unit = [&] {
    Vec3 d(U(rng), U(rng), U(rng));
    return Vec3(d.norm() > 1e-9 ? Vec3(d.normalized()) : Vec3::UnitX());
  };
  int rooms = 0, thins = 0;
  for (int i = 0; i < 20000; ++i) {
    const double s = std::pow(10.0, 2.0 * U(rng));  // 0.01 .. 100 mm
    std::array<Vec3, 3> p{s * Vec3(U(rng), U(rng), U(rng)), s * Vec3(U(rng), U(rng), U(rng)),
                          s * Vec3(U(rng), U(rng), U(rng))};
    if (i % 4 == 0) p[2] = 0.5 * (p[0] + p[1]) + 0.05 * s * U(rng) * unit();  // near-degenerate
    const double r = thinRoom(p[0], p[1], p[2], h);
    ASSERT_EQ(r < 0.0, thin(p[0], p[1], p[2], h)) << i;
    if (r < 0.0) {
      ++thins;
      continue;
    }
    ++rooms;
    // Random moves within the room.
    for (int k = 0; k < 4; ++k) {
      std::array<Vec3, 3> q = p;
      for (Vec3& x : q) x += r * std::abs(U(rng)) * unit();
      ASSERT_FALSE(thin(q[0], q[1], q[2], h)) << i << " room " << r;
    }
    // The flattening move, at the full room.
    int apex = 0;
    double longest = -1.0;
    for (int j = 0; j < 3; ++j)
      if (const double l = (p[(j + 2) % 3] - p[(j + 1) % 3]).norm(); l > longest) longest = l, apex = j;
    const Vec3 &A = p[apex], &E0 = p[(apex + 1) % 3], &E1 = p[(apex + 2) % 3];
    const Vec3 e = (E1 - E0).normalized();
    Vec3 n = (A - E0) - (A - E0).dot(e) * e;
    if (n.norm() > 0.0) {
      n.normalize();
      std::array<Vec3, 3> q = p;
      q[apex] -= r * n;
      q[(apex + 1) % 3] += r * n;
      q[(apex + 2) % 3] += r * n;
      ASSERT_FALSE(thin(q[0], q[1], q[2], h)) << i << " room " << r;
    }
  }
  EXPECT_GT(rooms, 1000);
  EXPECT_GT(thins, 100);
  // Equilateral, side 1: thin once flattened by (0.866 - h) / 2 = 0.42 (and past 0.433
  // it turns over); the room is 0.177 (the bound takes any move), so 2.42x the room
  // flattens it under h.
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0.5, std::sqrt(3.0) / 2.0, 0);
  const double r = thinRoom(a, b, c, h);
  EXPECT_GT(r, 0.15);
  EXPECT_FALSE(thin(a + Vec3(0, r, 0), b + Vec3(0, r, 0), c - Vec3(0, r, 0), h));
  const double f = 2.42 * r;
  EXPECT_TRUE(thin(a + Vec3(0, f, 0), b + Vec3(0, f, 0), c - Vec3(0, f, 0), h));
  EXPECT_EQ(thinRoom(a, b, Vec3(0.5, 0.01, 0), h), -1.0);
}

}  // namespace
}  // namespace ld::cutting
