#include "app/gui/orbit_camera.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/test_support.h"

namespace {

using ld::gui::OrbitCamera;
using ld::test::near;

// Window coordinates (pixels, y down) of a world point.
QPointF project(const OrbitCamera& c, const QVector3D& p, float w, float h) {
  const QVector3D ndc = (c.projection(w / h) * c.view()).map(p);
  return {(ndc.x() + 1.0) * 0.5 * w, (1.0 - ndc.y()) * 0.5 * h};
}

TEST(OrbitCamera, FitFramesEveryCornerOfTheBox) {
  const QVector3D lo(-40, -30, -2.5), hi(40, 30, 2.5);
  for (const float aspect : {0.5F, 1.0F, 1.6F, 3.0F}) {
    OrbitCamera c;
    c.fit(lo, hi, aspect);
    EXPECT_TRUE(near(c.target().x(), 0.0, 1e-5));
    EXPECT_TRUE(near(c.target().z(), 0.0, 1e-5));
    for (int k = 0; k < 8; ++k) {
      const QVector3D p(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
      const QVector3D ndc = (c.projection(aspect) * c.view()).map(p);
      EXPECT_LT(std::abs(ndc.x()), 1.0F) << "aspect " << aspect << " corner " << k;
      EXPECT_LT(std::abs(ndc.y()), 1.0F) << "aspect " << aspect << " corner " << k;
      EXPECT_LT(std::abs(ndc.z()), 1.0F) << "inside the depth range";
    }
  }
}

TEST(OrbitCamera, FitIsTightNotArbitrarilyFar) {
  OrbitCamera c;
  c.fit(QVector3D(-1, -1, -1), QVector3D(1, 1, 1), 1.0F);
  // Bounding sphere radius sqrt(3) seen under half the 35 degree field of view.
  const double expected = std::sqrt(3.0) / std::sin(17.5 * M_PI / 180.0);
  EXPECT_GT(c.distance(), expected * 0.99);
  EXPECT_LT(c.distance(), expected * 1.2);
}

TEST(OrbitCamera, OrbitKeepsTargetAndDistanceAndClampsPitch) {
  OrbitCamera c;
  c.fit(QVector3D(-1, -1, -1), QVector3D(1, 1, 1), 1.0F);
  const QVector3D eye0 = c.eye();
  c.orbit(100, 0);
  EXPECT_TRUE(near(c.yawDegrees(), -130.0, 1e-4));
  EXPECT_TRUE(near((c.eye() - c.target()).length(), c.distance(), 1e-3));
  EXPECT_GT((c.eye() - eye0).length(), 0.1F);
  c.orbit(0, 10000);
  EXPECT_TRUE(near(c.pitchDegrees(), 89.0, 1e-6));
  c.orbit(0, -100000);
  EXPECT_TRUE(near(c.pitchDegrees(), -89.0, 1e-6));
  EXPECT_TRUE(std::isfinite(c.view()(0, 0)));
}

TEST(OrbitCamera, PanMovesTheTargetPointWithTheCursor) {
  OrbitCamera c;
  c.fit(QVector3D(-40, -30, -2.5), QVector3D(40, 30, 2.5), 1.5F);
  const float w = 900, h = 600;
  const QVector3D p = c.target();
  const QPointF before = project(c, p, w, h);
  c.pan(30, -20, h);
  const QPointF after = project(c, p, w, h);
  // The world point that was under the cursor moves with the drag.
  EXPECT_TRUE(near(after.x() - before.x(), 30.0, 0.05));
  EXPECT_TRUE(near(after.y() - before.y(), -20.0, 0.05));
  // Panning moves in the view plane: the distance along the view axis is kept.
  EXPECT_TRUE(near(QVector3D::dotProduct(c.target() - p, c.forward()), 0.0, 1e-4));
}

TEST(OrbitCamera, ZoomChangesDistanceGeometrically) {
  OrbitCamera c;
  const float d0 = c.distance();
  c.zoom(1);
  EXPECT_TRUE(near(c.distance(), 0.85 * d0, 1e-3));
  c.zoom(-2);
  EXPECT_TRUE(near(c.distance(), d0 / 0.85, 1e-3));
}

TEST(OrbitCamera, RayThroughAPixelHitsWhatProjectsThere) {
  OrbitCamera c;
  c.fit(QVector3D(-40, -30, -2.5), QVector3D(40, 30, 2.5), 1.5F);
  const float w = 900, h = 600;
  EXPECT_TRUE(
      ld::test::nearVec(Eigen::Vector3f(c.rayDirection(w / 2, h / 2, w, h).x(), c.rayDirection(w / 2, h / 2, w, h).y(),
                                        c.rayDirection(w / 2, h / 2, w, h).z()),
                        Eigen::Vector3f(c.forward().x(), c.forward().y(), c.forward().z()), 1e-5));
  const QVector3D ray = c.rayDirection(100, 450, w, h);
  const QVector3D point = c.eye() + 120.0F * ray;
  const QPointF px = project(c, point, w, h);
  EXPECT_TRUE(near(px.x(), 100.0, 0.05));
  EXPECT_TRUE(near(px.y(), 450.0, 0.05));
}

}  // namespace
