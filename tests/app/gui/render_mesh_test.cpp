#include "app/gui/render_mesh.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/test_support.h"

namespace {

using ld::gui::buildCornerBuffer;
using ld::gui::kFloatsPerCorner;
using ld::gui::RenderMesh;
using ld::test::near;

// Unit cube, outward counter-clockwise faces.
RenderMesh cube() {
  RenderMesh m;
  for (int k = 0; k < 8; ++k) m.positions.push_back({float(k & 1), float((k >> 1) & 1), float((k >> 2) & 1)});
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

std::array<float, 3> normalAt(const std::vector<float>& buf, std::size_t corner) {
  return {buf[corner * kFloatsPerCorner + 3], buf[corner * kFloatsPerCorner + 4], buf[corner * kFloatsPerCorner + 5]};
}

TEST(RenderMesh, BoundsCoverReferencedVerticesOnly) {
  RenderMesh m = cube();
  m.positions.push_back({100, 100, 100});  // unreferenced
  const auto b = m.bounds();
  EXPECT_FALSE(b.empty());
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(b.min[a], 0.0F);
    EXPECT_EQ(b.max[a], 1.0F);
  }
  EXPECT_TRUE(RenderMesh{}.bounds().empty());
}

TEST(RenderMesh, CreasesKeepFaceNormalsOnACube) {
  const RenderMesh m = cube();
  const auto buf = buildCornerBuffer(m);
  ASSERT_EQ(buf.size(), m.triangles.size() * 3 * kFloatsPerCorner);
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    // Every corner of a cube face gets that face's axis normal, not a corner average.
    const auto n0 = normalAt(buf, 3 * f);
    for (int c = 0; c < 3; ++c) {
      const auto n = normalAt(buf, 3 * f + static_cast<std::size_t>(c));
      EXPECT_TRUE(near(std::abs(n[0]) + std::abs(n[1]) + std::abs(n[2]), 1.0, 1e-6)) << "face " << f;
      for (int a = 0; a < 3; ++a) EXPECT_TRUE(near(n[a], n0[a], 1e-6));
    }
    // ...pointing outward: the normal's sign matches the face's position.
    const auto& p = m.positions[m.triangles[f][0]];
    for (int a = 0; a < 3; ++a) {
      if (std::abs(n0[a]) > 0.5F) {
        EXPECT_EQ(n0[a] > 0, p[a] > 0.5F) << "face " << f;
      }
    }
  }
  // Positions are copied through.
  EXPECT_EQ(buf[0], m.positions[m.triangles[0][0]][0]);
}

TEST(RenderMesh, SmoothSurfaceSharesAveragedNormals) {
  // A shallow roof: two faces 10 degrees apart share the ridge normal (within crease).
  RenderMesh m;
  const float h = std::tan(10.0F * 3.14159265F / 180.0F);
  m.positions = {{0, 0, 0}, {1, 0, h}, {1, 1, h}, {0, 1, 0}, {2, 0, 0}, {2, 1, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 4, 5}, {1, 5, 2}};
  const auto buf = buildCornerBuffer(m);
  // Vertex 1 appears in face 0 (corner 1) and face 2 (corner 0): same smooth normal.
  const auto a = normalAt(buf, 1), b = normalAt(buf, 6);
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(near(a[k], b[k], 1e-6));
  // Area-weighted: one left face (tilted -x) and two right faces (tilted +x) of equal
  // area around vertex 1 give (s, 0, 3c) normalised, s, c = sin, cos 10 degrees.
  const double s = std::sin(10.0 * M_PI / 180.0), c = std::cos(10.0 * M_PI / 180.0);
  EXPECT_TRUE(near(a[0], s / std::sqrt(s * s + 9 * c * c), 1e-5));
  EXPECT_TRUE(near(a[1], 0.0, 1e-6));
  // A vertex on only the left face keeps the left face's tilt.
  EXPECT_LT(normalAt(buf, 0)[0], -0.1F);
}

TEST(RenderMesh, DegenerateFaceGetsAFiniteNormal) {
  RenderMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  m.triangles = {{0, 1, 2}};
  const auto buf = buildCornerBuffer(m);
  for (float x : buf) EXPECT_TRUE(std::isfinite(x));
  EXPECT_TRUE(near(normalAt(buf, 0)[2], 1.0, 1e-6));
}

}  // namespace
