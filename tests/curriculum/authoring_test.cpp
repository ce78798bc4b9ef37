#include "curriculum/authoring.h"
#include "curriculum/metrics/metrics.h"

#include <cmath>

#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

using V = Eigen::Vector3d;

// A tent: two planes meeting at a ridge along y at x = 2 (z = 2 - |x - 2|), x in [0, 4].
mesh::SurfaceMesh tent() {
  mesh::SurfaceMesh m;
  std::vector<mesh::Vertex> v;
  const int n = 8;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = 4.0 * i / n, y = 4.0 * j / n;
      v.push_back(m.addVertex(V(x, y, 2 - std::abs(x - 2))));
    }
  auto id = [&](int i, int j) { return v[static_cast<std::size_t>(j * (n + 1) + i)]; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.addFace(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      m.addFace(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  return m;
}

TEST(Authoring, CastRayFindsTheNearestHit) {
  const mesh::SurfaceMesh m = tent();
  double t = 0;
  auto hit = castRay(m, Ray{V(1.0, 1.3, 10), V(0, 0, -1)}, &t);
  ASSERT_TRUE(hit.has_value());
  EXPECT_TRUE(test::nearVec(position(m, *hit), V(1.0, 1.3, 1.0), 1e-9));
  EXPECT_TRUE(test::near(t, 9.0, 1e-9));
  // From below the surface upward: the first hit is still the surface.
  hit = castRay(m, Ray{V(3.0, 2.0, -5), V(0, 0, 2)}, &t);
  ASSERT_TRUE(hit.has_value());
  EXPECT_TRUE(test::near(position(m, *hit).z(), 1.0, 1e-9));
  EXPECT_TRUE(test::near(t, 3.0, 1e-9));  // in units of dir (length 2)
  EXPECT_FALSE(castRay(m, Ray{V(9, 9, 10), V(0, 0, -1)}).has_value());
}

TEST(Authoring, ProjectResampleSmoothSnap) {
  const mesh::SurfaceMesh m = tent();
  std::vector<Ray> rays;
  for (int k = 0; k <= 10; ++k) rays.push_back({V(0.2 + 0.36 * k, 2.0 + (k % 2 ? 0.1 : -0.1), 10), V(0, 0, -1)});
  rays.insert(rays.begin() + 5, Ray{V(20, 2, 10), V(0, 0, -1)});  // a miss splits the path
  const Polyline p = projectOntoSurface(m, rays);
  ASSERT_EQ(p.size(), 11u);
  EXPECT_EQ(pieces(p).size(), 2u);
  for (const auto& q : p) EXPECT_TRUE(test::near(q.p.z(), 2 - std::abs(q.p.x() - 2), 1e-9));

  const Polyline one = projectOntoSurface(m, std::vector<Ray>(rays.begin(), rays.begin() + 5));
  const Polyline r = resamplePath(one, 0.25);
  for (std::size_t i = 1; i < r.size(); ++i) EXPECT_LE((r[i].p - r[i - 1].p).norm(), 0.25 + 1e-9);
  EXPECT_TRUE(test::nearVec(r.front().p, one.front().p, 1e-12));
  EXPECT_TRUE(test::nearVec(r.back().p, one.back().p, 1e-12));
  // Points on the projected polyline, evenly spread (chords cut the corners a little).
  for (const auto& q : r) EXPECT_LT(distanceToPath(q.p, one), 1e-9);
  EXPECT_TRUE(test::near(piecesLength(r), piecesLength(one), 0.0, 0.03));

  // Smoothing takes out the zigzag (shorter path), ends fixed; snapping puts it back on.
  const Polyline s = snapToSurface(m, smoothPath(r, 20, 0.5));
  EXPECT_LT(piecesLength(s), piecesLength(r));
  EXPECT_TRUE(test::nearVec(s.front().p, r.front().p, 1e-9));
  EXPECT_TRUE(test::nearVec(s.back().p, r.back().p, 1e-9));
  for (const auto& q : s) EXPECT_TRUE(test::near(q.p.z(), 2 - std::abs(q.p.x() - 2), 1e-9));
}

}  // namespace
}  // namespace ld::curriculum
